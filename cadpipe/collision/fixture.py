"""Virtual fixtures: does a tool path stay inside a safety pipe, and where does it leave?

The points themselves are classified by their signed distance to the pipe's
ball chain. The path between them matters too (a straight move can cut a bend
while both ends are inside), so each path segment is intersected with every
nearby unit: the signed distance of a convex unit is convex along a line, so
each intersection is one interval of the segment, found by golden-section
search and bisection. The segment stays inside exactly when its intervals
cover it; the first gap is where the path leaves the pipe.
"""

from dataclasses import dataclass

import numpy as np

from cadpipe.collision.capsules import round_cone_distance

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
