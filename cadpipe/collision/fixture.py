"""Virtual fixtures: where points are relative to a safety pipe, and where a tool
path leaves it.

:func:`locate` answers, for an unordered cloud of points, everything a fixture
controller asks per point in one call: inside or not, the signed distance to
the pipe's wall, the nearest point of the centreline, its arc length and the
tangent there. The pipe is the chain of round cones along its centreline
through its ring radii. A perfect binary tree of axis-aligned boxes over the
centreline's consecutive segments (each box also knows its largest radius) is
walked per point in one compiled loop (C, ``csrc/fixture.c``), nearer child
first; a subtree is skipped only when its box is farther than the best
centreline distance found and, less its radius, than the best wall distance --
so both answers are the exact minima over every segment, not a nearest-vertex
guess, and a point costs a few dozen box tests rather than one per segment.

:func:`leaves` and :func:`containment` are the ordered tool-path question. The
points themselves are classified by their signed distance to the ball chain.
The path between them matters too (a straight move can cut a bend while both
ends are inside), so each path segment is intersected with every nearby unit:
the signed distance of a convex unit is convex along a line, so each
intersection is one interval of the segment, found by golden-section search
and bisection. The segment stays inside exactly when its intervals cover it;
the first gap is where the path leaves the pipe.
"""

from dataclasses import dataclass

import numpy as np

from cadpipe._validate import as_points
from cadpipe.core.tree import BoxTree
from cadpipe.collision.capsules import Chain, round_cone_distance
from cadpipe.core.kernels import native
from cadpipe.errors import InputError

#: golden-section steps and bisection steps (each shrinks the bracket below 1e-12)
GOLDEN_STEPS = 60
BISECTION_STEPS = 42


@dataclass(frozen=True)
class PipeContainment:
    """Result of :meth:`CollisionWorld.inside` and :func:`leaves` for a polyline of
    points.

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
        The centreline segment ``nearest`` lies on (from point ``k`` to ``k + 1``;
        of two equally near, the first).
    """

    inside: np.ndarray
    signed_distance: np.ndarray
    nearest: np.ndarray
    arc_length: np.ndarray
    tangent: np.ndarray
    segment: np.ndarray


class SegmentTree:
    """Boxes over a chain's units for point queries, in the chain's frame: the one box
    tree (:class:`~cadpipe.core.tree.BoxTree`) in the units' own order, a unit a leaf.

    Leaf ``L`` (at depth ``depth``) holds unit ``unit[L]`` or none (-1, an empty box);
    ``lo``, ``hi`` (nodes, 3) bound the units' axes; ``reach`` (nodes,) is the largest
    ball radius below each node.

    Parameters
    ----------
    chain : Chain
    """

    def __init__(self, chain: Chain):
        a, b = chain.starts, chain.ends
        count = len(a)
        tree = BoxTree(np.minimum(a, b), np.maximum(a, b), order="sequence", leaf_size=1)
        self.depth = tree.depth
        self.unit = np.full(tree.leaves, -1, np.int64)
        self.unit[:count] = np.arange(count)
        self.lo, self.hi = tree.node_lo, tree.node_hi
        self.reach = tree.maxima(np.maximum(chain.start_radii, chain.end_radii))


class _Centreline:
    """A pipe's units, their lengths, arcs and tangents, and their :class:`SegmentTree`."""

    def __init__(self, chain):
        self.a, self.b = chain.starts, chain.ends
        self.ra, self.rb = chain.start_radii, chain.end_radii
        axis = self.b - self.a
        self.length = np.linalg.norm(axis, axis=1)
        self.tangent = axis / np.where(self.length > 0, self.length, 1.0)[:, None]
        self.start_arc = np.concatenate([[0.0], np.cumsum(self.length)[:-1]])
        self.radius = float(max(self.ra.max(), self.rb.max()))
        self.uniform = bool(np.all(self.ra == self.radius) and np.all(self.rb == self.radius))
        self.tree = SegmentTree(chain)


def _pipe_chain(pipe, transform, call):
    from cadpipe.geometry.pipe import Pipe

    if not isinstance(pipe, Pipe):
        raise InputError(f"{call}(pipe, points): expected a cadpipe Pipe, got "
                         f"{type(pipe).__name__}", key="pipe")
    # the centreline's own units, in path order (the collision model adds miter-tip and
    # cap units that hold the mesh; locating along the path needs the segments alone)
    chain = Chain.along(pipe.path.points, pipe.ring_radii, closed=pipe.closed)
    if transform is not None:
        from cadpipe.collision.scene import as_pose

        chain = chain.moved(as_pose(transform, "pipe"))
    return chain


def locate(pipe, points, transform=None) -> PipeLocation:
    """Where each of ``points`` is relative to ``pipe``, in one compiled call.

    Parameters
    ----------
    pipe : Pipe
        The safety pipe: the solid is the chain of round cones along its
        centreline through its ring radii.
    points : (M, 3) array
        Query points, in any order (length units of the pipe).
    transform : (4, 4) array, optional
        Where the pipe stands (rigid); the identity by default.

    Returns
    -------
    PipeLocation
        Exact per point: the minima over every segment (see the module
        docstring). For an ordered tool path, :func:`leaves` says where it
        first leaves the pipe.
    """
    points = np.ascontiguousarray(as_points(points, "points"), np.float64)
    line = _Centreline(_pipe_chain(pipe, transform, "locate"))
    tree = line.tree
    m = len(points)
    out = PipeLocation(np.empty(m, bool), np.empty(m), np.empty((m, 3)), np.empty(m),
                       np.empty((m, 3)), np.empty(m, np.int64))
    # the walk: depth first, the nearer child first, a node skipped when its box is
    # farther than the best centreline distance and, less ``reach``, than the best wall
    # distance
    native.locate(points, *(np.ascontiguousarray(v, np.float64) for v in (
                      line.a, line.b, line.ra, line.rb, line.length, line.start_arc,
                      line.tangent, tree.lo, tree.hi, tree.reach)),
                  tree.unit, tree.depth, line.uniform, line.radius, out.inside,
                  out.signed_distance, out.nearest, out.arc_length, out.tangent, out.segment)
    return out


def leaves(pipe, points, transform=None) -> PipeContainment:
    """Where the ordered tool path through ``points`` first leaves ``pipe``.

    Parameters
    ----------
    pipe : Pipe
        The same solid as :func:`locate`'s (its per-point signed distances are
        :func:`locate`'s).
    points : (M, 3) array
        The tool path's points, in order; the straight moves between them are
        checked too.
    transform : (4, 4) array, optional
        Where the pipe stands (rigid); the identity by default.

    Returns
    -------
    PipeContainment
    """
    points = as_points(points, "points")
    return containment(_pipe_chain(pipe, transform, "leaves"), points)


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
