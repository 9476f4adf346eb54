"""Virtual fixtures: where points are relative to a safety pipe, and where a tool
path leaves it.

:func:`locate` answers, for an unordered cloud of points, everything a fixture
controller asks per point in one vectorized call: inside or not, the signed
distance to the pipe's wall, the nearest point of the centreline, its arc
length and the tangent there. The pipe is the chain of round cones through
its ring vertices (the same solid :meth:`CollisionWorld.inside` and the
collision checks use). A KD-tree over the centreline segments' midpoints
gives each point a few candidate segments; a point whose best candidate is
nearer than any other segment could be (the K-th midpoint's distance less
half the longest segment, and less the largest radius for the wall) is
answered from them, the rare rest against every segment -- so the answer is
exact, not a nearest-vertex approximation.

:func:`containment` is the ordered tool-path question. The points themselves are
classified by their signed distance to the pipe's
ball chain. The path between them matters too (a straight move can cut a bend
while both ends are inside), so each path segment is intersected with every
nearby unit: the signed distance of a convex unit is convex along a line, so
each intersection is one interval of the segment, found by golden-section
search and bisection. The segment stays inside exactly when its intervals
cover it; the first gap is where the path leaves the pipe.
"""

from dataclasses import dataclass

import numpy as np

from cadpipe._validate import as_points
from cadpipe.collision.capsules import BATCH, round_cone_distance
from cadpipe.errors import InputError

#: candidate segments per point from the KD-tree
CANDIDATES = 8
#: how many times more candidates the unsure points get before the exhaustive check
WIDER = 4
#: consecutive units per bounding ball of the exactness check
GROUP = 16
#: points per vectorized block of :func:`locate` (bounds the temporaries' memory)
BLOCK = 1 << 15
#: golden-section steps and bisection steps (each shrinks the bracket below 1e-12)
GOLDEN_STEPS = 60
BISECTION_STEPS = 42


@dataclass(frozen=True)
class PipeContainment:
    """Result of :meth:`CollisionWorld.inside` for a polyline of points.

    ``inside`` and ``signed_distance`` are per point (negative inside). The path
    first leaves the pipe on segment ``exit_segment`` (from point ``k`` to
    ``k + 1``) at ``exit_fraction`` along it, at ``exit_point``; all three are
    None when the whole path stays inside. A first point outside the pipe is an
    exit at segment 0, fraction 0.
    """

    inside: np.ndarray
    signed_distance: np.ndarray
    exit_segment: int
    exit_fraction: float
    exit_point: np.ndarray

    @property
    def all_inside(self):
        return self.exit_segment is None


@dataclass(frozen=True)
class PipeLocation:
    """Result of :func:`locate` for ``M`` points, per point.

    Attributes
    ----------
    inside : (M,) bool
        Within the pipe's wall (signed distance <= 0).
    signed_distance : (M,) float
        To the wall, negative inside (length units).
    nearest : (M, 3) float
        The nearest point of the centreline.
    arc_length : (M,) float
        Of ``nearest``, along the centreline from its first point.
    tangent : (M, 3) float
        Unit direction of the centreline at ``nearest`` (zero for a pipe of one
        point).
    segment : (M,) int
        The centreline segment ``nearest`` lies on (from point ``k`` to ``k + 1``).
    """

    inside: np.ndarray
    signed_distance: np.ndarray
    nearest: np.ndarray
    arc_length: np.ndarray
    tangent: np.ndarray
    segment: np.ndarray


class _Centreline:
    """A pipe's units with the KD-tree over their midpoints, built once per pipe."""

    def __init__(self, chain):
        from scipy.spatial import cKDTree

        self.a, self.b = chain.starts, chain.ends
        self.ra, self.rb = chain.start_radii, chain.end_radii
        axis = self.b - self.a
        self.length = np.linalg.norm(axis, axis=1)
        self.tangent = axis / np.where(self.length > 0, self.length, 1.0)[:, None]
        self.start_arc = np.concatenate([[0.0], np.cumsum(self.length)[:-1]])
        self.tree = cKDTree(0.5 * (self.a + self.b))
        self.half = 0.5 * float(self.length.max())
        self.radius = float(max(self.ra.max(), self.rb.max()))
        self.uniform = bool(np.all(self.ra == self.radius) and np.all(self.rb == self.radius))
        # a ball around each group of GROUP consecutive segments, and its largest radius
        count = -(-len(self.a) // GROUP)
        centre, ball, radius = [], [], []
        for g in range(count):
            span = np.concatenate([self.a[g * GROUP:(g + 1) * GROUP],
                                   self.b[g * GROUP:(g + 1) * GROUP]])
            c = 0.5 * (span.min(axis=0) + span.max(axis=0))
            centre.append(c)
            ball.append(np.linalg.norm(span - c, axis=1).max())
            radius.append(max(self.ra[g * GROUP:(g + 1) * GROUP].max(),
                              self.rb[g * GROUP:(g + 1) * GROUP].max()))
        self.group_centre, self.group_ball = np.array(centre), np.array(ball)
        self.group_radius = np.array(radius)

    def project(self, points, units):
        """Per point and candidate unit ``(M, K)``: the centreline distance, the
        segment parameter and the wall's signed distance."""
        a = self.a[units]
        axis = self.b[units] - a
        rel = points[:, None] - a
        lengths = self.length[units]
        t = np.clip(np.einsum("mki,mki->mk", rel, axis) / np.where(lengths > 0, lengths,
                                                                    1.0) ** 2, 0.0, 1.0)
        off = rel - t[..., None] * axis
        centreline = np.sqrt(np.einsum("mki,mki->mk", off, off))
        if self.uniform:          # capsules of one radius: the wall is r out from the line
            return centreline, t, centreline - self.radius
        wall = round_cone_distance(points[:, None], a, self.b[units], self.ra[units],
                                   self.rb[units])
        return centreline, t, wall


def _pipe_chain(pipe, transform):
    from cadpipe.collision.bodies import as_body
    from cadpipe.geometry.pipe import Pipe

    if not isinstance(pipe, Pipe):
        raise InputError(f"locate(pipe, points): expected a cadpipe Pipe, got "
                         f"{type(pipe).__name__}", key="pipe")
    chain = as_body(pipe, "pipe").chain
    if transform is not None:
        from cadpipe.collision.world import as_pose

        chain = chain.moved(as_pose(transform, "pipe"))
    return chain


def locate(pipe, points, transform=None):
    """Where each of ``points`` is relative to ``pipe``, in one vectorized call.

    Parameters
    ----------
    pipe : Pipe
        The safety pipe (its ball chain through the ring vertices is the solid).
    points : (M, 3) array
        Query points, in any order (length units of the pipe).
    transform : (4, 4) array, optional
        Where the pipe stands (rigid); the identity by default.

    Returns
    -------
    PipeLocation
    """
    points = as_points(points, "points")
    line = _Centreline(_pipe_chain(pipe, transform))
    count = len(line.a)
    k = min(CANDIDATES, count)
    m = len(points)
    out = PipeLocation(np.empty(m, bool), np.empty(m), np.empty((m, 3)), np.empty(m),
                       np.empty((m, 3)), np.empty(m, np.int64))
    for start in range(0, m, BLOCK):
        block = points[start:start + BLOCK]
        reach, units = line.tree.query(block, k=k)
        reach, units = reach.reshape(len(block), k), units.reshape(len(block), k)
        centreline, t, wall = line.project(block, units)
        unsure = _unsure(line, reach, centreline, wall, k < count)
        if unsure.any():  # a segment not among the candidates might be nearer: more of them
            wide = min(WIDER * k, count)
            rows = np.flatnonzero(unsure)
            reach, more = (v.reshape(len(rows), wide) for v in line.tree.query(block[rows],
                                                                                k=wide))
            c, s, w = line.project(block[rows], more)
            best = np.argmin(c, axis=1)
            pick = np.arange(len(rows))
            centreline[rows], wall[rows] = np.inf, np.inf
            centreline[rows, 0], t[rows, 0], units[rows, 0] = c[pick, best], s[pick, best], \
                more[pick, best]
            wall[rows, 0] = w.min(axis=1)
            still = _unsure(line, reach, c, w, wide < count)
            if still.any():
                unsure[:] = False
                unsure[rows[still]] = True
                _every_unit(line, block, unsure, centreline, t, wall, units)
        _fill(out, slice(start, start + len(block)), line, block, units, centreline, t, wall)
    return out


def _unsure(line, reach, centreline, wall, partial):
    """Points whose best candidate might be beaten by a unit not among them: one
    nearer than the last candidate's midpoint less half the longest unit (and, for
    the wall, less the largest radius)."""
    if not partial:
        return np.zeros(len(reach), bool)
    far = reach[:, -1] - line.half
    return (centreline.min(axis=1) > far) | (wall.min(axis=1) > far - line.radius)


def _every_unit(line, block, unsure, centreline, t, wall, units):
    """Make the candidates of the ``unsure`` points exact: every unit in a group of
    :data:`GROUP` consecutive units whose bounding ball could hold something
    nearer than the best candidate is projected too, and the best goes to
    column 0 (the other columns are then never the best)."""
    rows = np.flatnonzero(unsure)
    best_line, best_wall = centreline[rows].min(axis=1), wall[rows].min(axis=1)
    gap = np.linalg.norm(block[rows, None] - line.group_centre, axis=2) - line.group_ball
    near = (gap < best_line[:, None]) | (gap - line.group_radius < best_wall[:, None])
    row, group = np.nonzero(near)
    offsets = np.arange(GROUP)
    row = np.repeat(row, GROUP)
    unit = (group[:, None] * GROUP + offsets).ravel()
    keep = unit < len(line.a)
    row, unit = row[keep], unit[keep]
    for at in range(0, len(row), BATCH):
        r, u = row[at:at + BATCH], unit[at:at + BATCH]
        c, s, w = (v[:, 0] for v in line.project(block[rows[r]], u[:, None]))
        first = np.r_[True, r[1:] != r[:-1]]
        starts = np.flatnonzero(first)
        order = np.lexsort((c, r))
        pick = order[starts]
        into = rows[r[pick]]
        better = c[pick] < centreline[into].min(axis=1)
        into, pick = into[better], pick[better]
        centreline[into] = np.inf
        centreline[into, 0], t[into, 0], units[into, 0] = c[pick], s[pick], u[pick]
        lowest = np.minimum.reduceat(w, starts)
        into = rows[r[starts]]
        wall[into, 0] = np.minimum(wall[into].min(axis=1), lowest)
        wall[into, 1:] = np.inf


def _fill(out, rows, line, block, units, centreline, t, wall):
    pick = np.arange(len(block))
    best = np.argmin(centreline, axis=1)
    unit = units[pick, best]
    param = t[pick, best]
    sd = wall.min(axis=1)
    out.signed_distance[rows] = sd
    out.inside[rows] = sd <= 0
    out.segment[rows] = unit
    out.nearest[rows] = line.a[unit] + param[:, None] * (line.b[unit] - line.a[unit])
    out.arc_length[rows] = line.start_arc[unit] + param * line.length[unit]
    out.tangent[rows] = line.tangent[unit]


def _unit_intervals(p0, p1, a, b, ra, rb):
    """Parameter interval of each (segment, unit) pair inside the unit; NaN where
    the segment misses it."""
    d = p1 - p0

    def f(t):
        return round_cone_distance(p0 + t[:, None] * d, a, b, ra, rb)

    lo, hi = np.zeros(len(p0)), np.ones(len(p0))
    ratio = (np.sqrt(5.0) - 1.0) / 2.0
    for _ in range(GOLDEN_STEPS):                 # minimum of the convex distance
        m1, m2 = hi - ratio * (hi - lo), lo + ratio * (hi - lo)
        left = f(m1) < f(m2)
        hi = np.where(left, m2, hi)
        lo = np.where(left, lo, m1)
    best = 0.5 * (lo + hi)
    hit = f(best) <= 0
    starts, ends = np.where(f(np.zeros_like(best)) <= 0, 0.0, np.nan), \
        np.where(f(np.ones_like(best)) <= 0, 1.0, np.nan)
    for bound, edge in ((starts, 0.0), (ends, 1.0)):
        todo = np.isnan(bound) & hit
        outside, inside = np.full(todo.sum(), edge), best[todo]
        sel = np.flatnonzero(todo)
        for _ in range(BISECTION_STEPS):
            mid = 0.5 * (outside + inside)
            out = round_cone_distance(p0[sel] + mid[:, None] * d[sel], a[sel], b[sel], ra[sel],
                                      rb[sel]) > 0
            outside, inside = np.where(out, mid, outside), np.where(out, inside, mid)
        bound[sel] = inside
    return np.where(hit, starts, np.nan), np.where(hit, ends, np.nan)


def containment(chain, points):
    """A :class:`PipeContainment` of the polyline ``points`` against ``chain``."""
    sd = chain.signed_distance(points)
    inside = sd <= 0
    if not inside[0]:
        return PipeContainment(inside, sd, 0, 0.0, points[0].copy())
    if len(points) == 1:
        return PipeContainment(inside, sd, None, None, None)
    p0, p1 = points[:-1], points[1:]
    seg_lo = np.minimum(p0, p1)
    seg_hi = np.maximum(p0, p1)
    ub = chain.unit_bounds
    near = np.all((seg_lo[:, None] <= ub[None, :, 1]) & (seg_hi[:, None] >= ub[None, :, 0]),
                  axis=2)
    seg, unit = np.nonzero(near)
    start, end = _unit_intervals(p0[seg], p1[seg], chain.starts[unit], chain.ends[unit],
                                 chain.start_radii[unit], chain.end_radii[unit])
    keep = ~np.isnan(start)
    seg, start, end = seg[keep], start[keep], end[keep]
    # sweep the intervals in order along the whole path (segment k spans [k, k + 1])
    order = np.lexsort((start, seg))
    key_start, key_end = seg[order] + start[order], seg[order] + end[order]
    reach = np.maximum.accumulate(key_end)
    covered_to = np.concatenate([[0.0], reach[:-1]])
    gaps = np.flatnonzero(key_start > covered_to + 1e-12)
    stop = float(reach[-1]) if len(reach) else 0.0
    exit_at = float(covered_to[gaps[0]]) if gaps.size else (stop if stop < len(p0) - 1e-12
                                                              else None)
    if exit_at is None:
        return PipeContainment(inside, sd, None, None, None)
    k = min(int(exit_at), len(p0) - 1)
    t = exit_at - k
    return PipeContainment(inside, sd, k, t, p0[k] + t * (p1[k] - p0[k]))
