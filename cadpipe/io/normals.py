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
faces (numba; a third, light one only when there are creases), the first in
blocks whose corner angles vectorize: numpy's dozen full-size passes over
every corner cost several times the plain write of a GLB. A pipe's mesh knows
its runs of rings (``Mesh.ring_runs``): its inner rings take their normals
from their ring neighbours in one lighter pass, checked against the faces
between them, and only the faces around end rings and caps go through the
general passes (:func:`_ring_shading`; 3 against 21 ms for a million
triangles). The result is cached on the mesh (an immutable value) per crease
angle, so a scene written as USD and GLB computes it once.
"""

from typing import NamedTuple

import numba
import numpy as np

from cadpipe.errors import InputError
from cadpipe.geometry import buffers

DEFAULT_CREASE_ANGLE = 35.0
#: degrees: the faces around an inner ring vertex of a pipe lie within this of the
#: normal from its ring neighbours (else the general passes shade it)
RING_SPREAD = 15.0

# error_model="numpy": a division is not checked for zero (the kernels guard their own);
# fastmath without nnan/ninf: contractions and reassociation let the angle loop vectorize
_jit = numba.njit(cache=True, nogil=True, error_model="numpy",
                  fastmath={"contract", "arcp", "nsz", "reassoc", "afn"})
#: faces per block of :func:`_vertex_normals` (its block arrays stay in L1 cache)
_BLOCK = 512
#: odd minimax polynomial of arctan on [0, 1] (in powers of t**2), max error 3.8e-8 rad
_ATAN = (0.9999993355792427, -0.3332986078552379, 0.19946565651546788, -0.139086295105954,
         0.09642197156556104, -0.05591232372186997, 0.02186295538583439,
         -0.004054566441771568)
_A0, _A1, _A2, _A3, _A4, _A5, _A6, _A7 = _ATAN


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
    faces = np.ascontiguousarray(mesh.faces)
    normals = np.zeros((len(vertices), 3), np.float32)
    face_normals = np.empty((len(faces), 3), np.float32)
    _vertex_normals(vertices, faces, normals, face_normals)
    _unit_rows(normals, 0, len(normals))
    # a vertex is smooth when every face around it is within half the angle of its
    # normal: then any two of those faces are within the full angle of each other
    on_crease = np.zeros(len(vertices), np.bool_)
    _on_crease(face_normals, faces, normals, np.float32(np.cos(np.radians(angle / 2))),
               on_crease)
    del face_normals
    none = np.empty(0, np.int64)
    if not on_crease.any():
        return Shading(normals, mesh.faces, none, none, none)
    extra, corners, rows, vertex = _crease_rows(vertices, faces, normals, on_crease,
                                                np.cos(np.radians(angle)) - 1e-6)
    return Shading(np.concatenate([normals, extra]), mesh.faces, corners, rows, vertex)


def _ring_shading(mesh, runs, angle):
    """:func:`_shading` of a mesh laid out in runs of rings (a pipe's), or None where
    the rings do not all shade smooth at this angle.

    The vertices of a run's inner rings (all but its first and last) take the normal
    of the surface through their four ring neighbours (:func:`_inner_ring_normals`):
    one light pass over those vertices in place of the angle-weighted sum over their
    six faces (on a straight round tube both are the radial direction). Every face
    at an inner vertex must lie within :data:`RING_SPREAD` (and half the angle) of
    its corners' normals, which keeps the two within that of each other and the
    crease rule's answer the same; else None. Only the faces around the other
    vertices (end rings, caps, seams) go through the general passes.
    """
    vertices = np.ascontiguousarray(mesh.vertices, np.float64)
    faces = mesh.faces
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
    _vertex_normals(vertices, some, normals, face_normals)
    for start, stop in outer:
        _unit_rows(normals, start, stop)
    inner = np.zeros(len(vertices), np.bool_)
    cos_spread = np.cos(np.radians(min(angle / 2, RING_SPREAD)))
    if not (_inner_ring_normals(vertices, runs, normals, inner, cos_spread) and
            _inner_faces_within(face_normals, some, normals, inner, np.float32(cos_spread),
                                np.isin(picked, others, assume_unique=True))):
        return None
    on_crease = np.zeros(len(vertices), np.bool_)
    _on_crease(face_normals, some, normals, np.float32(np.cos(np.radians(angle / 2))),
               on_crease)
    none = np.empty(0, np.int64)
    if not on_crease.any():
        return Shading(normals, faces, none, none, none)
    if _any_both(on_crease, inner, some):   # an inner ring's faces are not all in ``some``
        return None
    extra, corners, rows, vertex = _crease_rows(vertices, some, normals, on_crease,
                                                np.cos(np.radians(angle)) - 1e-6)
    rows_room[len(vertices):len(vertices) + len(extra)] = extra
    return Shading(rows_room[:len(vertices) + len(extra)], faces,
                   3 * picked[corners // 3] + corners % 3, rows, vertex)


def _ranges(starts, stops):
    """The integers of the ranges ``[starts[i], stops[i])``, one range after the other."""
    lengths = np.maximum(stops - starts, 0)
    return np.repeat(starts - np.cumsum(lengths) + lengths, lengths) + np.arange(lengths.sum())


#: rings per chunk of :func:`_inner_ring_normals` (its component rows stay in cache)
_RINGS = 128


@_jit
def _inner_ring_normals(vertices, runs, normals, inner, cos_spread):
    """Set ``normals`` of the inner rings of ``runs`` from their ring neighbours, mark
    them in ``inner``; False where one is degenerate or a face between inner rings is
    more than the spread off a corner's normal.

    A vertex's normal is the chord around its ring crossed with the sum of its two
    unit edges along the tube (unit, so unequal segments do not tilt it). A chunk of
    rings at a time is copied into component rows, float32 about the chunk's first
    vertex (its edges keep 24 bits), each ring padded with its last vertex before it
    and its first after it: a vertex's neighbours are then the same positions of
    shifted rows, with no wrap to handle, so every loop runs over whole rows and
    vectorizes. The pads' own results are dropped.
    """
    cos2 = np.float32(cos_spread * cos_spread)
    off = 0                          # failed tests: faces off, degenerate normals
    for r in range(len(runs)):
        first, count, sides = runs[r, 0], runs[r, 1], runs[r, 2]
        w = sides + 2                                # a padded ring
        size = (_RINGS + 3) * w
        x, y, z = (np.empty(size, np.float32), np.empty(size, np.float32),
                   np.empty(size, np.float32))
        ex, ey, ez = (np.empty(size, np.float32), np.empty(size, np.float32),
                      np.empty(size, np.float32))
        nx, ny, nz = (np.empty(size, np.float32), np.empty(size, np.float32),
                      np.empty(size, np.float32))
        seam = np.ones(size, np.int64)
        seam[w - 1::w] = 0
        position = np.empty(_RINGS * sides, np.int64)   # of each vertex in padded rows
        for i in range(len(position)):
            position[i] = i // sides * w + i % sides + 1
        for j0 in range(1, count - 1, _RINGS):
            j1 = min(j0 + _RINGS, count - 1)          # inner rings j0..j1-1 written
            last = min(j1, count - 2)                 # normals of j0..last (one more to test)
            rings = last - j0 + 3                     # points: rings j0-1..last+1
            base = first + (j0 - 1) * sides
            _padded_rows(vertices, base, sides, rings, x, y, z)
            # unit edges from each point to the next ring's; then the normals of the
            # rings between the first and last row (normal row q: point row q + 1)
            _unit_edges(x, y, z, x[w:], y[w:], z[w:], ex, ey, ez, (rings - 1) * w)
            _ring_normals(x[w + 1:], y[w + 1:], z[w + 1:], x[w - 1:], y[w - 1:], z[w - 1:],
                          ex[w:], ey[w:], ez[w:], ex, ey, ez, nx, ny, nz, (rings - 2) * w)
            for n in (nx, ny, nz):                    # the pads' normals: their vertices'
                for q in range(rings - 2):
                    n[q * w] = n[q * w + sides]
                    n[q * w + w - 1] = n[q * w + 1]
            off += _bands_off(x, y, z, nx, ny, nz, sides, last - j0, cos2, seam)
            written = (j1 - j0) * w
            off += _degenerate(nx, ny, written)
            start, stop = first + j0 * sides, first + j1 * sides
            _from_padded(nx, ny, nz, normals[start:stop], position)
            inner[start:stop] = True
    return off == 0


@_jit
def _degenerate(nx, ny, m):
    """How many of normals ``[:m]`` are not finite (of a zero edge or chord)."""
    bad = 0
    for o in range(m):
        bad += not abs(nx[o]) + abs(ny[o]) < np.float32(2)
    return bad


@_jit
def _from_padded(nx, ny, nz, out, position):
    """``out`` (M, 3): the normals at ``position`` of padded component rows (a gather
    from cache and a write in order, which is faster than the scatter)."""
    for i in range(len(out)):
        o = position[i]
        out[i, 0], out[i, 1], out[i, 2] = nx[o], ny[o], nz[o]


@_jit
def _padded_rows(vertices, base, sides, rings, x, y, z):
    """Copy ``rings`` rings of ``sides`` vertices from row ``base`` into padded component
    rows (the ring's last vertex, the ring, its first), about the first vertex."""
    ox, oy, oz = vertices[base, 0], vertices[base, 1], vertices[base, 2]
    w = sides + 2
    for q in range(rings):
        ring, row = base + q * sides, q * w
        for k in range(sides):
            x[row + 1 + k] = vertices[ring + k, 0] - ox
            y[row + 1 + k] = vertices[ring + k, 1] - oy
            z[row + 1 + k] = vertices[ring + k, 2] - oz
        x[row], y[row], z[row] = x[row + sides], y[row + sides], z[row + sides]
        x[row + w - 1], y[row + w - 1], z[row + w - 1] = x[row + 1], y[row + 1], z[row + 1]


@_jit
def _unit_edges(ax, ay, az, bx, by, bz, ex, ey, ez, m):
    """``e[:m]``: the unit edges from points ``a`` to ``b`` (inf or NaN for a zero one)."""
    for o in range(m):
        dx, dy, dz = bx[o] - ax[o], by[o] - ay[o], bz[o] - az[o]
        scale = np.float32(1.0) / np.sqrt(dx * dx + dy * dy + dz * dz)
        ex[o], ey[o], ez[o] = dx * scale, dy * scale, dz * scale


@_jit
def _ring_normals(ax, ay, az, bx, by, bz, ux, uy, uz, dx, dy, dz, nx, ny, nz, m):
    """Unit normals ``n[:m]`` of points with ring neighbours after and before ``a``,
    ``b``, and unit edges along the tube to the next ring ``u`` and from the ring
    before ``d`` (inf or NaN where degenerate)."""
    for o in range(m):
        cx, cy, cz = ax[o] - bx[o], ay[o] - by[o], az[o] - bz[o]            # around
        wx, wy, wz = ux[o] + dx[o], uy[o] + dy[o], uz[o] + dz[o]            # along
        mx, my, mz = cy * wz - cz * wy, cz * wx - cx * wz, cx * wy - cy * wx
        scale = np.float32(1.0) / np.sqrt(mx * mx + my * my + mz * mz)
        nx[o], ny[o], nz[o] = mx * scale, my * scale, mz * scale


@_jit
def _bands_off(x, y, z, nx, ny, nz, sides, bands, cos2, seam):
    """How many corners of the first ``bands`` bands' triangles are more than the spread
    (``cos2``: its cosine squared) off their normals: ``f . n < cos |f|``, compared as
    squares with no root. Band ``q`` lies between point rows ``q + 1`` and ``q + 2``
    (normal rows ``q`` and ``q + 1``); its quad at ``a`` has the triangles (a, b, c)
    and (b, d, c), ``b`` next in the row, ``c`` and ``d`` in the next one.

    One loop over all the bands' positions, so that it vectorizes (a ring's few sides
    would not): the quad at a padded row's first position repeats its last real one,
    and ``seam`` (0 at a row's last position, 1 elsewhere) drops the one that spans
    two rows.
    """
    w = sides + 2
    return _quads_off(x[w:], y[w:], z[w:], x[w + 1:], y[w + 1:], z[w + 1:],
                      x[2 * w:], y[2 * w:], z[2 * w:], x[2 * w + 1:], y[2 * w + 1:],
                      z[2 * w + 1:], nx, ny, nz, nx[1:], ny[1:], nz[1:], nx[w:], ny[w:],
                      nz[w:], nx[w + 1:], ny[w + 1:], nz[w + 1:], seam, cos2, bands * w)


@_jit
def _quads_off(ax, ay, az, bx, by, bz, cx, cy, cz, dx, dy, dz, max_, may, maz, mbx, mby, mbz,
               mcx, mcy, mcz, mdx, mdy, mdz, seam, cos2, m):
    """:func:`_bands_off` of quads ``[:m]``, each corner ``a``..``d`` and its normal in
    arrays of its own (indexed by the loop alone, so the loads are contiguous)."""
    off = 0
    for o in range(m):
        off += seam[o] * (
            _triangle_off(ax[o], ay[o], az[o], bx[o], by[o], bz[o], cx[o], cy[o], cz[o],
                          max_[o], may[o], maz[o], mbx[o], mby[o], mbz[o],
                          mcx[o], mcy[o], mcz[o], cos2)
            + _triangle_off(bx[o], by[o], bz[o], dx[o], dy[o], dz[o], cx[o], cy[o], cz[o],
                            mbx[o], mby[o], mbz[o], mdx[o], mdy[o], mdz[o],
                            mcx[o], mcy[o], mcz[o], cos2))
    return off


@_jit
def _triangle_off(ix, iy, iz, jx, jy, jz, kx, ky, kz, mix, miy, miz, mjx, mjy, mjz, mkx, mky,
                  mkz, cos2):
    """How many corners of triangle ``i, j, k`` have a normal ``m`` more than the spread
    off the triangle's (``f . m < cos |f|``, squared)."""
    ax, ay, az = jx - ix, jy - iy, jz - iz
    bx, by, bz = kx - ix, ky - iy, kz - iz
    fx, fy, fz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
    bound = cos2 * (fx * fx + fy * fy + fz * fz)
    di = fx * mix + fy * miy + fz * miz
    dj = fx * mjx + fy * mjy + fz * mjz
    dk = fx * mkx + fy * mky + fz * mkz
    return (np.int64(di * abs(di) < bound) + np.int64(dj * abs(dj) < bound)
            + np.int64(dk * abs(dk) < bound))


@_jit
def _inner_faces_within(face_normals, faces, normals, inner, cos_spread, other):
    """False where a face at an inner ring vertex is more than the spread off its normal,
    or is ``other`` (not in a run's bands: its vertex normal would miss it)."""
    for f in range(len(faces)):
        for v in (faces[f, 0], faces[f, 1], faces[f, 2]):
            if inner[v] and (other[f] or face_normals[f, 0] * normals[v, 0]
                             + face_normals[f, 1] * normals[v, 1]
                             + face_normals[f, 2] * normals[v, 2] < cos_spread):
                return False
    return True


@_jit
def _angle(y, x):
    """``arctan2(y, x)`` for ``y >= 0`` to float32 accuracy, without branches (so a
    loop of them vectorizes): the weights need no more, and the library
    arctangent was most of the normals' cost."""
    ax = abs(x)
    t = min(y, ax) / max(max(y, ax), 1e-300)
    z = t * t
    a = t * (_A0 + z * (_A1 + z * (_A2 + z * (_A3 + z * (_A4 + z * (_A5 + z * (_A6 + z * _A7)))))))
    a = np.pi / 2 - a if y > ax else a
    return np.pi - a if x < 0 else a


@_jit
def _vertex_normals(vertices, faces, normals, face_normals):
    """Add to ``normals`` (V, 3) float32 zeros the vertices' normals before scaling
    (:func:`_unit_rows`): the faces' unit normals weighted by their corner angles; and
    fill ``face_normals`` (F, 3) float32 with the faces' (zero if degenerate).

    Weighting by corner angle (not face area) makes a vertex normal independent
    of how the surface around it is cut into triangles: a tube vertex gets the
    radial normal whichever way its quads were split. A block of faces at a
    time: gather the corners, then the angles (a vectorized loop), then add.
    """
    nx, ny, nz = np.empty(_BLOCK), np.empty(_BLOCK), np.empty(_BLOCK)
    dot0, dot1, weight0, weight1 = (np.empty(_BLOCK), np.empty(_BLOCK), np.empty(_BLOCK),
                                    np.empty(_BLOCK))
    for start in range(0, len(faces), _BLOCK):
        count = min(len(faces) - start, _BLOCK)
        for o in range(count):
            i, j, k = faces[start + o, 0], faces[start + o, 1], faces[start + o, 2]
            ax, ay, az = (vertices[j, 0] - vertices[i, 0], vertices[j, 1] - vertices[i, 1],
                          vertices[j, 2] - vertices[i, 2])          # corner 0 -> 1
            cx, cy, cz = (vertices[i, 0] - vertices[k, 0], vertices[i, 1] - vertices[k, 1],
                          vertices[i, 2] - vertices[k, 2])          # corner 2 -> 0
            bx, by, bz = -ax - cx, -ay - cy, -az - cz               # corner 1 -> 2
            nx[o], ny[o], nz[o] = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
            dot0[o] = -(ax * cx + ay * cy + az * cz)
            dot1[o] = -(ax * bx + ay * by + az * bz)
        for o in range(count):
            # every corner's edge cross product is 2 * area long: the angle at a corner
            # is atan2(2 * area, dot of its edges); the three sum to pi
            twice_area = np.sqrt(nx[o] * nx[o] + ny[o] * ny[o] + nz[o] * nz[o])
            scale = 1.0 / twice_area if twice_area > 0.0 else 0.0   # degenerate: weighs 0
            nx[o], ny[o], nz[o] = nx[o] * scale, ny[o] * scale, nz[o] * scale
            weight0[o], weight1[o] = _angle(twice_area, dot0[o]), _angle(twice_area, dot1[o])
        for o in range(count):
            w0, w1 = weight0[o], weight1[o]
            w2 = np.pi - w0 - w1
            face_normals[start + o, 0] = nx[o]
            face_normals[start + o, 1] = ny[o]
            face_normals[start + o, 2] = nz[o]
            i, j, k = faces[start + o, 0], faces[start + o, 1], faces[start + o, 2]
            normals[i, 0] += nx[o] * w0
            normals[i, 1] += ny[o] * w0
            normals[i, 2] += nz[o] * w0
            normals[j, 0] += nx[o] * w1
            normals[j, 1] += ny[o] * w1
            normals[j, 2] += nz[o] * w1
            normals[k, 0] += nx[o] * w2
            normals[k, 1] += ny[o] * w2
            normals[k, 2] += nz[o] * w2


@_jit
def _unit_rows(normals, start, stop):
    """Scale rows ``start:stop`` of ``normals`` to unit length (zero rows stay zero)."""
    for v in range(start, stop):
        length = np.sqrt(normals[v, 0] ** 2 + normals[v, 1] ** 2 + normals[v, 2] ** 2)
        scale = 1.0 / length if length > 0.0 else 0.0
        for c in range(3):
            normals[v, c] *= scale


@_jit
def _any_both(a, b, faces):
    """Whether a vertex of ``faces`` is set in both ``a`` and ``b``."""
    for f in range(len(faces)):
        for c in range(3):
            if a[faces[f, c]] and b[faces[f, c]]:
                return True
    return False


@_jit
def _face_normal(vertices, faces, f):
    """Unit normal of face ``f`` (zero if degenerate) and twice its area."""
    i, j, k = faces[f, 0], faces[f, 1], faces[f, 2]
    ax, ay, az = (vertices[j, 0] - vertices[i, 0], vertices[j, 1] - vertices[i, 1],
                  vertices[j, 2] - vertices[i, 2])
    bx, by, bz = (vertices[k, 0] - vertices[j, 0], vertices[k, 1] - vertices[j, 1],
                  vertices[k, 2] - vertices[j, 2])
    nx, ny, nz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
    twice_area = np.sqrt(nx * nx + ny * ny + nz * nz)
    if twice_area > 0:
        return nx / twice_area, ny / twice_area, nz / twice_area, twice_area
    return 0.0, 0.0, 0.0, 0.0


@_jit
def _on_crease(face_normals, faces, normals, cos_half, crease):
    """Set ``crease`` (V,) where some face at the vertex is more than half the angle off
    its normal (degenerate faces, of zero normal, count as off)."""
    for f in range(len(faces)):
        nx, ny, nz = face_normals[f, 0], face_normals[f, 1], face_normals[f, 2]
        for v in (faces[f, 0], faces[f, 1], faces[f, 2]):
            if nx * normals[v, 0] + ny * normals[v, 1] + nz * normals[v, 2] < cos_half:
                crease[v] = True


@_jit
def _corner_angle(vertices, faces, f, k):
    """The angle of face ``f`` at its corner ``k``."""
    i, j, m = faces[f, k], faces[f, (k + 1) % 3], faces[f, (k + 2) % 3]
    ux, uy, uz = (vertices[j, 0] - vertices[i, 0], vertices[j, 1] - vertices[i, 1],
                  vertices[j, 2] - vertices[i, 2])
    wx, wy, wz = (vertices[m, 0] - vertices[i, 0], vertices[m, 1] - vertices[i, 1],
                  vertices[m, 2] - vertices[i, 2])
    cx, cy, cz = uy * wz - uz * wy, uz * wx - ux * wz, ux * wy - uy * wx
    return _angle(np.sqrt(cx * cx + cy * cy + cz * cz), ux * wx + uy * wy + uz * wz)


@_jit
def _crease_rows(vertices, faces, normals, on_crease, cos_full):
    """The normals of the corners at crease vertices: the extra rows (E, 3) to append
    to ``normals`` (whose crease vertices' rows it updates), and ``(corners, rows,
    vertex)`` of a :class:`Shading`.

    Each corner there takes the unit angle-weighted sum of the normals of the faces
    at its vertex within the full angle of its own face's. Per vertex, the first
    distinct sum takes the vertex's own row and each further one a new row; a
    corner of a degenerate face (whose sum is zero) keeps the vertex normal, and
    then every sum takes a new row.
    """
    # the corners at crease vertices, grouped by vertex in corner order (counted first:
    # an array grown inside the loop costs reference counting on every corner)
    corners = faces.ravel()
    count = 0
    for c in range(len(corners)):
        count += on_crease[corners[c]]
    keys = np.empty(count, np.int64)
    count = 0
    for c in range(len(corners)):
        if on_crease[corners[c]]:
            keys[count] = corners[c] * len(corners) + c        # sorts by vertex, then corner
            count += 1
    keys.sort()
    vertex_of = keys // len(corners)
    corner = keys - vertex_of * len(corners)
    face_normal = np.empty((count, 3))
    weight = np.empty(count)
    for c in range(count):
        f, k = corner[c] // 3, corner[c] % 3
        nx, ny, nz, _ = _face_normal(vertices, faces, f)
        face_normal[c, 0], face_normal[c, 1], face_normal[c, 2] = nx, ny, nz
        weight[c] = _corner_angle(vertices, faces, f, k)
    summed = np.zeros((count, 3), np.float32)
    row = np.full(count, -1, np.int64)
    extra_of = np.empty(count, np.int64)          # the corner whose sum each extra row is
    n_vertices, extra = len(vertices), 0
    start = 0
    while start < count:
        stop = start
        while stop < count and vertex_of[stop] == vertex_of[start]:
            stop += 1
        v = vertex_of[start]
        slot_taken = False            # by a degenerate face's corner or the first sum
        for c in range(start, stop):
            sx, sy, sz = 0.0, 0.0, 0.0
            for d in range(start, stop):
                if (face_normal[c, 0] * face_normal[d, 0] + face_normal[c, 1] * face_normal[d, 1]
                        + face_normal[c, 2] * face_normal[d, 2]) >= cos_full:
                    sx += face_normal[d, 0] * weight[d]
                    sy += face_normal[d, 1] * weight[d]
                    sz += face_normal[d, 2] * weight[d]
            length = np.sqrt(sx * sx + sy * sy + sz * sz)
            if length > 0.0:
                summed[c, 0], summed[c, 1], summed[c, 2] = sx / length, sy / length, sz / length
            else:
                row[c] = v
                slot_taken = True
        for c in range(start, stop):
            if row[c] != -1:
                continue
            for d in range(start, c):    # an equal normal met before (never a zero one)
                if summed[d, 0] == summed[c, 0] and summed[d, 1] == summed[c, 1] and \
                        summed[d, 2] == summed[c, 2]:
                    row[c] = row[d]
                    break
            if row[c] != -1:
                continue
            if not slot_taken:                           # the first takes the vertex's row
                row[c] = v
                slot_taken = True
                normals[v, 0], normals[v, 1], normals[v, 2] = \
                    summed[c, 0], summed[c, 1], summed[c, 2]
            elif summed[c, 0] == normals[v, 0] and summed[c, 1] == normals[v, 1] and \
                    summed[c, 2] == normals[v, 2]:       # the vertex normal a degenerate
                row[c] = v                               # face's corner keeps
            else:
                row[c] = n_vertices + extra
                extra_of[extra] = c
                extra += 1
        start = stop
    moved = row >= n_vertices
    return summed[extra_of[:extra]], corner[moved], row[moved], vertex_of[extra_of[:extra]]


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
