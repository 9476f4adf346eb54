"""Faces of a mesh that cut through each other (self-intersections).

Broad phase: the box tree of the triangles (:class:`~cadpipe.geometry.boxtree.BoxTree`:
Morton order, leaves of :data:`~cadpipe.geometry.boxtree.LEAF` triangles, heap-ordered
nodes). Each leaf is then queried against the tree in one compiled loop (numba,
like the collision kernels), which tests the triangle pairs of overlapping leaves
as it finds them: a million triangles take about a second, where a level-by-level
numpy expansion of every node pair spent most of its time gathering boxes of
pairs that share a vertex.

Narrow phase: two triangles that share no vertex intersect when an edge of
one passes through the interior of the other. Touching (within
:func:`touching_tolerance`) does not count, and neither do neighbouring faces that
share a vertex or coplanar overlaps (those show up as non-manifold edges).
"""

import numba
import numpy as np

from cadpipe.geometry.boxtree import LEAF, BoxTree
from cadpipe.solids.booleans import float32_step

_jit = numba.njit(cache=True, nogil=True)


def self_intersections(mesh):
    """(K, 2) int array of face index pairs ``i < j`` whose triangles cut through each other,
    sorted by ``i`` then ``j``."""
    faces = mesh.faces
    if len(faces) < 2:
        return np.empty((0, 2), np.int64)
    tri = np.ascontiguousarray(mesh.triangles)
    tree = BoxTree.of_triangles(tri)
    found = _traverse(*tree.arrays(), True, tri, np.ascontiguousarray(faces),
                      np.ascontiguousarray(mesh.face_normals), touching_tolerance(mesh))
    return found[np.lexsort((found[:, 1], found[:, 0]))]


def touching_tolerance(mesh):
    """Distance below which faces touch rather than cross: 1e-9 of the mesh's size, or,
    for coordinates a file rounded to float32 (:func:`float32_coordinates`: STL, GLB,
    USD, and the decimal text of 3MF and OBJ), a few float32 steps at the mesh's
    largest coordinate, so that rounding a solid that touches itself (two arm links
    meeting tangentially) does not turn it into one that crosses itself. Crossings
    deeper than that are representable in the file, and found."""
    tol = 1e-9 * float(np.linalg.norm(mesh.bounds[1] - mesh.bounds[0]))
    if len(mesh.vertices) and float32_coordinates(mesh.vertices):
        tol = max(tol, 2 * float32_step(mesh.bounds))
    return tol


def float32_coordinates(points):
    """Are ``points`` float32 values, or their decimals printed with 9 significant digits
    (as cadpipe writes 3MF and OBJ: each within a twelfth of a float32 step of its
    value)? Every one within a quarter step of a float32 counts; coordinates computed
    in float64 lie anywhere within half a step, so many of them never pass."""
    rounded = points.astype(np.float32)
    return bool((np.abs(points - rounded) <= 0.25 * np.spacing(np.abs(rounded))).all())


def box_pairs(lo, hi):
    """(M, 2) int array of index pairs ``i != j`` of boxes that overlap, each pair once.

    ``lo``, ``hi``: (N, 3) box corners. Touching boxes count as overlapping.
    """
    if len(lo) < 2:
        return np.empty((0, 2), np.int64)
    none = np.empty((0, 3, 3))
    return _traverse(*BoxTree(lo, hi).arrays(), False, none, np.empty((0, 3), np.int64),
                     np.empty((0, 3)), 0.0)


@_jit
def _overlap(lo, hi, a, blo, bhi, b):
    for axis in range(3):
        if lo[a, axis] > bhi[b, axis] or blo[b, axis] > hi[a, axis]:
            return False
    return True


@_jit
def _traverse(node_lo, node_hi, lo, hi, order, n, narrow, tri, faces, normals, tol):
    """Overlapping box pairs (original indices), or with ``narrow`` the crossing
    triangle pairs among them ``(min, max)``: the tree against itself, node pairs
    ``a <= b`` of one level at a time, so each pair is met once."""
    leaves = len(node_lo) // 2
    out = np.empty((1024, 2), np.int64)
    count = 0
    stack = np.empty((256, 3), np.int64)
    stack[0, 0], stack[0, 1], stack[0, 2] = 1, 1, leaves    # node a, node b, leaves under each
    top = 1
    while top:
        top -= 1
        a, b, span = stack[top, 0], stack[top, 1], stack[top, 2]
        if a != b and not _overlap(node_lo, node_hi, a, node_lo, node_hi, b):
            continue
        if span > 1:
            for ca in range(2 * a, 2 * a + 2):
                for cb in range(max(ca, 2 * b), 2 * b + 2):
                    stack[top, 0], stack[top, 1], stack[top, 2] = ca, cb, span // 2
                    top += 1
            continue
        first, second = (a - leaves) * LEAF, (b - leaves) * LEAF
        for i in range(first, min(n, first + LEAF)):
            for j in range(i + 1 if a == b else second, min(n, second + LEAF)):
                if not _overlap(lo, hi, i, lo, hi, j):
                    continue
                p, q = order[i], order[j]
                if narrow:
                    if not _cross(tri, faces, normals, tol, p, q):
                        continue
                    p, q = min(p, q), max(p, q)
                if count == len(out):
                    grown = np.empty((2 * len(out), 2), np.int64)
                    grown[:count] = out
                    out = grown
                out[count, 0], out[count, 1] = p, q
                count += 1
    return out[:count].copy()


@_jit
def _cross(tri, faces, normals, tol, a, b):
    """Do triangles ``a`` and ``b`` (sharing no vertex) cut through each other?"""
    for k in range(3):
        for m in range(3):
            if faces[a, k] == faces[b, m]:
                return False                        # neighbours: touching, not crossing
    # signed distances of each triangle's corners from the other's plane; a
    # triangle wholly on one side of the other's plane cannot cut it (most pairs)
    da, db = np.empty(3), np.empty(3)
    for k in range(3):
        db[k] = _plane(tri[b, k], tri[a, 0], normals[a])
        da[k] = _plane(tri[a, k], tri[b, 0], normals[b])
    if not (_straddles(da, tol) and _straddles(db, tol)):
        return False
    return (_edges_pierce(tri[b], db, tri[a], normals[a], tol)
            or _edges_pierce(tri[a], da, tri[b], normals[b], tol))


@_jit
def _plane(point, origin, normal):
    return ((point[0] - origin[0]) * normal[0] + (point[1] - origin[1]) * normal[1]
            + (point[2] - origin[2]) * normal[2])


@_jit
def _straddles(d, tol):
    """The three signed distances ``d`` are not all on one side (beyond ``tol``)."""
    above = d[0] > tol and d[1] > tol and d[2] > tol
    below = d[0] < -tol and d[1] < -tol and d[2] < -tol
    return not (above or below)


@_jit
def _edges_pierce(edges_of, d, target, normal, tol):
    """Does an edge of triangle ``edges_of`` (3, 3) cross the interior of ``target``?

    ``d``: (3,) signed distances of ``edges_of``'s corners from the plane of
    ``target``; ``normal``: its unit normal. The crossing point must lie inside
    the target, beyond ``tol`` from each of its sides.
    """
    point = np.empty(3)
    for e in range(3):
        ds, de = d[e], d[(e + 1) % 3]
        if not ((ds > tol and de < -tol) or (ds < -tol and de > tol)):
            continue
        t = ds / (ds - de)
        for c in range(3):
            point[c] = edges_of[e, c] + t * (edges_of[(e + 1) % 3, c] - edges_of[e, c])
        inside = True
        for s in range(3):
            u, v = target[s], target[(s + 1) % 3]
            sx, sy, sz = v[0] - u[0], v[1] - u[1], v[2] - u[2]
            px, py, pz = point[0] - u[0], point[1] - u[1], point[2] - u[2]
            inward = ((sy * pz - sz * py) * normal[0] + (sz * px - sx * pz) * normal[1]
                      + (sx * py - sy * px) * normal[2])
            if not inward > tol * np.sqrt(sx * sx + sy * sy + sz * sz):
                inside = False
                break
        if inside:
            return True
    return False
