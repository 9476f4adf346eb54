"""A box tree over triangles (or any boxes), built once and walked by compiled loops (C).

The boxes are sorted along a Morton (Z-order) curve of their centres and grouped
into leaves of :data:`LEAF`; the tree is a complete binary tree in heap order
(node ``k`` has children ``2k`` and ``2k + 1``, the root is node 1, the leaves are
the last ``leaves`` nodes), built level by level. Node ``k`` at span ``s`` (leaves
under it) holds the sorted boxes ``[(k * s - leaves) * LEAF, (k * s - leaves + s) * LEAF)``,
so a walk carries the span instead of looking ranges up. The self-intersection
search (:mod:`cadpipe.geometry.intersect`) walks it against itself, the winding
number (:mod:`cadpipe.geometry.winding`) walks it for one point at a time; both walks
take this arithmetic from ``csrc/boxtree.c``, which builds the tree too.
"""

import numpy as np

from cadpipe.core.kernels import native

#: boxes per leaf of the tree (``BOX_LEAF`` of ``csrc/boxtree.c``)
LEAF = 4


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
        # boxes in the Morton order of their centres (21 bits per axis over the centres'
        # bounds), ties in input order
        self.order = np.argsort(native.morton(lo, hi), kind="stable")
        leaves = 1 << int(np.ceil(np.log2(max(1, -(-n // LEAF)))))
        # the boxes in that order padded with empty ones, and the nodes from the leaves up
        self.lo, self.hi, self.node_lo, self.node_hi = native.box_build(lo, hi, self.order,
                                                                        leaves)

    @classmethod
    def of_triangles(cls, triangles):
        """The tree of the boxes of ``triangles`` (F, 3, 3)."""
        return cls(*triangle_boxes(triangles))

    @property
    def leaves(self):
        """Number of leaf nodes (a power of two)."""
        return len(self.node_lo) // 2

    def arrays(self):
        """``(node_lo, node_hi, lo, hi, order, n)``: what the compiled walks take."""
        return self.node_lo, self.node_hi, self.lo, self.hi, self.order, self.n


def triangle_boxes(tri):
    """(F, 3) lower and upper corners of the triangles ``tri`` (F, 3, 3)."""
    return native.triangle_boxes(np.ascontiguousarray(tri, np.float64).reshape(-1, 3, 3))
