"""The one box tree: items' boxes in a perfect binary tree in heap order, built once and
walked by compiled loops.

Node 0 is the root, node ``k``'s children are ``2k + 1`` and ``2k + 2``, and the
``2**depth`` leaves are the last nodes; leaf ``L`` holds the items ``[L * leaf_size,
(L + 1) * leaf_size)`` of the tree's order (``csrc/tree.h``). A walk carries each node's
span (the leaves under it) and so finds its items without any table. The order is
what the data needs:

* ``"morton"``: a Z-order curve of the boxes' centres, several items a leaf -- any triangle
  soup (the self-intersection search, :mod:`cadpipe.geometry.intersect`; the winding
  number, :mod:`cadpipe.geometry.winding`);
* ``"median"``: each node's items split at the median of their centres along their
  longest extent, one a leaf -- the triangles a pipe's capsule tree is walked against
  (:mod:`cadpipe.collision.chain_mesh`: about 30 % fewer node pairs than a Morton order,
  whose boxes straddle the curve's jumps);
* ``"sequence"``: the items as given, one a leaf -- a path's segments, whose runs are
  its stretches (:mod:`cadpipe.collision.fixture`, and the fold search of
  :mod:`cadpipe.geometry.clearance`, which builds it inside its walk; the chains'
  capsule trees of :mod:`cadpipe.collision.hierarchy` take the same layout with
  capsules for boxes, :func:`node_ranges`).
"""

import numpy as np

from cadpipe.core.kernels import native

#: items per leaf of a Morton-ordered tree
LEAF = 4
#: the orders a tree can take
ORDERS = ("morton", "median", "sequence")


def depth_for(leaves):
    """The depth of the perfect tree over ``leaves`` leaves at least (0 for one)."""
    return int(np.ceil(np.log2(leaves))) if leaves > 1 else 0


class BoxTree:
    """The tree of boxes ``lo``, ``hi``.

    Parameters
    ----------
    lo, hi : (N, 3) float
        Lower and upper box corners.
    order : {"morton", "median", "sequence"}
        How items are laid along the leaves (see the module docstring); ``"median"``
        takes one item a leaf.
    leaf_size : int
        Items per leaf.
    centres : (N, 3) float, optional
        The points a median split compares (the boxes' centres by default; a triangle's
        centroid, say).

    Attributes
    ----------
    n : int
        Number of boxes, N.
    depth, leaves : int
        The tree's depth and its ``2**depth`` leaves.
    order : (N,) int64
        Item ``i`` of the tree's order is box ``order[i]``.
    lo, hi : (leaves * leaf_size, 3) float64
        The boxes in that order, padded with empty boxes (lo = +inf, hi = -inf: they
        overlap nothing).
    node_lo, node_hi : (2 * leaves - 1, 3) float64
        Node boxes in heap order, leaves last.
    """

    def __init__(self, lo, hi, order="morton", leaf_size=LEAF, centres=None):
        lo, hi = np.ascontiguousarray(lo, np.float64), np.ascontiguousarray(hi, np.float64)
        self.n = n = len(lo)
        self.leaf_size = int(leaf_size)
        self.depth = depth_for(-(-n // self.leaf_size))
        self.leaves = 1 << self.depth
        if order == "morton":              # ties in input order
            self.order = np.argsort(native.morton(lo, hi), kind="stable")
        elif order == "median":
            if self.leaf_size != 1:
                raise ValueError("a median-split tree holds one item a leaf")
            self.order = np.empty(n, np.int64)
            centres = 0.5 * (lo + hi) if centres is None else centres
            native.median_order(np.ascontiguousarray(centres, np.float64), self.depth,
                                self.order)
        elif order == "sequence":
            self.order = np.arange(n, dtype=np.int64)
        else:
            raise ValueError(f"order must be one of {ORDERS}, got {order!r}")
        self.lo, self.hi, self.node_lo, self.node_hi = native.tree_build(
            lo, hi, self.order, self.leaves, self.leaf_size)

    @classmethod
    def of_triangles(cls, triangles, order="morton", leaf_size=LEAF):
        """The tree of the boxes of ``triangles`` (F, 3, 3)."""
        return cls(*triangle_boxes(triangles), order=order, leaf_size=leaf_size)

    def maxima(self, values):
        """(nodes,) the largest of the items' ``values`` (N,) under each node (``-inf``
        for a node without items): a reach per node, say."""
        items = np.full(self.leaves * self.leaf_size, -np.inf)
        items[:self.n] = np.asarray(values, np.float64)[self.order]
        level = items.reshape(self.leaves, self.leaf_size).max(axis=1)
        levels = [level]
        while len(level) > 1:
            level = np.maximum(level[0::2], level[1::2])
            levels.append(level)
        return np.concatenate(levels[::-1])

    def arrays(self):
        """``(node_lo, node_hi, lo, hi, order, n, leaf_size)``: what the compiled walks
        take."""
        return self.node_lo, self.node_hi, self.lo, self.hi, self.order, self.n, self.leaf_size


def node_ranges(count, depth, even=False):
    """``(first, stop)`` items of every node of the tree of ``depth`` over ``count`` items
    one a leaf, in heap order (empty where equal). Node ``2**d - 1 + j`` (the ``j``-th at
    depth ``d``) covers ``j * w`` up to ``(j + 1) * w`` with ``w = 2**(depth - d)``, at most
    ``count`` (the items in the first leaves, as :class:`BoxTree` lays them); with
    ``even``, ``j * count // 2**d`` up to ``(j + 1) * count // 2**d`` instead (the empty
    leaves spread among the others, so the nodes of a level hold as many items as
    they can: a chain's capsule tree, whose nodes' chords stay balanced)."""
    first, stop = [], []
    for d in range(depth + 1):
        j = np.arange(1 << d)
        if even:
            first.append(j * count // (1 << d))
            stop.append((j + 1) * count // (1 << d))
        else:
            width = 1 << (depth - d)
            first.append(np.minimum(j * width, count))
            stop.append(np.minimum((j + 1) * width, count))
    return np.concatenate(first), np.concatenate(stop)


def triangle_boxes(tri):
    """(F, 3) lower and upper corners of the triangles ``tri`` (F, 3, 3)."""
    return native.triangle_boxes(np.ascontiguousarray(tri, np.float64).reshape(-1, 3, 3))
