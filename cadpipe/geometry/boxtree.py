"""A box tree over triangles (or any boxes), built once and walked by compiled loops.

The boxes are sorted along a Morton (Z-order) curve of their centres and grouped
into leaves of :data:`LEAF`; the tree is a complete binary tree in heap order
(node ``k`` has children ``2k`` and ``2k + 1``, the root is node 1, the leaves are
the last ``leaves`` nodes), built level by level. Node ``k`` at span ``s`` (leaves
under it) holds the sorted boxes ``[(k * s - leaves) * LEAF, (k * s - leaves + s) * LEAF)``,
so a walk carries the span instead of looking ranges up. The self-intersection
search (:mod:`cadpipe.solids.intersect`) walks it against itself, the winding
number (:mod:`cadpipe.geometry.winding`) walks it for one point at a time.
"""

import numba
import numpy as np

#: boxes per leaf of the tree
LEAF = 4

_jit = numba.njit(cache=True, nogil=True)


class BoxTree:
    """The tree of boxes ``lo``, ``hi``.

    Parameters
    ----------
    lo, hi : (N, 3) float
        Lower and upper box corners.

    Attributes
    ----------
    n : int
        Number of boxes, N.
    order : (N,) int64
        The boxes' Morton order: sorted row ``i`` is box ``order[i]``.
    lo, hi : (leaves * LEAF, 3) float64
        The boxes in that order, padded with empty boxes (lo = +inf, hi = -inf:
        they overlap nothing).
    node_lo, node_hi : (2 * leaves, 3) float64
        Node boxes in heap order (row 0 unused), leaves last.
    """

    def __init__(self, lo, hi):
        lo, hi = np.ascontiguousarray(lo, np.float64), np.ascontiguousarray(hi, np.float64)
        self.n = n = len(lo)
        self.order = np.argsort(_morton(lo, hi), kind="stable")
        leaves = 1 << int(np.ceil(np.log2(max(1, -(-n // LEAF)))))
        self.lo, self.hi, self.node_lo, self.node_hi = _build(lo, hi, self.order, leaves)

    @classmethod
    def of_triangles(cls, triangles):
        """The tree of the boxes of ``triangles`` (F, 3, 3)."""
        return cls(*triangle_boxes(np.ascontiguousarray(triangles, np.float64)))

    @property
    def leaves(self):
        """Number of leaf nodes (a power of two)."""
        return len(self.node_lo) // 2

    def arrays(self):
        """``(node_lo, node_hi, lo, hi, order, n)``: what the compiled walks take."""
        return self.node_lo, self.node_hi, self.lo, self.hi, self.order, self.n


@_jit
def triangle_boxes(tri):
    """(F, 3) lower and upper corners of the triangles ``tri`` (F, 3, 3)."""
    lo, hi = np.empty((len(tri), 3)), np.empty((len(tri), 3))
    for f in range(len(tri)):
        for axis in range(3):
            lo[f, axis] = min(tri[f, 0, axis], tri[f, 1, axis], tri[f, 2, axis])
            hi[f, axis] = max(tri[f, 0, axis], tri[f, 1, axis], tri[f, 2, axis])
    return lo, hi


@_jit
def _build(lo, hi, order, leaves):
    """Boxes in Morton order, padded to ``leaves * LEAF`` with empty boxes, and the node
    boxes, leaves first, then each level from the one below."""
    size = leaves * LEAF
    sorted_lo, sorted_hi = np.full((size, 3), np.inf), np.full((size, 3), -np.inf)
    node_lo, node_hi = np.full((2 * leaves, 3), np.inf), np.full((2 * leaves, 3), -np.inf)
    for i in range(len(order)):
        leaf = leaves + i // LEAF
        for axis in range(3):
            sorted_lo[i, axis], sorted_hi[i, axis] = lo[order[i], axis], hi[order[i], axis]
            node_lo[leaf, axis] = min(node_lo[leaf, axis], sorted_lo[i, axis])
            node_hi[leaf, axis] = max(node_hi[leaf, axis], sorted_hi[i, axis])
    for node in range(leaves - 1, 0, -1):
        for axis in range(3):
            node_lo[node, axis] = min(node_lo[2 * node, axis], node_lo[2 * node + 1, axis])
            node_hi[node, axis] = max(node_hi[2 * node, axis], node_hi[2 * node + 1, axis])
    return sorted_lo, sorted_hi, node_lo, node_hi


@_jit
def _morton(lo, hi):
    """Z-order curve key of each box's centre (21 bits per axis over the centres' bounds)."""
    n = len(lo)
    centre = (lo + hi) / 2
    low = np.empty(3)
    span = np.empty(3)
    for axis in range(3):
        low[axis] = centre[:, axis].min() if n else 0.0
        span[axis] = centre[:, axis].max() - low[axis] if n else 0.0
        if not span[axis] > 0:
            span[axis] = 1.0
    key = np.zeros(n, np.uint64)
    for i in range(n):
        k = np.uint64(0)
        for axis in range(3):
            cell = np.uint64((centre[i, axis] - low[axis]) / span[axis] * (2**21 - 1))
            for bit in range(21):
                k |= ((cell >> np.uint64(bit)) & np.uint64(1)) << np.uint64(3 * bit + axis)
        key[i] = k
    return key
