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
cost and the output stay close to one normal per vertex.
"""

from typing import NamedTuple

import numpy as np

from cadpipe.errors import InputError
from cadpipe.geometry.ragged import Groups

DEFAULT_CREASE_ANGLE = 35.0


class Shading(NamedTuple):
    """Normals of a mesh, indexed per face corner.

    ``normals[corner_index[k]]`` is the normal at corner ``k`` of ``faces.ravel()``.
    When ``per_vertex`` is true there are no creases: ``normals`` has one row per
    vertex and ``corner_index`` is ``faces.ravel()``.
    """

    normals: np.ndarray
    corner_index: np.ndarray
    per_vertex: bool


def _unit(vectors):
    length = np.sqrt(np.einsum("ij,ij->i", vectors, vectors))[:, None]
    return np.divide(vectors, length, out=np.zeros_like(vectors), where=length > 0)


def _group_sum(labels, weights, count):
    """Sum the rows of ``weights`` (N, 3) per label in ``[0, count)``."""
    return np.stack([np.bincount(labels, weights[:, i], minlength=count) for i in range(3)],
                    axis=1)


def _faces_and_corners(mesh):
    """Unit face normals (3, F) and corner angles (3, F) in float32, coordinate-major.

    ``angles[k, f]`` is the angle at corner ``k`` of face ``f``. Weighting by corner
    angle (not face area) makes a vertex normal independent of how the surface
    around it is cut into triangles: a tube vertex gets the radial normal
    whichever way its quads were split. Every corner's edge cross product has
    the length ``2 * area``, so only the dot products differ. One contiguous
    row per coordinate and corner, in float32, keeps a million triangles fast.
    """
    coords = np.ascontiguousarray(np.asarray(mesh.vertices, dtype=np.float32).T)   # (3, V)
    p = np.take(coords, mesh.faces.T, axis=1)         # (3 coords, 3 corners, F)
    edge = p[:, [1, 2, 0]] - p                        # edge k runs from corner k to k + 1
    u, w = edge[:, 0], -edge[:, 2]                    # corner 0 -> 1 and corner 0 -> 2
    cross = np.stack([u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2],
                      u[0] * w[1] - u[1] * w[0]])
    twice_area = np.sqrt((cross * cross).sum(axis=0))
    normals = np.divide(cross, twice_area, out=np.zeros_like(cross), where=twice_area > 0)
    dots = -(edge * edge[:, [2, 0, 1]]).sum(axis=0)   # (next edge) . -(previous edge)
    return normals, np.arctan2(twice_area, dots)


def shading_normals(mesh, crease_angle=DEFAULT_CREASE_ANGLE):
    """Normals for rendering ``mesh``: a :class:`Shading`.

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
    n_faces, n_vertices = len(mesh.faces), len(mesh.vertices)
    # corners in corner-major order: all first corners, then all second, then third
    corner_vertex = mesh.faces.T.ravel()
    face_normals, angles = _faces_and_corners(mesh)
    vertex_normals = np.empty((n_vertices, 3))
    for axis in range(3):
        vertex_normals[:, axis] = np.bincount(corner_vertex, (face_normals[axis] * angles).ravel(),
                                              minlength=n_vertices)
    vertex_normals = _unit(vertex_normals).astype(np.float32)
    # a vertex is smooth when every face around it is within half the angle of its
    # normal: then any two of those faces are within the full angle of each other
    deviation = sum(face_normals[axis] * vertex_normals[:, axis][mesh.faces.T]
                    for axis in range(3)).ravel()
    on_crease = np.zeros(n_vertices, bool)
    on_crease[corner_vertex[deviation < np.cos(np.radians(angle / 2))]] = True
    if not on_crease.any():
        return Shading(vertex_normals, mesh.faces.ravel(), True)

    corners = np.flatnonzero(on_crease[corner_vertex])
    corners = corners[np.argsort(corner_vertex[corners], kind="stable")]
    # corners of one crease vertex are now contiguous: pair each with all of its group
    _, start, size = np.unique(corner_vertex[corners], return_index=True, return_counts=True)
    group_start, group_size = np.repeat(start, size), np.repeat(size, size)
    runs = Groups(group_size)
    first = runs.index
    second = np.repeat(group_start, group_size) + runs.local()
    normal_of = face_normals[:, corners % n_faces].T             # (C, 3) face normal per corner
    near = (np.einsum("ij,ij->i", normal_of[first], normal_of[second])
            >= np.cos(np.radians(angle)) - 1e-6)
    weighted = normal_of * angles.ravel()[corners][:, None]
    summed = _unit(_group_sum(first[near], weighted[second[near]], len(corners)))
    found = np.einsum("ij,ij->i", summed, summed) > 0   # degenerate faces: keep the vertex normal
    # corners of one smoothing group sum the same faces in the same order: equal rows
    extra, which = np.unique(summed[found], axis=0, return_inverse=True)
    corner_index = corner_vertex.copy()
    corner_index[corners[found]] = n_vertices + which.ravel()
    return Shading(np.concatenate([vertex_normals, extra.astype(np.float32)]),
                   corner_index.reshape(3, n_faces).T.ravel(), False)


def split_for_normals(mesh, crease_angle=DEFAULT_CREASE_ANGLE):
    """Vertices, faces and per-vertex normals for formats with one normal per vertex (glTF).

    A vertex on a crease is split into one copy per distinct corner normal, so
    hard edges stay hard; faces keep their order (``face_part`` still applies).

    Returns
    -------
    vertices : (V', 3) float array
    faces : (F, 3) int array
    normals : (V', 3) float array
    """
    shading = shading_normals(mesh, crease_angle)
    if shading.per_vertex:
        return mesh.vertices, mesh.faces, shading.normals
    key = mesh.faces.ravel() * len(shading.normals) + shading.corner_index
    unique, inverse = np.unique(key, return_inverse=True)
    vertex, normal = np.divmod(unique, len(shading.normals))
    return mesh.vertices[vertex], inverse.reshape(-1, 3), shading.normals[normal]
