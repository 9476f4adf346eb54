"""Transitional: the numba GJK of :mod:`cadpipe.collision.convex` before its C port.

``funnel.py`` and ``chain_mesh.py`` are being ported to C on another branch; until then
their numba kernels call :func:`body_gap` and :func:`nearest_on_triangle`, which numba
can only compile as numba functions. :mod:`cadpipe.collision.convex` hands these out
for those two imports alone; delete this file (and that hand-out) once they are C.
"""

import numba
import numpy as np

from cadpipe.collision.convex import CONVERGED, ITERATIONS, SLACK

_jit = numba.njit(cache=True, nogil=True, error_model="numpy")    # x / 0 is inf, not raised


@_jit
def _support(points, lo, hi, m, dx, dy, dz):
    """World support point (x, y, z) of the core points ``lo:hi`` placed by ``m``
    towards ``(dx, dy, dz)``."""
    ux = m[0, 0] * dx + m[1, 0] * dy + m[2, 0] * dz      # the direction in the piece's frame
    uy = m[0, 1] * dx + m[1, 1] * dy + m[2, 1] * dz
    uz = m[0, 2] * dx + m[1, 2] * dy + m[2, 2] * dz
    best, at = -np.inf, lo
    for s in range(lo, hi):
        v = ux * points[s, 0] + uy * points[s, 1] + uz * points[s, 2]
        if v > best:
            best, at = v, s
    x, y, z = points[at, 0], points[at, 1], points[at, 2]
    return (m[0, 0] * x + m[0, 1] * y + m[0, 2] * z + m[0, 3],
            m[1, 0] * x + m[1, 1] * y + m[1, 2] * z + m[1, 3],
            m[2, 0] * x + m[2, 1] * y + m[2, 2] * z + m[2, 3])


@_jit
def _segment(ax, ay, az, bx, by, bz):
    """Point of segment ab nearest the origin, and the corners that span it (bits 1, 2)."""
    ex, ey, ez = bx - ax, by - ay, bz - az
    t = -(ax * ex + ay * ey + az * ez)
    if t <= 0.0:
        return ax, ay, az, 1
    length = ex * ex + ey * ey + ez * ez
    if t >= length:
        return bx, by, bz, 2
    t /= length
    return ax + t * ex, ay + t * ey, az + t * ez, 3


@_jit
def nearest_on_triangle(ax, ay, az, bx, by, bz, cx, cy, cz):
    """Point of triangle abc nearest the origin, and the corners that span it (bits
    1, 2, 4): the Voronoi regions of its corners, edges and face in turn (Ericson,
    Real-Time Collision Detection, 5.1.5; a flat triangle by its nearest edge).
    GJK's simplex step, and the pipe-mesh walk's point-triangle distance."""
    abx, aby, abz = bx - ax, by - ay, bz - az
    acx, acy, acz = cx - ax, cy - ay, cz - az
    d1 = -(abx * ax + aby * ay + abz * az)
    d2 = -(acx * ax + acy * ay + acz * az)
    if d1 <= 0.0 and d2 <= 0.0:
        return ax, ay, az, 1
    d3 = -(abx * bx + aby * by + abz * bz)
    d4 = -(acx * bx + acy * by + acz * bz)
    if d3 >= 0.0 and d4 <= d3:
        return bx, by, bz, 2
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        t = d1 / (d1 - d3)
        return ax + t * abx, ay + t * aby, az + t * abz, 3
    d5 = -(abx * cx + aby * cy + abz * cz)
    d6 = -(acx * cx + acy * cy + acz * cz)
    if d6 >= 0.0 and d5 <= d6:
        return cx, cy, cz, 4
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        t = d2 / (d2 - d6)
        return ax + t * acx, ay + t * acy, az + t * acz, 5
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and d4 - d3 >= 0.0 and d5 - d6 >= 0.0:
        t = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        return bx + t * (cx - bx), by + t * (cy - by), bz + t * (cz - bz), 6
    total = va + vb + vc
    if not total > 0.0:              # a degenerate (flat) triangle: its nearest edge
        px, py, pz, m = _segment(ax, ay, az, bx, by, bz)
        qx, qy, qz, n = _segment(bx, by, bz, cx, cy, cz)
        if qx * qx + qy * qy + qz * qz < px * px + py * py + pz * pz:
            px, py, pz, m = qx, qy, qz, n << 1
        qx, qy, qz, n = _segment(ax, ay, az, cx, cy, cz)
        if qx * qx + qy * qy + qz * qz < px * px + py * py + pz * pz:
            px, py, pz, m = qx, qy, qz, (n & 1) | ((n & 2) << 1)
        return px, py, pz, m
    v, w = vb / total, vc / total
    return ax + v * abx + w * acx, ay + v * aby + w * acy, az + v * abz + w * acz, 7


@_jit
def _beyond(s, i, j, k, o):
    """Whether the origin lies beyond face ``i j k`` of the tetrahedron ``s`` (4, 3),
    seen from its fourth corner ``o`` (True for a flat tetrahedron: every face is
    then tried)."""
    ux, uy, uz = s[j, 0] - s[i, 0], s[j, 1] - s[i, 1], s[j, 2] - s[i, 2]
    wx, wy, wz = s[k, 0] - s[i, 0], s[k, 1] - s[i, 1], s[k, 2] - s[i, 2]
    nx, ny, nz = uy * wz - uz * wy, uz * wx - ux * wz, ux * wy - uy * wx
    origin = -(nx * s[i, 0] + ny * s[i, 1] + nz * s[i, 2])
    corner = nx * (s[o, 0] - s[i, 0]) + ny * (s[o, 1] - s[i, 1]) + nz * (s[o, 2] - s[i, 2])
    return origin * corner <= 0.0


@_jit
def _keep(s, n, corners, mask):
    """Keep the simplex points ``corners[b]`` whose bit ``b`` is set in ``mask``,
    in order, at the front of ``s`` (8, 3), through its scratch rows 4 to 7 (the
    tetrahedron's faces list their corners wrapped around); their count."""
    kept = 0
    for b in range(n):
        if mask & (1 << b):
            c = corners[b]
            s[4 + kept, 0], s[4 + kept, 1], s[4 + kept, 2] = s[c, 0], s[c, 1], s[c, 2]
            kept += 1
    for r in range(kept):
        s[r, 0], s[r, 1], s[r, 2] = s[4 + r, 0], s[4 + r, 1], s[4 + r, 2]
    return kept


@_jit
def _nearest(s, n, corners):
    """Reduce the simplex ``s[:n]`` to the corners spanning its point nearest the
    origin; ``(count, x, y, z)``, count 4 (and the origin) when it encloses it.
    ``s`` is (8, 3), rows 4 to 7 scratch; ``corners`` (4,) scratch."""
    if n == 1:
        return 1, s[0, 0], s[0, 1], s[0, 2]
    if n == 2:
        x, y, z, mask = _segment(s[0, 0], s[0, 1], s[0, 2], s[1, 0], s[1, 1], s[1, 2])
        corners[0], corners[1] = 0, 1
        return _keep(s, 2, corners, mask), x, y, z
    if n == 3:
        x, y, z, mask = nearest_on_triangle(s[0, 0], s[0, 1], s[0, 2], s[1, 0], s[1, 1],
                                            s[1, 2], s[2, 0], s[2, 1], s[2, 2])
        corners[0], corners[1], corners[2] = 0, 1, 2
        return _keep(s, 3, corners, mask), x, y, z
    best, bx, by, bz, bmask, face = np.inf, 0.0, 0.0, 0.0, 0, -1
    for f in range(4):               # face f leaves out corner f
        i, j, k = (f + 1) % 4, (f + 2) % 4, (f + 3) % 4
        if not _beyond(s, i, j, k, f):
            continue
        x, y, z, mask = nearest_on_triangle(s[i, 0], s[i, 1], s[i, 2], s[j, 0], s[j, 1],
                                            s[j, 2], s[k, 0], s[k, 1], s[k, 2])
        d = x * x + y * y + z * z
        if d < best:
            best, bx, by, bz, bmask, face = d, x, y, z, mask, f
    if face < 0:
        return 4, 0.0, 0.0, 0.0
    corners[0], corners[1], corners[2] = (face + 1) % 4, (face + 2) % 4, (face + 3) % 4
    return _keep(s, 3, corners, bmask), bx, by, bz


@_jit
def _pad_range(pads, lo, hi):
    small, large = np.inf, 0.0
    for s in range(lo, hi):
        small, large = min(small, pads[s]), max(large, pads[s])
    return small, large


@_jit
def bounds(points, pads, lo_a, hi_a, m_a, lo_b, hi_b, m_b, enough, iterations=ITERATIONS):
    """``(lower, upper)`` bounds of the distance between the padded hulls of points
    ``lo_a:hi_a`` placed by ``m_a`` (4, 4) and ``lo_b:hi_b`` placed by ``m_b``.

    ``lower > 0`` proves them apart; ``upper`` is their distance or more (<= 0:
    they touch). The walk stops once the lower bound reaches ``enough``, when
    the bounds agree to :data:`CONVERGED`, or after ``iterations`` steps.
    """
    s = np.empty((8, 3))
    corners = np.empty(4, np.int64)
    ax, ay, az = _support(points, lo_a, hi_a, m_a, 1.0, 0.0, 0.0)
    bx, by, bz = _support(points, lo_b, hi_b, m_b, -1.0, 0.0, 0.0)
    vx, vy, vz = ax - bx, ay - by, az - bz
    scale = max(abs(ax), abs(ay), abs(az), abs(bx), abs(by), abs(bz))
    small_a, large_a = _pad_range(pads, lo_a, hi_a)
    small_b, large_b = _pad_range(pads, lo_b, hi_b)
    slack = large_a + large_b
    lower, n = -np.inf, 0
    for _ in range(iterations):
        vv = vx * vx + vy * vy + vz * vz
        if not vv > 0.0:             # touching (or NaN): nothing more to prove
            break
        ax, ay, az = _support(points, lo_a, hi_a, m_a, -vx, -vy, -vz)
        bx, by, bz = _support(points, lo_b, hi_b, m_b, vx, vy, vz)
        scale = max(scale, abs(ax), abs(ay), abs(az), abs(bx), abs(by), abs(bz))
        wx, wy, wz = ax - bx, ay - by, az - bz
        wv = wx * vx + wy * vy + wz * vz
        lower = max(lower, wv / np.sqrt(vv))
        if lower - slack - SLACK * (1.0 + scale) >= enough:
            break
        if vv - wv <= CONVERGED * vv:    # converged: the bounds meet
            break
        s[n, 0], s[n, 1], s[n, 2] = wx, wy, wz
        n, vx, vy, vz = _nearest(s, n + 1, corners)
        if n == 4:                   # the simplex encloses the origin: the cores overlap
            vx, vy, vz = 0.0, 0.0, 0.0
            break
    rounding = SLACK * (1.0 + scale)
    upper = np.sqrt(vx * vx + vy * vy + vz * vz)
    if not upper > 0.0:
        lower = min(lower, 0.0)
    return lower - slack - rounding, upper - small_a - small_b + rounding


@_jit
def body_bounds(points, pads, piece_starts, centre, radius, pieces, i, m_i, j, m_j, enough,
                iterations=ITERATIONS):
    """``(lower, upper)`` bounds of the distance between objects ``i`` and ``j`` at
    poses ``m_i``, ``m_j`` (4, 4), from their pairs of convex pieces (object ``k``'s
    are ``pieces[k]:pieces[k + 1]``, piece ``q``'s padded points
    ``piece_starts[q]:piece_starts[q + 1]`` inside the ball ``centre[q]``,
    ``radius[q]`` of its object's frame).

    ``lower`` bounds the bodies' distance from below. ``upper`` is the least
    distance between two pieces or more: a bound of the bodies' distance only
    where both bodies are their pieces (:attr:`Pieces.exact`). Piece pairs
    whose balls are already at least ``enough`` (or the best bound so far)
    apart are bounded by the balls; the others by :func:`bounds`. Returns
    early, below 0, once a pair may touch.
    """
    best, least = np.inf, np.inf
    ci, cj = np.empty(3), np.empty(3)
    for p in range(pieces[i], pieces[i + 1]):
        for r in range(3):
            ci[r] = m_i[r, 0] * centre[p, 0] + m_i[r, 1] * centre[p, 1] \
                + m_i[r, 2] * centre[p, 2] + m_i[r, 3]
        for q in range(pieces[j], pieces[j + 1]):
            for r in range(3):
                cj[r] = m_j[r, 0] * centre[q, 0] + m_j[r, 1] * centre[q, 1] \
                    + m_j[r, 2] * centre[q, 2] + m_j[r, 3]
            balls = np.sqrt((ci[0] - cj[0]) ** 2 + (ci[1] - cj[1]) ** 2
                            + (ci[2] - cj[2]) ** 2) - radius[p] - radius[q]
            balls -= SLACK * (1.0 + np.abs(ci).max() + np.abs(cj).max() + radius[p] + radius[q])
            if balls >= min(best, enough):
                best = min(best, balls)
                continue
            low, high = bounds(points, pads, piece_starts[p], piece_starts[p + 1], m_i,
                               piece_starts[q], piece_starts[q + 1], m_j, min(best, enough),
                               iterations)
            best, least = min(best, max(balls, low)), min(least, high)
            if best <= 0.0:
                return best, least
    return best, least


@_jit
def body_gap(points, pads, piece_starts, centre, radius, pieces, i, m_i, j, m_j, enough,
             iterations=ITERATIONS):
    """The lower bound of :func:`body_bounds`: > 0 proves objects ``i`` and ``j`` apart."""
    return body_bounds(points, pads, piece_starts, centre, radius, pieces, i, m_i, j, m_j,
                       enough, iterations)[0]
