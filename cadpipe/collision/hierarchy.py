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
and most node pairs are decided high in the tree: two pipes of about a
hundred units each settle a yes/no query in about thirty capsule tests.

The tree is perfect (every leaf at the same depth, some empty) in heap order,
so :func:`chain_gaps` walks both trees without looking children up (node
``k``'s are ``2k + 1``, ``2k + 2``), splitting the larger node of each pair
(splitting both at once tested about three times as many pairs): a compiled
depth-first walk per pose (``csrc/hierarchy.c``; one call for all poses, not the
~60 numpy calls per pose a breadth-first frontier in numpy took), in which
capsule leaf pairs get their exact gap from the radii and only tapered leaf
pairs go to the exact round-cone gap of
:func:`cadpipe.collision.capsules.unit_pair_gap`, batched over all poses.
"""


import numpy as np

from cadpipe.collision.capsules import unit_pair_gap
from cadpipe.core.distance import inverse
from cadpipe.core.kernels import native
from cadpipe.core.tree import depth_for, node_ranges
from cadpipe.geometry.ragged import Groups

#: poses per call of the compiled walk (bounds the buffer of leaf pairs left over)
CHUNK = 4096


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
        self.depth = depth_for(count)
        size = 2 ** (self.depth + 1) - 1
        first, last = node_ranges(count, self.depth, even=True)
        full = np.flatnonzero(last > first)
        lo, hi = first[full], last[full]
        # every unit of every non-empty node, node after node (ragged rows), so per-node
        # extremes are one reduceat over them
        members = Groups(hi - lo)
        runs, offsets, owner = members.counts, members.first, members.index
        units = lo[owner] + members.local()
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
        # each point once (a pipe's units share their end balls): a walk moves every
        # point per pose
        self.points, once = np.unique(self.points, axis=0, return_inverse=True)
        self.p0, self.p1 = once.reshape(-1)[self.p0], once.reshape(-1)[self.p1]
        leaves = np.arange(2 ** self.depth - 1, size)
        self.unit = np.where(last[leaves] > first[leaves], first[leaves], -1)
        self.start = self.points[self.p0]
        self.chord = self.points[self.p1] - self.start
        self.chord_sq = np.einsum("ij,ij->i", self.chord, self.chord)
        self.inv_chord_sq = inverse(self.chord_sq)
        # the walk's view, packed so one call passes few arrays: per node start,
        # chord, chord_sq, its inverse, inner, outer; and p0, p1, the leaf's unit
        # (-1 above)
        self.table = np.column_stack([self.start, self.chord, self.chord_sq,
                                      self.inv_chord_sq, self.inner, self.outer])
        self.index = np.column_stack([self.p0, self.p1, np.r_[np.full(size - len(leaves), -1),
                                                              self.unit]])


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
    poses = np.ascontiguousarray(poses, np.float64).reshape(-1, 4, 4)
    gap, units, params = np.empty(len(poses)), np.empty((len(poses), 2), np.int64), \
        np.empty((len(poses), 2))                 # every entry written by the walk
    for start in range(0, len(poses), CHUNK):
        part = slice(start, start + CHUNK)
        _walk(chain_a, chain_b, poses[part], stop_below, gap[part], units[part], params[part])
    return gap, units, params


def _walk(chain_a, chain_b, poses, stop_below, gap, units, params):
    """:func:`chain_gaps` for one chunk of poses, into its output slices: the
    compiled walk, then the exact round-cone gap of the tapered leaf pairs it
    left (capsule leaf pairs it settles itself: their radii are exact).

    The walk (``native.chain_walk``) takes both trees for each pose depth first,
    splitting the larger node of each pair (by chord and outer radius). Per node
    pair: the chords' closest points (Ericson's clamping, as
    :func:`~cadpipe.core.distance.segment_params`), ``dist``; ``dist - inner -
    inner`` bounds the gap from above, ``dist - outer - outer`` from below. A
    yes/no query settles a pose once the upper bound is at most ``stop_below``;
    otherwise pairs whose lower bound exceeds the best upper bound are dropped.
    Capsule leaf pairs (inner == outer) give their exact gap; other leaf pairs go
    to ``left`` for the exact round-cone gap (-1 returned: ``left`` is too small).
    """
    ta, tb = chain_a.tree, chain_b.tree
    cap = np.inf if stop_below is None else float(stop_below)
    room = 64 * len(poses)
    while True:
        left = np.empty((room, 3), np.int64)         # (pose, unit of a, unit of b)
        count = native.chain_walk(ta.table, ta.index, ta.depth, tb.points, tb.table, tb.index,
                                  tb.depth, poses, cap, stop_below is not None, gap, units,
                                  params, left)
        if count >= 0:
            break
        room *= 4
    if count:
        _exact(chain_a, chain_b, poses, left[:count], gap, units, params)


def _exact(chain_a, chain_b, poses, left, gap, units, params):
    """Exact gaps of the tapered leaf pairs ``left`` (K, 3) of (pose, unit, unit); a
    pose whose smallest beats the walk's gets it (its closest pair always
    survives the pruning)."""
    pose, ua, ub = left[:, 0], left[:, 1], left[:, 2]
    ends_b = [np.einsum("kij,kj->ki", poses[pose, :3, :3], chain_b.centers[chain_b.edges[ub, k]])
              + poses[pose, :3, 3] for k in (0, 1)]
    found, s, t = unit_pair_gap(chain_a.starts[ua], chain_a.ends[ua], chain_a.start_radii[ua],
                                chain_a.end_radii[ua], ends_b[0], ends_b[1],
                                chain_b.start_radii[ub], chain_b.end_radii[ub])
    order = np.lexsort((found, pose))
    first = order[np.r_[True, pose[order][1:] != pose[order][:-1]]]
    better = first[found[first] < gap[pose[first]]]
    p = pose[better]
    gap[p], units[p, 0], units[p, 1], params[p, 0], params[p, 1] = \
        found[better], ua[better], ub[better], s[better], t[better]
