"""A bounding-capsule hierarchy over a chain's units, traversed for many poses at once.

Each node of the binary tree covers a run of consecutive units and carries a
capsule: a segment, its chord, with two radii. A unit's chord is its own axis;
a longer run's is the segment between its first and last ball centres, moved
across its direction to the middle of the run's bulge (on a bend that halves
how far the run strays from it). The radii:

* ``outer``: the capsule contains every unit of the run (each end ball lies in
  it: distance to the chord plus radius);
* ``inner``: within ``inner`` of the chord lies a point of the run (a point
  inside it when ``inner >= 0``). The run's axis is a connected polyline whose
  ends project onto the chord's ends, so it passes over every chord point
  within ``dev``, its largest distance from the chord's line, and the ball
  there has radius at least ``r_min``: ``inner = r_min - dev``. Runs whose
  units do not join up get ``-inf``.

So two nodes hold no touching units when their chords are farther apart than
the outer radii, and they touch when the chords are closer than the inner
radii. A pipe's units are short beside its radius, the two radii are close,
and most node pairs are decided high in the tree: two pipes settle a yes/no
query in about eight capsule tests.

The tree is perfect (every leaf at the same depth, some empty) in heap order,
so :func:`chain_gaps` walks both trees in lockstep without looking children
up: the frontier is a flat list of ``(pose, node_a, node_b)`` entries for a
whole batch of poses, every capsule test is a few numpy operations on
coordinate arrays, and only leaf pairs the radii cannot decide go to the exact
round-cone gap of :func:`cadpipe.collision.capsules.unit_pair_gap`.
"""

from functools import cached_property

import numpy as np

from cadpipe._vec import dot
from cadpipe.collision.capsules import inverse, segment_params, unit_pair_gap

#: poses per pass of :func:`chain_gaps`: the frontier's arrays stay in cache
CHUNK = 4096
#: node pairs per pose the walk may start with: a small batch starts deeper
START = 256
#: the four child pairs of a node pair, as offsets from each side's first child
SPLIT_A, SPLIT_B = np.array([0, 0, 1, 1]), np.array([0, 1, 0, 1])


class CapsuleTree:
    """The hierarchy of one chain, in the chain's own frame.

    Node ``k`` has children ``2k + 1`` and ``2k + 2``; the leaves, at depth
    ``depth``, hold one unit each (``unit``) or none (``unit == -1``, radii
    ``-inf``: never near anything). Per node: ``p0``, ``p1`` index the chord's
    ends in ``points`` (the ball centres, then the longer runs' chord ends),
    ``start`` and ``chord`` are the first end and the vector, ``chord_sq`` and
    its :func:`inverse`, ``inner`` and ``outer`` the radii.
    """

    def __init__(self, chain):
        edges = chain.edges
        count = len(edges)
        self.depth = int(np.ceil(np.log2(count))) if count > 1 else 0
        size = 2 ** (self.depth + 1) - 1
        first, last = np.zeros(size, np.int64), np.zeros(size, np.int64)
        for d in range(self.depth + 1):
            j = np.arange(2 ** d)
            first[2 ** d - 1 + j] = j * count // 2 ** d
            last[2 ** d - 1 + j] = (j + 1) * count // 2 ** d
        full = np.flatnonzero(last > first)
        lo, hi = first[full], last[full]
        # every unit of every node, node after node, for per-node extremes by reduceat
        runs = hi - lo
        offsets = np.r_[0, np.cumsum(runs)[:-1]]
        units = np.repeat(lo - offsets, runs) + np.arange(runs.sum())
        owner = np.repeat(np.arange(len(full)), runs)
        start = chain.centers[edges[lo, 0]]
        d = chain.centers[edges[hi - 1, 1]] - start
        inv = inverse(np.einsum("ij,ij->i", d, d))
        ends = ((chain.starts[units], chain.start_radii[units]),
                (chain.ends[units], chain.end_radii[units]))
        # a longer run's chord moves across its direction to the middle of the bulge
        across = [p - start[owner] for p, _ in ends]
        across = [w - (np.einsum("ij,ij->i", w, d[owner]) * inv[owner])[:, None] * d[owner]
                  for w in across]
        middle = 0.5 * (np.minimum.reduceat(np.minimum(*across), offsets)
                        + np.maximum.reduceat(np.maximum(*across), offsets))
        middle -= (np.einsum("ij,ij->i", middle, d) * inv)[:, None] * d
        middle[runs == 1] = 0.0
        start = start + middle
        outer, dev = [], []
        for p, r in ends:
            rel = p - start[owner]
            along = np.einsum("ij,ij->i", rel, d[owner]) * inv[owner]
            outer.append(np.linalg.norm(rel - np.clip(along, 0.0, 1.0)[:, None] * d[owner],
                                        axis=1) + r)
            dev.append(np.linalg.norm(rel - along[:, None] * d[owner], axis=1))
        r_min = np.minimum(*(r for _, r in ends))
        # a unit joins the next when its end is the next one's start
        breaks = np.r_[0, np.cumsum(edges[:-1, 1] != edges[1:, 0])]
        joined = breaks[lo] == breaks[hi - 1]
        self.inner, self.outer = np.full(size, -np.inf), np.full(size, -np.inf)
        self.inner[full] = np.where(joined, np.minimum.reduceat(r_min, offsets)
                                    - np.maximum.reduceat(np.maximum(*dev), offsets), -np.inf)
        self.outer[full] = np.maximum.reduceat(np.maximum(*outer), offsets)
        # a single unit's chord is its own axis: the radii are exact, free of rounding
        one = full[runs == 1]
        self.inner[one] = np.minimum(chain.start_radii, chain.end_radii)[first[one]]
        self.outer[one] = np.maximum(chain.start_radii, chain.end_radii)[first[one]]
        # chord ends as points: a unit's are its ball centres, a longer run's its own
        longer = np.flatnonzero(runs > 1)
        n = len(chain.centers)
        self.points = np.concatenate([chain.centers, start[longer], start[longer] + d[longer]])
        self.p0, self.p1 = np.zeros(size, np.int64), np.zeros(size, np.int64)
        self.p0[full], self.p1[full] = edges[lo, 0], edges[hi - 1, 1]
        self.p0[full[longer]] = n + np.arange(len(longer))
        self.p1[full[longer]] = n + len(longer) + np.arange(len(longer))
        leaves = np.arange(2 ** self.depth - 1, size)
        self.unit = np.where(last[leaves] > first[leaves], first[leaves], -1)
        self.start = self.points[self.p0]
        self.chord = self.points[self.p1] - self.start
        self.chord_sq = np.einsum("ij,ij->i", self.chord, self.chord)
        self.inv_chord_sq = inverse(self.chord_sq)
        self.homogeneous = np.vstack([self.points.T, np.ones(len(self.points))])
        self.span = self.p1 - self.p0

    @cached_property
    def start_t(self):
        """``start`` as (3, N) coordinate rows."""
        return np.ascontiguousarray(self.start.T)

    @cached_property
    def chord_t(self):
        """``chord`` as (3, N) coordinate rows."""
        return np.ascontiguousarray(self.chord.T)

    @cached_property
    def capsule_leaves(self):
        """Whether every unit is a capsule (inner == outer): then the radii decide
        every leaf pair of a yes/no query."""
        leaves = 2 ** self.depth - 1 + np.flatnonzero(self.unit >= 0)
        return bool(np.all(self.inner[leaves] == self.outer[leaves]))


def chain_gaps(chain_a, chain_b, poses, stop_below=None):
    """The smallest unit-pair gap between two chains at each of many poses.

    Parameters
    ----------
    chain_a, chain_b : Chain
        In their own frames.
    poses : (P, 4, 4) array
        Rigid poses of ``chain_b`` in ``chain_a``'s frame.
    stop_below : float, optional
        A yes/no query: a pose is settled as soon as its gap is proven to be at
        most this (>= 0); its returned gap is then only an upper bound.

    Returns
    -------
    gap : (P,) array
        The minimum over unit pairs of :func:`unit_pair_gap` (negative when
        units overlap). With ``stop_below`` only ``gap <= stop_below`` is
        meaningful: the value is then a bound, not the minimum.
    units : (P, 2) int array
        The unit pair attaining ``gap`` (-1 where settled early).
    params : (P, 2) array
        ``(s, t)`` along those units' axes (NaN where settled early).
    """
    poses = np.asarray(poses, np.float64)
    gap = np.full(len(poses), np.inf)
    units = np.full((len(poses), 2), -1, np.int64)
    params = np.full((len(poses), 2), np.nan)
    for start in range(0, len(poses), CHUNK):
        part = slice(start, start + CHUNK)
        _walk(chain_a, chain_b, poses[part], stop_below, gap[part], units[part], params[part])
    return gap, units, params


def _walk(chain_a, chain_b, poses, stop_below, gap, units, params):
    """:func:`chain_gaps` for one chunk of poses, into its output slices."""
    ta, tb = chain_a.tree, chain_b.tree
    count, n_b = len(poses), len(tb.points)
    # b's chord ends at every pose in one matrix product: coordinate k of point c at
    # pose p is moved[(3 p + k) n_b + c] (the ball centres come first)
    moved = (poses[:, :3].reshape(-1, 4) @ tb.homogeneous).ravel()
    xyz = (np.arange(3) * n_b)[:, None]
    cap = np.inf if stop_below is None else float(stop_below)
    exact = stop_below is None or not (ta.capsule_leaves and tb.capsule_leaves)
    bound = np.full(count, np.inf)                 # a proven upper bound of each gap
    # the roots' test is left out (whole chains' capsules nearly always meet, and the
    # world's broad phase has compared them), and few poses start deeper still: fewer
    # passes, each over more node pairs
    bottom = max(ta.depth, tb.depth)
    top = min(max(int(np.log(max(START / count, 1.0)) / np.log(4.0)), 1), bottom)
    na, nb = _level(ta, top), _level(tb, top)
    pose = np.repeat(np.arange(count), len(na) * len(nb))
    na, nb = np.tile(np.repeat(na, len(nb)), count), np.tile(nb, count * len(na))
    for depth in range(top, bottom + 1):
        i0 = tb.p0[nb] + pose * (3 * n_b) + xyz                     # (3, E) coordinates
        q0 = np.take(moved, i0)
        v = np.take(moved, i0 + tb.span[nb]) - q0
        u = np.take(ta.chord_t, na, axis=1)
        r = np.take(ta.start_t, na, axis=1) - q0
        s, t = segment_params(ta.chord_sq[na], tb.chord_sq[nb], dot(u, v, 0), dot(u, r, 0),
                              dot(v, r, 0), ta.inv_chord_sq[na], tb.inv_chord_sq[nb])
        r += s * u - t * v
        dist = np.sqrt(dot(r, r, 0))
        upper = dist - ta.inner[na] - tb.inner[nb]
        lower = dist - ta.outer[na] - tb.outer[nb]
        if stop_below is None:
            np.minimum.at(bound, pose, np.maximum(upper, 0.0))
            keep = (lower <= bound[pose]).nonzero()[0]
        else:
            hit = (upper <= cap).nonzero()[0]
            bound[pose[hit]] = np.maximum(upper[hit], 0.0)
            keep = ((lower <= cap) & (bound[pose] > cap)).nonzero()[0]
        pose, na, nb = pose[keep], na[keep], nb[keep]
        if depth == bottom:
            break
        # children in heap order; a tree already at its leaves stays there
        pose = np.repeat(pose, 4)
        na = ((2 * na + 1)[:, None] + SPLIT_A).ravel() if depth < ta.depth else np.repeat(na, 4)
        nb = ((2 * nb + 1)[:, None] + SPLIT_B).ravel() if depth < tb.depth else np.repeat(nb, 4)
    gap[:] = bound
    if exact and pose.size:
        ua, ub = ta.unit[na - 2 ** ta.depth + 1], tb.unit[nb - 2 ** tb.depth + 1]
        _exact(chain_a, chain_b, moved, n_b, pose, ua, ub, gap, units, params)


def _level(tree, depth):
    """The nodes of ``tree`` at ``depth`` (its leaves if it is shallower)."""
    depth = min(depth, tree.depth)
    return np.arange(2 ** depth - 1, 2 ** (depth + 1) - 1)


def _exact(chain_a, chain_b, moved, n_b, pose, ua, ub, gap, units, params):
    """Exact gaps of the leaf pairs the radii could not decide; each pose with any
    gets the smallest (its closest pair always survives the pruning)."""
    row = (pose * (3 * n_b))[:, None] + np.arange(3) * n_b
    ends_b = [moved[chain_b.edges[ub, k][:, None] + row] for k in (0, 1)]
    found, s, t = unit_pair_gap(chain_a.starts[ua], chain_a.ends[ua], chain_a.start_radii[ua],
                                chain_a.end_radii[ua], ends_b[0], ends_b[1],
                                chain_b.start_radii[ub], chain_b.end_radii[ub])
    order = np.lexsort((found, pose))
    first = order[np.r_[True, pose[order][1:] != pose[order][:-1]]]
    p = pose[first]
    gap[p], units[p, 0], units[p, 1], params[p, 0], params[p, 1] = \
        found[first], ua[first], ub[first], s[first], t[first]
