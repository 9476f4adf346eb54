"""Faces of a mesh that cut through each other (self-intersections).

Broad phase: the box tree of the triangles (:class:`~cadpipe.core.tree.BoxTree`:
Morton order, leaves of :data:`~cadpipe.core.tree.LEAF` triangles, heap-ordered
nodes). Each leaf is then queried against the tree in one compiled loop (C,
``csrc/intersect.c``), which tests the triangle pairs of overlapping leaves
as it finds them: a million triangles take about a second, where a level-by-level
numpy expansion of every node pair spent most of its time gathering boxes of
pairs that share a vertex.

Narrow phase: two triangles that share no vertex intersect when an edge of
one passes through the interior of the other. Touching (within
:func:`touching_tolerance`) does not count, and neither do neighbouring faces that
share a vertex or coplanar overlaps (those show up as non-manifold edges).
"""

import numpy as np

from cadpipe.core.kernels import native
from cadpipe.core.tree import BoxTree
from cadpipe.core import float32


def self_intersections(mesh):
    """(K, 2) int array of face index pairs ``i < j`` whose triangles cut through each other,
    sorted by ``i`` then ``j``."""
    faces = mesh.faces
    if len(faces) < 2:
        return np.empty((0, 2), np.int64)
    tri = np.ascontiguousarray(mesh.triangles, np.float64)
    tree = BoxTree.of_triangles(tri)
    found = native.traverse(*tree.arrays(), True, tri, np.ascontiguousarray(faces, np.int64),
                            np.ascontiguousarray(mesh.face_normals, np.float64),
                            touching_tolerance(mesh))
    return found[np.lexsort((found[:, 1], found[:, 0]))]


def touching_tolerance(mesh):
    """Distance below which faces touch rather than cross: 1e-9 of the mesh's size, or,
    for coordinates a file rounded to float32 (:func:`cadpipe.core.float32.coordinates`: STL, GLB,
    USD, and the decimal text of 3MF and OBJ), a few float32 steps at the mesh's
    largest coordinate, so that rounding a solid that touches itself (two arm links
    meeting tangentially) does not turn it into one that crosses itself. Crossings
    deeper than that are representable in the file, and found."""
    tol = 1e-9 * float(np.linalg.norm(mesh.bounds[1] - mesh.bounds[0]))
    if len(mesh.vertices) and float32.coordinates(mesh.vertices):
        tol = max(tol, 2 * float32.step(mesh.bounds, float32.COLLAPSE))
    return tol


def box_pairs(lo, hi):
    """(M, 2) int array of index pairs ``i != j`` of boxes that overlap, each pair once.

    ``lo``, ``hi``: (N, 3) box corners. Touching boxes count as overlapping.
    """
    if len(lo) < 2:
        return np.empty((0, 2), np.int64)
    none = np.empty((0, 3, 3))
    return native.traverse(*BoxTree(lo, hi).arrays(), False, none, np.empty((0, 3), np.int64),
                           np.empty((0, 3)), 0.0)
