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
vertices on a crease compare their faces pairwise, and each further normal
there is a new row, so the output is one normal per vertex plus one per extra
(vertex, normal) pair: what glTF stores as split vertices, and what USD's
indexed normals take as they are. The work is two compiled passes over the
faces (C, ``csrc/normals.c``; a third, light one only when there are creases),
the first in blocks whose corner angles vectorize: numpy's dozen full-size
passes over every corner cost several times the plain write of a GLB. A pipe's mesh knows
its runs of rings (``Mesh.ring_runs``): its inner rings take their normals
from their ring neighbours in one lighter pass, checked against the faces
between them, and only the faces around end rings and caps go through the
general passes (:func:`_ring_shading`; 3 against 18 ms for a million
triangles). The result is cached on the mesh (an immutable value) per crease
angle, so a scene written as USD and GLB computes it once.
"""

from typing import NamedTuple

import numpy as np

from cadpipe.core.kernels import native
from cadpipe.errors import InputError
from cadpipe.geometry import buffers

DEFAULT_CREASE_ANGLE = 35.0
#: degrees: the faces around an inner ring vertex of a pipe lie within this of the
#: normal from its ring neighbours (else the general passes shade it)
RING_SPREAD = 15.0


class Shading(NamedTuple):
    """Normals of a mesh: one per vertex, plus a row per extra normal at a crease vertex.

    Corners not listed in ``corners`` take their vertex's row ``normals[v]``; the
    listed ones (flat indices into ``faces.ravel()``) take ``normals[rows]``, a row
    of vertex ``vertex[rows - V]``. Splitting each extra row off as a copy of its
    vertex gives a mesh with one normal per vertex (glTF's form).
    """

    normals: np.ndarray     #: (V + E, 3) float32 unit normals
    faces: np.ndarray       #: (F, 3) the mesh's faces
    corners: np.ndarray     #: (K,) int64 corners that take an extra row
    rows: np.ndarray        #: (K,) int64 their rows in ``normals`` (>= V)
    vertex: np.ndarray      #: (E,) int64 the vertex of each extra row

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
    runs = mesh.ring_runs
    if runs is not None:
        runs = runs[runs[:, 1] >= 3]                   # those with rings between their ends
        if len(runs):
            shading = _ring_shading(mesh, runs, angle)
            if shading is not None:
                return shading
    vertices = np.ascontiguousarray(mesh.vertices, np.float64)
    faces = np.ascontiguousarray(mesh.faces, np.int64)
    normals = np.zeros((len(vertices), 3), np.float32)
    face_normals = np.empty((len(faces), 3), np.float32)
    native.vertex_normals(vertices, faces, normals, face_normals)
    native.unit_rows(normals, 0, len(normals))
    # a vertex is smooth when every face around it is within half the angle of its
    # normal: then any two of those faces are within the full angle of each other
    on_crease = np.zeros(len(vertices), np.bool_)
    native.on_crease(face_normals, faces, normals, np.float32(np.cos(np.radians(angle / 2))),
                     on_crease)
    del face_normals
    none = np.empty(0, np.int64)
    if not on_crease.any():
        return Shading(normals, mesh.faces, none, none, none)
    extra, corners, rows, vertex = native.crease_rows(vertices, faces, normals, on_crease,
                                                      np.cos(np.radians(angle)) - 1e-6)
    return Shading(np.concatenate([normals, extra]), mesh.faces, corners, rows, vertex)


def _ring_shading(mesh, runs, angle):
    """:func:`_shading` of a mesh laid out in runs of rings (a pipe's), or None where
    the rings do not all shade smooth at this angle.

    The vertices of a run's inner rings (all but its first and last) take the normal
    of the surface through their four ring neighbours (the C kernel
    ``inner_ring_normals``, ``csrc/normals.c``): one light pass over those vertices in
    place of the angle-weighted sum over their six faces (on a straight round tube both
    are the radial direction). Every face at an inner vertex must lie within
    :data:`RING_SPREAD` (and half the angle) of its corners' normals, which keeps the
    two within that of each other and the crease rule's answer the same; else None.
    Only the faces around the other vertices (end rings, caps, seams) go through the
    general passes.
    """
    vertices = np.ascontiguousarray(mesh.vertices, np.float64)
    faces = np.ascontiguousarray(mesh.faces, np.int64)
    first, count, sides, band = runs.T
    span = 2 * sides                                            # faces per band
    # faces around the end rings: every face not in a run's bands, then the first
    # and last band of each run
    bands = np.column_stack([band, band + span * (count - 1)])
    order = np.argsort(bands[:, 0])
    starts = np.concatenate([[0], bands[order, 1]])
    stops = np.concatenate([bands[order, 0], [len(faces)]])
    others = _ranges(starts, stops)
    edge_bands = _ranges(np.concatenate([band, band + span * (count - 2)]),
                         np.concatenate([band + span, band + span * (count - 1)]))
    picked = np.sort(np.concatenate([others, edge_bands]))    # rows in corner order as
    some = faces[picked]                                       # :func:`_shading` has them
    # recycled memory (see geometry.buffers), with room for the extra rows of the crease
    # vertices (at most one per corner of ``some``): adding them copies no full-size array
    rows_room = buffers.empty((len(vertices) + 3 * len(some), 3), np.float32)
    normals = rows_room[:len(vertices)]
    inner_rows = np.sort(np.column_stack([first + sides, first + (count - 1) * sides]), axis=0)
    outer = list(zip(np.r_[0, inner_rows[:, 1]].tolist(),
                     np.r_[inner_rows[:, 0], len(normals)].tolist()))
    for start, stop in outer:                   # the inner rows are written below
        normals[start:stop] = 0.0
    face_normals = np.empty((len(some), 3), np.float32)
    native.vertex_normals(vertices, some, normals, face_normals)
    for start, stop in outer:
        native.unit_rows(normals, start, stop)
    inner = np.zeros(len(vertices), np.bool_)
    cos_spread = np.cos(np.radians(min(angle / 2, RING_SPREAD)))
    if not (native.inner_ring_normals(vertices, runs, normals, inner, cos_spread) and
            native.inner_faces_within(face_normals, some, normals, inner,
                                      np.float32(cos_spread),
                                      np.isin(picked, others, assume_unique=True))):
        return None
    on_crease = np.zeros(len(vertices), np.bool_)
    native.on_crease(face_normals, some, normals, np.float32(np.cos(np.radians(angle / 2))),
                     on_crease)
    none = np.empty(0, np.int64)
    if not on_crease.any():
        return Shading(normals, faces, none, none, none)
    if native.any_both(on_crease, inner, some):   # an inner ring's faces are not all in ``some``
        return None
    extra, corners, rows, vertex = native.crease_rows(vertices, some, normals, on_crease,
                                                      np.cos(np.radians(angle)) - 1e-6)
    rows_room[len(vertices):len(vertices) + len(extra)] = extra
    return Shading(rows_room[:len(vertices) + len(extra)], faces,
                   3 * picked[corners // 3] + corners % 3, rows, vertex)


def _ranges(starts, stops):
    """The integers of the ranges ``[starts[i], stops[i])``, one range after the other."""
    lengths = np.maximum(stops - starts, 0)
    return np.repeat(starts - np.cumsum(lengths) + lengths, lengths) + np.arange(lengths.sum())


def split_for_normals(mesh, crease_angle=DEFAULT_CREASE_ANGLE):
    """Vertices, faces and per-vertex normals for formats with one normal per vertex (glTF).

    A vertex on a crease is split into one copy per distinct corner normal, so
    hard edges stay hard; faces keep their order (``face_part`` still applies).
    Returned in the types glTF stores: the normals are the shading's own rows,
    the faces its corner rows.

    Returns
    -------
    vertices : (V', 3) float32 array
    faces : (F, 3) uint32 array
    normals : (V', 3) float32 array
    """
    shading = shading_normals(mesh, crease_angle)
    n_vertices = len(mesh.vertices)
    vertices = np.empty((len(shading.normals), 3), np.float32)
    vertices[:n_vertices] = mesh.vertices
    vertices[n_vertices:] = mesh.vertices[shading.vertex]
    index = shading.corner_index
    faces = (index.view(np.uint32) if index.dtype == np.int32 else index.astype(np.uint32))
    return vertices, faces.reshape(-1, 3), shading.normals
