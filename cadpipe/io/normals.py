"""Shading normals with a crease angle: round tubes shade smooth, edges stay sharp.

A cadpipe pipe is a polygon standing in for a circle, so a 16-sided tube should
shade round; but its flat caps, the edges of a square duct and the seams where
a boolean joined two tubes are real edges. The rule (the "auto smooth" of DCC
tools): at each corner of a face, average the normals (weighted by corner
angle) of the faces around that vertex that lie within ``crease_angle`` of the
face's own normal. With the default 35 degrees a tube of 11 or more sides (at
most 33 degrees between neighbouring sides) shades round, one of 10 or fewer
keeps its facets, and caps keep a hard rim.

Vertices where all faces agree (the great majority) keep one normal; only
vertices on a crease compare their faces pairwise and get extra normals, so the
cost and the output stay close to one normal per vertex. The work is three
compiled passes over the faces (numba, as the collision kernels): numpy's
dozen full-size passes over every corner cost several times the plain write
of a GLB. The result is cached on the mesh (an immutable value) per crease
angle, so a scene written as USD and GLB computes it once.
"""

from typing import NamedTuple

import numba
import numpy as np

from cadpipe._rows import unique_rows
from cadpipe.errors import InputError

DEFAULT_CREASE_ANGLE = 35.0

_jit = numba.njit(cache=True, nogil=True)


class Shading(NamedTuple):
    """Normals of a mesh: one per vertex, plus extra ones at the corners on creases.

    ``normals[:V]`` are the vertices' own normals; the corners ``corners`` (flat
    indices into ``faces.ravel()``) take ``normals[rows]`` instead.
    """

    normals: np.ndarray     #: (V + E, 3) float32 unit normals
    faces: np.ndarray       #: (F, 3) the mesh's faces
    corners: np.ndarray     #: (K,) int64 corners on a crease
    rows: np.ndarray        #: (K,) int64 their rows in ``normals`` (>= V)

    @property
    def per_vertex(self):
        """True when there are no creases: ``normals`` has one row per vertex."""
        return len(self.corners) == 0

    @property
    def corner_index(self):
        """(3F,) int32 (int64 past 2**31 rows) row of ``normals`` at each corner of
        ``faces.ravel()``."""
        large = len(self.normals) >= 2**31
        index = self.faces.astype(np.int64 if large else np.int32).ravel()
        index[self.corners] = self.rows
        return index


def shading_normals(mesh, crease_angle=DEFAULT_CREASE_ANGLE):
    """Normals for rendering ``mesh``: a :class:`Shading` (cached on the mesh).

    Parameters
    ----------
    mesh : Mesh
    crease_angle : float
        Degrees in [0, 180]: faces meeting at a sharper angle keep a hard edge.
        0 gives faceted shading, 180 fully smooth vertex normals.
    """
    angle = float(crease_angle)
    if not 0.0 <= angle <= 180.0:
        raise InputError(f"crease_angle: expected degrees in [0, 180], got {crease_angle!r}")
    memo = mesh.__dict__.setdefault("_shading_normals", {})
    if angle not in memo:
        memo[angle] = _shading(mesh, angle)
    return memo[angle]


def _shading(mesh, angle):
    vertices = np.ascontiguousarray(mesh.vertices, np.float64)
    faces = np.ascontiguousarray(mesh.faces)
    vertex_normals = np.zeros((len(vertices), 3))
    _vertex_normals(vertices, faces, vertex_normals)
    # a vertex is smooth when every face around it is within half the angle of its
    # normal: then any two of those faces are within the full angle of each other
    on_crease = np.zeros(len(vertices), bool)
    _on_crease(vertices, faces, vertex_normals, np.cos(np.radians(angle / 2)), on_crease)
    normals = vertex_normals.astype(np.float32)
    if not on_crease.any():
        none = np.empty(0, np.int64)
        return Shading(normals, mesh.faces, none, none)
    corners, summed = _crease_corners(vertices, faces, on_crease,
                                      np.cos(np.radians(angle)) - 1e-6)
    # corners of one smoothing group sum the same faces in the same order: equal rows,
    # shared (with equal normals elsewhere) as one extra normal
    summed = summed.astype(np.float32) + np.float32(0.0)
    first, which = unique_rows(summed.view(np.int32).astype(np.int64))
    return Shading(np.concatenate([normals, summed[first]]), mesh.faces, corners,
                   len(vertices) + which)


@_jit
def _face_normal(vertices, faces, f):
    """Unit normal of face ``f`` (zero if degenerate) and twice its area."""
    i, j, k = faces[f, 0], faces[f, 1], faces[f, 2]
    ax, ay, az = (vertices[j, 0] - vertices[i, 0], vertices[j, 1] - vertices[i, 1],
                  vertices[j, 2] - vertices[i, 2])            # corner 0 -> 1
    cx, cy, cz = (vertices[i, 0] - vertices[k, 0], vertices[i, 1] - vertices[k, 1],
                  vertices[i, 2] - vertices[k, 2])            # corner 2 -> 0
    nx, ny, nz = -(ay * cz - az * cy), -(az * cx - ax * cz), -(ax * cy - ay * cx)
    twice_area = np.sqrt(nx * nx + ny * ny + nz * nz)
    if twice_area > 0:
        return nx / twice_area, ny / twice_area, nz / twice_area, twice_area
    return 0.0, 0.0, 0.0, 0.0


@_jit
def _face(vertices, faces, f):
    """Unit normal (zero if degenerate) and the three corner angles of face ``f``:
    ``(nx, ny, nz, angle0, angle1, angle2)``.

    Weighting by corner angle (not face area) makes a vertex normal independent
    of how the surface around it is cut into triangles: a tube vertex gets the
    radial normal whichever way its quads were split. Every corner's edge cross
    product has the length ``2 * area``, so only the dot products differ.
    """
    nx, ny, nz, twice_area = _face_normal(vertices, faces, f)
    i, j, k = faces[f, 0], faces[f, 1], faces[f, 2]
    # the angle at a corner: between the edge leaving it and the one arriving, reversed
    # (the three sum to pi: two arctangents do; a degenerate face weighs nothing)
    dot0, dot1 = 0.0, 0.0
    for c in range(3):
        dot0 += (vertices[j, c] - vertices[i, c]) * (vertices[k, c] - vertices[i, c])
        dot1 += (vertices[k, c] - vertices[j, c]) * (vertices[i, c] - vertices[j, c])
    angle0, angle1 = _angle(twice_area, dot0), _angle(twice_area, dot1)
    return nx, ny, nz, angle0, angle1, np.pi - angle0 - angle1


@_jit
def _angle(y, x):
    """``arctan2(y, x)`` for ``y >= 0`` to float32 accuracy (Cephes' ``atanf``
    polynomial after reducing to [0, tan(pi / 8)]): the weights need no more,
    and the library arctangent was most of the normals' cost."""
    if y == 0.0 and x == 0.0:
        return 0.0
    flip = y > abs(x)                       # beyond 45 degrees: pi / 2 - atan(|x| / y)
    t = abs(x) / y if flip else y / abs(x)
    base = 0.0
    if t > 0.41421356237309503:             # tan(pi / 8): atan(t) = pi / 4 + atan((t-1)/(t+1))
        t = (t - 1.0) / (t + 1.0)
        base = np.pi / 4
    z = t * t
    a = base + ((((8.05374449538e-2 * z - 1.38776856032e-1) * z + 1.99777106478e-1) * z
                 - 3.33329491539e-1) * z * t + t)
    if flip:
        a = np.pi / 2 - a
    return np.pi - a if x < 0 else a


@_jit
def _vertex_normals(vertices, faces, summed):
    """Fill ``summed`` (V, 3) float64 zeros with the unit angle-weighted normals of the
    vertices (zero where unused)."""
    for f in range(len(faces)):
        nx, ny, nz, a0, a1, a2 = _face(vertices, faces, f)
        for k in range(3):
            weight = a0 if k == 0 else a1 if k == 1 else a2
            v = faces[f, k]
            summed[v, 0] += nx * weight
            summed[v, 1] += ny * weight
            summed[v, 2] += nz * weight
    for v in range(len(summed)):
        length = np.sqrt(summed[v, 0] ** 2 + summed[v, 1] ** 2 + summed[v, 2] ** 2)
        if length > 0:
            for c in range(3):
                summed[v, c] /= length


@_jit
def _on_crease(vertices, faces, vertex_normals, cos_half, crease):
    """Set ``crease`` (V,) where some face at the vertex is more than half the angle off
    its normal."""
    for f in range(len(faces)):
        nx, ny, nz, _ = _face_normal(vertices, faces, f)
        for k in range(3):
            v = faces[f, k]
            if (nx * vertex_normals[v, 0] + ny * vertex_normals[v, 1]
                    + nz * vertex_normals[v, 2]) < cos_half:
                crease[v] = True


@_jit
def _crease_corners(vertices, faces, on_crease, cos_full):
    """The corners at crease vertices (flat indices into ``faces.ravel()``) and, for
    each, the unit angle-weighted sum of the normals of the faces at its vertex
    within the full angle of its own face's (the corners of degenerate faces,
    whose sum is zero, are left out: they keep the vertex normal)."""
    n_vertices = len(vertices)
    start = np.zeros(n_vertices + 1, np.int64)               # corners per crease vertex
    for f in range(len(faces)):
        for k in range(3):
            if on_crease[faces[f, k]]:
                start[faces[f, k] + 1] += 1
    for v in range(n_vertices):
        start[v + 1] += start[v]
    filled = start[:-1].copy()
    corner = np.empty(start[-1], np.int64)
    normal = np.empty((start[-1], 3))
    weight = np.empty(start[-1])
    for f in range(len(faces)):
        for k in range(3):
            v = faces[f, k]
            if on_crease[v]:
                nx, ny, nz, a0, a1, a2 = _face(vertices, faces, f)
                angle = a0 if k == 0 else a1 if k == 1 else a2
                i = filled[v]
                corner[i] = 3 * f + k
                normal[i, 0], normal[i, 1], normal[i, 2] = nx, ny, nz
                weight[i] = angle
                filled[v] += 1
    summed = np.zeros((len(corner), 3))
    found = np.zeros(len(corner), np.bool_)
    for v in range(n_vertices):
        for i in range(start[v], start[v + 1]):
            for j in range(start[v], start[v + 1]):
                if (normal[i, 0] * normal[j, 0] + normal[i, 1] * normal[j, 1]
                        + normal[i, 2] * normal[j, 2]) >= cos_full:
                    for c in range(3):
                        summed[i, c] += normal[j, c] * weight[j]
            length = np.sqrt(summed[i, 0] ** 2 + summed[i, 1] ** 2 + summed[i, 2] ** 2)
            if length > 0:
                found[i] = True
                for c in range(3):
                    summed[i, c] /= length
    return corner[found], summed[found]


def split_for_normals(mesh, crease_angle=DEFAULT_CREASE_ANGLE):
    """Vertices, faces and per-vertex normals for formats with one normal per vertex (glTF).

    A vertex on a crease is split into one copy per distinct corner normal, so
    hard edges stay hard; faces keep their order (``face_part`` still applies).
    Returned in the types glTF stores, so a writer copies nothing more.

    Returns
    -------
    vertices : (V', 3) float32 array
    faces : (F, 3) uint32 array
    normals : (V', 3) float32 array
    """
    shading = shading_normals(mesh, crease_angle)
    if shading.per_vertex:
        return (mesh.vertices.astype(np.float32), mesh.faces.astype(np.uint32),
                shading.normals)
    # only corners with an extra (crease) normal need a new vertex: one per distinct
    # (vertex, normal) pair among them; every other corner keeps its vertex
    vertex = mesh.faces.ravel()[shading.corners]
    first, pair = unique_rows(np.column_stack([vertex, shading.rows, np.zeros_like(vertex)]))
    return _split(mesh.vertices, mesh.faces, shading.normals, shading.corners, pair,
                  vertex[first], shading.rows[first])


def _split(vertices, faces, normals, corners, pair, pair_vertex, pair_normal):
    """The split mesh, written straight into glTF's types. ``corners`` move to their
    ``pair`` (vertex ``pair_vertex`` with normal ``pair_normal``): the first pair of a
    vertex takes the vertex's own slot, unless a corner there keeps the vertex
    normal (a degenerate face's); every other pair is a new vertex at the end.
    (Outputs are allocated by numpy, which asks the kernel for huge pages: fresh
    memory the kernels allocate costs more in page faults than their work.)"""
    out = np.empty((len(faces), 3), np.uint32)
    target = np.empty(len(pair_vertex), np.int64)
    count = _split_faces(faces, len(vertices), corners, pair, pair_vertex, out, target,
                         np.zeros(3 * len(faces), bool), np.zeros(len(vertices), bool))
    points, shading = np.empty((count, 3), np.float32), np.empty((count, 3), np.float32)
    points[:len(vertices)] = vertices
    shading[:len(vertices)] = normals[:len(vertices)]
    points[target] = vertices[pair_vertex]
    shading[target] = normals[pair_normal]
    return points, out, shading


@_jit
def _split_faces(faces, n_old, corners, pair, pair_vertex, out, target, moved, keeps):
    """Fill ``out`` (F, 3) with ``faces`` and each pair's ``target`` vertex; the count
    of vertices. ``moved`` (3F,) and ``keeps`` (V,) are zeroed scratch."""
    for i in range(len(corners)):
        moved[corners[i]] = True
    for f in range(len(faces)):
        for k in range(3):
            v = faces[f, k]
            out[f, k] = v
            if not moved[3 * f + k]:
                keeps[v] = True                      # a corner there keeps the vertex
    count = n_old
    for p in range(len(pair_vertex)):                # pairs come in first-seen order
        v = pair_vertex[p]
        if keeps[v]:
            target[p] = count
            count += 1
        else:
            target[p] = v
            keeps[v] = True                          # later pairs of v are copies
    for i in range(len(corners)):
        out[corners[i] // 3, corners[i] % 3] = target[pair[i]]
    return count
