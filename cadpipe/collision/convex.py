"""Lower bounds of the clearance between convex hulls, by GJK (compiled, numba).

Every body has convex pieces whose union contains it: a mesh its convex hull,
a chain each of its units as the capsule of the unit's larger radius (what the
narrow phase collides against meshes; it contains the unit's round cone). A convex piece is a
padded point set -- points ``p_i`` with radii ``r_i``, the hull of the balls
``B(p_i, r_i)`` -- so its support point in a direction ``d`` is the ``p_i`` of
largest ``p_i . d + r_i |d|``, pushed out by ``r_i`` along ``d``.

Gilbert's iteration (Gilbert, Johnson and Keerthi 1988) walks a point ``v`` of
the Minkowski difference ``D = A - B`` towards the origin. Whatever direction ``v``
it holds, the support point ``w`` of ``D`` towards ``-v`` gives the plane
``x . v >= w . v`` that all of ``D`` lies beyond, so ``w . v / |v|`` is a lower
bound of the distance between ``A`` and ``B`` -- true for any ``v``, however far
the iteration has come. :func:`gap` returns the best such bound
(minus a rounding slack), so a positive answer proves the pieces apart and the
bodies inside them at least that far apart; near convergence it is the exact
distance between the hulls. Zero or less means "not proven apart".

Used by the funnel (:mod:`cadpipe.collision.funnel`, the ``"hull"`` stage: pairs
the boxes cannot separate but the hulls can) and by the motion check
(:mod:`cadpipe.collision.motion`: clearance bounds that need no exact query).
"""

import numba
import numpy as np

_jit = numba.njit(cache=True, nogil=True, error_model="numpy")    # x / 0 is inf, not raised

#: GJK iterations before the best bound so far is returned
ITERATIONS = 40
#: the funnel's budget: a pair its hulls have not proven apart by then goes on to
#: the exact phase (pairs clearly apart are proven in a few steps; touching ones never)
FUNNEL_ITERATIONS = 10
#: relative rounding slack taken off every bound (of the pieces' size and place)
SLACK = 1e-10


@_jit
def _support(points, pads, lo, hi, m, dx, dy, dz):
    """World support point (x, y, z) of padded points ``lo:hi`` placed by ``m``
    towards ``(dx, dy, dz)``."""
    # the direction in the piece's frame
    ux = m[0, 0] * dx + m[1, 0] * dy + m[2, 0] * dz
    uy = m[0, 1] * dx + m[1, 1] * dy + m[2, 1] * dz
    uz = m[0, 2] * dx + m[1, 2] * dy + m[2, 2] * dz
    norm = np.sqrt(dx * dx + dy * dy + dz * dz)
    best, at = -np.inf, lo
    for s in range(lo, hi):
        v = ux * points[s, 0] + uy * points[s, 1] + uz * points[s, 2] + pads[s] * norm
        if v > best:
            best, at = v, s
    scale = pads[at] / norm if norm > 0 else 0.0
    x, y, z = points[at, 0], points[at, 1], points[at, 2]
    return (m[0, 0] * x + m[0, 1] * y + m[0, 2] * z + m[0, 3] + scale * dx,
            m[1, 0] * x + m[1, 1] * y + m[1, 2] * z + m[1, 3] + scale * dy,
            m[2, 0] * x + m[2, 1] * y + m[2, 2] * z + m[2, 3] + scale * dz)


@_jit
def gap(points, pads, lo_a, hi_a, m_a, lo_b, hi_b, m_b, enough, iterations=ITERATIONS):
    """A lower bound of the distance between the hulls of padded points ``lo_a:hi_a``
    placed by ``m_a`` (4, 4) and ``lo_b:hi_b`` placed by ``m_b``; > 0 proves them
    apart, <= 0 says nothing. It stops as soon as the bound reaches ``enough``, or
    after ``iterations`` steps.

    The simplex is a segment (Gilbert's original step: ``v`` moves to the point
    of ``[v, w]`` nearest the origin), all in scalars: no array is allocated.
    """
    ax, ay, az = _support(points, pads, lo_a, hi_a, m_a, 1.0, 0.0, 0.0)
    bx, by, bz = _support(points, pads, lo_b, hi_b, m_b, -1.0, 0.0, 0.0)
    vx, vy, vz = ax - bx, ay - by, az - bz
    lower, scale = -np.inf, 0.0
    for _ in range(iterations):
        vv = vx * vx + vy * vy + vz * vz
        if not vv > 0.0:             # touching (or NaN): nothing more to prove
            break
        ax, ay, az = _support(points, pads, lo_a, hi_a, m_a, -vx, -vy, -vz)
        bx, by, bz = _support(points, pads, lo_b, hi_b, m_b, vx, vy, vz)
        scale = max(scale, abs(ax), abs(ay), abs(az), abs(bx), abs(by), abs(bz))
        wx, wy, wz = ax - bx, ay - by, az - bz
        wv = wx * vx + wy * vy + wz * vz
        lower = max(lower, wv / np.sqrt(vv))
        if lower - SLACK * (1.0 + scale) >= enough:
            break
        if vv - wv <= 1e-9 * vv:     # converged: the bound is the distance
            break
        dx, dy, dz = wx - vx, wy - vy, wz - vz
        t = -(vx * dx + vy * dy + vz * dz) / (dx * dx + dy * dy + dz * dz)
        t = min(max(t, 0.0), 1.0)
        vx, vy, vz = vx + t * dx, vy + t * dy, vz + t * dz
    return lower - SLACK * (1.0 + scale)


@_jit
def body_gap(points, pads, piece_starts, centre, radius, pieces, i, m_i, j, m_j, enough,
             iterations=ITERATIONS):
    """A lower bound of the distance between objects ``i`` and ``j`` at poses ``m_i``,
    ``m_j`` (4, 4), from their pairs of convex pieces (object ``k``'s are
    ``pieces[k]:pieces[k + 1]``, piece ``q``'s padded points
    ``piece_starts[q]:piece_starts[q + 1]`` inside the ball ``centre[q]``,
    ``radius[q]`` of its object's frame).

    Piece pairs whose balls are already at least ``enough`` (or the best bound so
    far) apart are bounded by the balls; the others by :func:`gap`. Returns
    early, below 0, once a pair may touch.
    """
    best = np.inf
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
            g = max(balls, gap(points, pads, piece_starts[p], piece_starts[p + 1], m_i,
                               piece_starts[q], piece_starts[q + 1], m_j, min(best, enough),
                               iterations))
            best = min(best, g)
            if best <= 0.0:
                return best
    return best


class Pieces:
    """The convex pieces of a list of bodies, packed for :func:`body_gap`: a mesh's
    hull (its hull vertices), a chain's units (two padded points each).

    Parameters
    ----------
    bodies : sequence of :class:`~cadpipe.collision.bodies.Body`
        Object ``k`` of :func:`body_gap` is ``bodies[k]``.
    """

    def __init__(self, bodies):
        points, pads, sizes, owners = [], [], [], []
        for k, body in enumerate(bodies):
            if body.kind == "chain":
                c = body.chain
                units = np.stack([c.starts, c.ends], axis=1)                # (U, 2, 3)
                # the capsule of the larger end radius, as the narrow phase takes a
                # unit against a mesh (it contains the unit's round cone)
                radii = np.repeat(np.maximum(c.start_radii, c.end_radii)[:, None], 2, axis=1)
                points += list(units)
                pads += list(radii)
                sizes += [2] * len(units)
                owners += [k] * len(units)
            else:
                hull, pad = body.hull
                points.append(hull)
                pads.append(pad)
                sizes.append(len(hull))
                owners.append(k)
        self.points = np.concatenate(points or [np.zeros((0, 3))]).reshape(-1, 3).astype(float)
        self.pads = np.concatenate(pads or [np.zeros(0)]).astype(np.float64)
        self.piece_starts = np.r_[0, np.cumsum(sizes)].astype(np.int64)
        self.pieces = np.searchsorted(owners, np.arange(len(bodies) + 1)).astype(np.int64)
        self.centre = np.empty((len(sizes), 3))
        self.radius = np.empty(len(sizes))
        for q in range(len(sizes)):
            at = slice(self.piece_starts[q], self.piece_starts[q + 1])
            lo, hi = self.points[at].min(axis=0), self.points[at].max(axis=0)
            self.centre[q] = 0.5 * (lo + hi)
            self.radius[q] = (np.linalg.norm(self.points[at] - self.centre[q], axis=1)
                              + self.pads[at]).max()

    def arrays(self):
        """The arguments of :func:`body_gap` before the objects."""
        return self.points, self.pads, self.piece_starts, self.centre, self.radius, self.pieces


@_jit
def body_gaps(points, pads, piece_starts, centre, radius, pieces, first, poses_a, second,
              poses_b, enough, out):
    """:func:`body_gap` of each entry: objects ``first[e]`` at ``poses_a[e]`` and
    ``second[e]`` at ``poses_b[e]``, each needing no more than ``enough[e]``."""
    for e in range(len(first)):
        out[e] = body_gap(points, pads, piece_starts, centre, radius, pieces, first[e],
                          poses_a[e], second[e], poses_b[e], enough[e])
