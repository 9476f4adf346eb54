"""Chains against meshes: a pipe's capsule tree walked against a box tree of a mesh's
triangles, one compiled call for one pose or for thousands.

Each chain unit is taken as the capsule of its larger end radius (exact for the
untapered units of a pipe of one radius, a little larger for a tapered one: the
model FCL's capsules gave this pair before). The mesh's triangles, split at
medians of their centroids, are the leaves of a perfect binary tree
(:class:`TriangleTree`, built once per mesh) whose nodes carry an axis-aligned
box and, above the leaves, an oriented one along the principal axes of their
triangles' corners (thin across a patch of a curved surface, where the
axis-aligned box of a tilted patch is not; a leaf's is its triangle's plane).
The chain's nodes are :class:`~cadpipe.collision.hierarchy.CapsuleTree`'s, whose
chords move with the pose; each is placed (its chord's ends moved, their box
widened by the outer radius) the first time a pose's walk reaches it.

Both trees are walked in lockstep, depth first, splitting the larger node. A
node pair is dropped when a lower bound of its gap exceeds the best gap found (a
yes/no query: 0): the gap of the axis-aligned boxes, then the capsule's against
the oriented box along its three axes (a leaf's plane); a yes/no query takes
first the pair whose chord crosses the mesh node's middle plane across its
thinnest axis (a contact is likelier there), any other the pair of nearer boxes.
A leaf pair is a capsule against a triangle: dropped when both ends of the axis
lie on one side of the triangle's plane, farther than the bound; else the exact
distance from the unit's axis to the triangle (0 where the axis pierces it;
otherwise the least of the axis' ends to the triangle and the axis to the
triangle's edges) less the radius. Every bound is a true lower bound widened by
rounding slack, so the walk drops no pair the exact test would find nearer: its
answers are those of the exact test on every pair. On the pipe against a
1,536-triangle torus of ``benchmarks/bench_poses.py`` the oriented boxes, the
plane test and the order cut the node pairs a yes/no pose takes from 97 to 32
where it finds a contact (exact leaf tests from 21 to 3) and from 147 to 50
where it proves none (27 to 2), and placing the chain's nodes when reached saves
the 2 us a pose spent moving all of them first (``docs/performance.md``).

Containment (a unit wholly inside the mesh, or the mesh inside a unit) is not
seen by the walk; :func:`cadpipe.collision.narrow.collide` adds it.
"""

import numpy as np

from cadpipe.collision.bounds import rounding_slack
from cadpipe.core.tree import BoxTree
from cadpipe.core.kernels import native


class TriangleTree:
    """Boxes over a mesh's triangles, in the mesh's frame.

    Parameters
    ----------
    vertices : (V, 3) float
    faces : (F, 3) int

    A perfect binary tree in heap order: leaf ``k`` (at depth ``depth``) holds
    triangle ``order[k]`` or none (-1), the triangles in the first leaves, and
    each node's triangles are split between its children at the median of their
    centroids along their longest extent (a quickselect per node,
    ``csrc/triangle_tree.c``: on the pipe against the torus a walk tests about
    30% fewer node pairs than over a Morton order of the centroids, whose boxes
    straddle the curve's jumps). ``boxes`` (nodes, 7)
    holds each node's ``lo``, ``hi`` and size (the sum of its extents);
    ``frames`` (nodes above the leaves, 15) each one's oriented box: centre
    (3), axes (3, 3, as rows, the thinnest first) and half extents (3);
    ``triangles`` (leaves, 9) the leaves' corners, row by row. A node without
    triangles has ``lo = inf``, ``hi = -inf`` (its frame is never read).
    """

    def __init__(self, vertices, faces):
        vertices = np.asarray(vertices, np.float64)
        corners = vertices[np.asarray(faces)]                               # (F, 3, 3)
        count = len(corners)
        # the one box tree, split at medians of the triangles' centroids, a triangle a leaf
        tree = BoxTree(corners.min(axis=1), corners.max(axis=1), order="median", leaf_size=1,
                       centres=corners.mean(axis=1))
        self.depth, leaves, order = tree.depth, tree.leaves, tree.order
        self.order = np.full(leaves, -1, np.int64)
        self.order[:count] = order
        self.triangles = np.zeros((leaves, 9))
        self.triangles[:count] = corners[order].reshape(count, 9)
        lo, hi = tree.node_lo, tree.node_hi
        # per node lo, hi and its size (the sum of its extents, for the walk's split rule)
        size = hi[:, 0] - lo[:, 0] + hi[:, 1] - lo[:, 1] + hi[:, 2] - lo[:, 2]
        self.boxes = np.ascontiguousarray(np.concatenate([lo, hi, size[:, None]], axis=1))
        # per node above the leaves an oriented box holding the corners of its
        # triangles, along their principal axes (the least spread first), widened by the
        # rounding slack; zeros for a node without a triangle. One compiled pass, its
        # 3x3 eigenvectors by Jacobi rotations: for a 327,680-triangle sphere 0.28 s of
        # CPU (numba's pass with LAPACK's eigenvectors 0.46 s, numpy's batched eigh and a
        # temporary per level 0.9)
        self.frames = np.empty((leaves - 1, 15))
        native.triangle_frames(self.triangles, count, self.depth,
                               rounding_slack(corners.reshape(-1, 3)), self.frames)


def segment_triangle(a, b, t, near, far):
    """Distance from segment ``a``-``b`` (3,) to triangle ``t`` (9,), with the
    closest points written to ``near`` (on the segment) and ``far`` (on the
    triangle). 0 where the segment pierces the triangle. The walk's leaf test
    (``csrc/distance.h``), for one segment and triangle."""
    a, b, t = (_f64(v).reshape(-1) for v in (a, b, t))
    on_segment, on_triangle = np.empty(3), np.empty(3)
    d = native.segment_triangle(a, b, t, on_segment, on_triangle)
    near[...], far[...] = on_segment, on_triangle
    return d


def walk(boxes, frames, triangles, depth_m, table, index, points, depth_c, poses, yes_no, gap,
         unit, near, far):
    """For each pose ``poses[p]`` (the chain in the mesh's frame): the least
    capsule-triangle gap into ``gap[p]``, its unit into ``unit[p]`` and the
    closest points (on the unit's axis, on the triangle; mesh frame) into
    ``near[p]``, ``far[p]``. With ``yes_no`` a pose stops at its first gap <= 0
    (``gap`` is then that gap; where none is, a positive number that need not
    be the least). ``table``, ``index``, ``points``, ``depth_c``: the chain's
    :class:`~cadpipe.collision.hierarchy.CapsuleTree` packed; ``boxes``,
    ``frames``, ``triangles``, ``depth_m``: the :class:`TriangleTree`. The
    outputs are C-ordered arrays (float64, int64 for ``unit``), written in place;
    one compiled walk (``csrc/chain_mesh.c``) for all poses.
    """
    native.mesh_walk(_f64(boxes), _f64(frames), _f64(triangles), int(depth_m), _f64(table),
                     np.ascontiguousarray(index, np.int64), _f64(points), int(depth_c),
                     _f64(poses).reshape(-1, 4, 4), bool(yes_no), gap, unit, near, far)


def _f64(value):
    return np.ascontiguousarray(value, np.float64)
