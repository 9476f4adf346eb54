"""Shading normals with a crease angle: round tubes shade smooth, edges stay sharp.

A cadpipe pipe is a polygon standing in for a circle, so a 16-sided tube should
shade round; but its flat caps, the edges of a square duct and the seams where
a boolean joined two tubes are real edges. The rule (the "auto smooth" of DCC
tools): at each corner of a face, average the normals (weighted by corner angle) of the
faces around that vertex that lie within ``crease_angle`` of the face's own
normal. With the default 35 degrees a tube of 11 or more sides (at most 33
degrees between neighbouring sides) shades round, one of 10 or fewer keeps its
facets, and caps keep a hard rim.

Vertices where all faces agree (the great majority) take the plain vertex
normal; only vertices on a crease compare their faces pairwise, so the cost
stays linear in the mesh size.
"""

import numpy as np

from ..errors import InputError

DEFAULT_CREASE_ANGLE = 35.0


def _unit(vectors):
    length = np.sqrt(np.einsum("ij,ij->i", vectors, vectors))[:, None]
    return np.divide(vectors, length, out=np.zeros_like(vectors), where=length > 0)


def _group_sum(labels, weights, count):
    """Sum the rows of ``weights`` (N, 3) per label in ``[0, count)``."""
    return np.stack([np.bincount(labels, weights[:, i], minlength=count) for i in range(3)],
                    axis=1)


def _corner_angles(mesh):
    """(3F,) angle of each face corner, in ``faces.ravel()`` order.

    Weighting by corner angle (not face area) makes a vertex normal independent
    of how the surface around it is cut into triangles: a tube vertex gets the
    radial normal whichever way its quads were split.
    """
    tri = mesh.triangles
    to_next = np.roll(tri, -1, axis=1) - tri
    to_prev = np.roll(tri, 1, axis=1) - tri
    dot = np.einsum("fkc,fkc->fk", to_next, to_prev)
    cross = np.linalg.norm(np.cross(to_next, to_prev), axis=2)
    return np.arctan2(cross, dot).ravel()


def shading_normals(mesh, crease_angle=DEFAULT_CREASE_ANGLE):
    """Normals for rendering ``mesh``, and how they map onto it.

    Parameters
    ----------
    mesh : Mesh
    crease_angle : float
        Degrees in [0, 180]: faces meeting at a sharper angle keep a hard edge.
        0 gives faceted shading, 180 fully smooth vertex normals.

    Returns
    -------
    normals : (V, 3) or (3F, 3) float array
        Unit normals.
    interpolation : {"vertex", "faceVarying"}
        One normal per vertex when no vertex lies on a crease, else one per face corner
        (in ``faces.ravel()`` order), as USD names them.
    """
    angle = float(crease_angle)
    if not 0.0 <= angle <= 180.0:
        raise InputError(f"crease_angle: expected degrees in [0, 180], got {crease_angle!r}")
    faces = mesh.faces
    corner_vertex = faces.ravel()
    corner_face = np.repeat(np.arange(len(faces)), 3)
    face_normals = mesh.face_normals
    weighted = face_normals[corner_face] * _corner_angles(mesh)[:, None]
    vertex_normals = _unit(_group_sum(corner_vertex, weighted, len(mesh.vertices)))
    # a vertex is smooth when every face around it is within half the angle of its
    # normal: then any two of those faces are within the full angle of each other
    deviation = np.einsum("ij,ij->i", face_normals[corner_face], vertex_normals[corner_vertex])
    on_crease = np.zeros(len(mesh.vertices), bool)
    on_crease[corner_vertex[deviation < np.cos(np.radians(angle / 2))]] = True
    if not on_crease.any():
        return vertex_normals, "vertex"

    corner_normals = vertex_normals[corner_vertex]
    corners = np.flatnonzero(on_crease[corner_vertex])
    corners = corners[np.argsort(corner_vertex[corners], kind="stable")]
    # corners of one crease vertex are now contiguous: pair each with all of its group
    _, start, size = np.unique(corner_vertex[corners], return_index=True, return_counts=True)
    group_start, group_size = np.repeat(start, size), np.repeat(size, size)
    first = np.repeat(np.arange(len(corners)), group_size)
    offset = np.arange(len(first)) - np.repeat(np.cumsum(group_size) - group_size, group_size)
    second = np.repeat(group_start, group_size) + offset
    face_a, face_b = corner_face[corners[first]], corner_face[corners[second]]
    near = (np.einsum("ij,ij->i", face_normals[face_a], face_normals[face_b])
            >= np.cos(np.radians(angle)) - 1e-12)
    summed = _unit(_group_sum(first[near], weighted[corners[second[near]]], len(corners)))
    found = np.einsum("ij,ij->i", summed, summed) > 0       # degenerate faces keep the vertex normal
    corner_normals[corners[found]] = summed[found]
    return corner_normals, "faceVarying"


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
    normals, interpolation = shading_normals(mesh, crease_angle)
    if interpolation == "vertex":
        return mesh.vertices, mesh.faces, normals
    keys = np.column_stack([mesh.faces.ravel().astype(np.float64), normals])
    unique, inverse = np.unique(keys, axis=0, return_inverse=True)
    return (mesh.vertices[unique[:, 0].astype(np.int64)], inverse.reshape(-1, 3),
            unique[:, 1:])
