"""Pipes as chains of round cones: exact distances from segments and radii.

The source checks pipes "by finite units"; here each unit between two path points
is the convex hull of two balls, ``conv(B(a, ra), B(b, rb))`` -- a capsule when
the radii are equal, a truncated cone with spherical ends otherwise. That hull is
the union of the balls ``B(a + s (b - a), ra + s (rb - ra))`` for ``s`` in
``[0, 1]``, so

* a point's signed distance to a unit has a closed form in the unit's
  (axial, radial) half-plane, and
* the gap between two units is ``min over (s, t) of |p(s) - q(t)| - r(s) - rho(t)``,
  a convex function on the unit square whose minimum is at a stationary point
  inside or on one of the four edges -- each found in closed form.

A chain is the union of its units. Everything is vectorized over units, unit
pairs and query points (and, through :mod:`cadpipe.collision.hierarchy`, over
many poses of one chain against another): no triangle is ever looked at.
"""

from functools import cached_property

import numpy as np

from cadpipe.core.kernels import native
from cadpipe.core.distance import closest_params
from cadpipe.core.vec import dot


# -- points against units -------------------------------------------------------
def round_cone_distance(points, a, b, ra, rb):
    """Signed distance of points to round-cone units ``conv(B(a, ra), B(b, rb))``.

    All arguments broadcast against each other (points ``(..., 3)``, radii
    ``(...)``). Exact outside a unit; inside it is the distance to the unit's
    own boundary. The one implementation (``round_cone_at`` in
    ``csrc/capsules.c``), which :func:`chain_signed_distance` and the fixture
    queries call too, reduces the point to the unit's half-plane -- axial ``y``
    along ``a -> b``, radial ``x`` -- where the side line touches both end
    circles; ``w``, the coordinate along that line, tells which of the three
    boundary pieces is nearest. A unit one ball of which swallows the other (or
    of length 0) is the bigger ball.
    """
    points, a, b = (np.asarray(v, np.float64) for v in (points, a, b))
    ra, rb = (np.asarray(v, np.float64)[..., None] for v in (ra, rb))
    shape = np.broadcast_shapes(points.shape, a.shape, b.shape, ra.shape, rb.shape)
    # owned C-ordered copies of the broadcast (read-only, strided) views
    flat = [np.array(np.broadcast_to(v, shape)).reshape(-1, 3) for v in (points, a, b)]
    radii = [np.array(np.broadcast_to(v, shape)[..., 0]).reshape(-1) for v in (ra, rb)]
    out = np.empty(shape[:-1])
    native.round_cones(*flat, *radii, out.reshape(-1))
    return out


def chain_signed_distance(points, a, b, ra, rb):
    """Signed distance of ``(P, 3)`` points to a union of units ``a``, ``b`` (U, 3),
    ``ra``, ``rb`` (U,).

    Exact outside; inside, the depth within the deepest unit (never more than the
    true depth), so the sign is exact everywhere. One compiled loop, no
    temporaries.
    """
    points = np.ascontiguousarray(points, np.float64).reshape(-1, 3)
    out = np.empty(len(points))
    native.chain_signed_distance(points, *(np.ascontiguousarray(v, np.float64)
                                           for v in (a, b, ra, rb)), out)
    return out


# -- unit against unit ------------------------------------------------------------
def _edge_minimum(c, w, k):
    """argmin over x in [0, 1] of ``|c + x w| - k x`` (convex), vectorized."""
    beta = np.linalg.norm(w, axis=-1)
    safe = np.where(beta > 0, beta, 1.0)
    along = dot(c, w) / safe
    h = np.sqrt(np.maximum(dot(c, c) - along * along, 0.0))
    kappa = k / safe
    inner = np.abs(kappa) < 1.0
    root = np.where(inner, kappa * h / np.sqrt(np.where(inner, 1.0 - kappa * kappa, 1.0)), 0.0)
    x = np.where(inner, (root - along) / safe, np.where(kappa >= 1.0, 1.0, 0.0))
    x = np.where(beta > 0, x, np.where(k > 0, 1.0, 0.0))
    return np.clip(x, 0.0, 1.0)


def _interior_stationary(p0, u, q0, v, dr, drho, sign):
    """A stationary point of the pair gap inside the square, or NaN where none.

    At a smooth minimum the unit direction ``d`` between the centres satisfies
    ``u.d = dr`` and ``v.d = -drho``; with ``|d| = 1`` that leaves two candidates
    (``sign`` picks one), each giving (s, t, lambda) by a linear solve.
    """
    n = np.cross(u, v)
    nn = dot(n, n)
    uu, vv, uv = dot(u, u), dot(v, v), dot(u, v)
    det = uu * vv - uv * uv
    ok = nn > 1e-14 * np.maximum(uu * vv, 1e-300)
    det = np.where(ok, det, 1.0)
    alpha = (dr * vv + drho * uv) / det
    beta = (-drho * uu - dr * uv) / det
    m = alpha[..., None] * u + beta[..., None] * v
    rest = 1.0 - dot(m, m)
    ok &= rest > 0
    gamma = sign * np.sqrt(np.where(ok, rest, 0.0) / np.where(ok, nn, 1.0))
    d = m + gamma[..., None] * n
    r = p0 - q0
    den = gamma * nn
    ok &= np.abs(den) > 0
    lam = dot(r, n) / np.where(ok, den, 1.0)
    target = lam[..., None] * d - r               # = s u - t v
    tu, tv = dot(target, u), dot(target, v)
    s = (tu * vv - tv * uv) / det
    t = (tu * uv - tv * uu) / det
    ok &= (lam > 0) & (s >= 0) & (s <= 1) & (t >= 0) & (t <= 1)
    return np.where(ok, s, np.nan), np.where(ok, t, np.nan)


def unit_pair_gap(a0, a1, ra0, ra1, b0, b1, rb0, rb1):
    """Gap between paired units (negative: they overlap) and where it is attained.

    Returns ``gap, s, t`` (arrays over the pairs); the nearest centres are
    ``a0 + s (a1 - a0)`` and ``b0 + t (b1 - b0)``. Exact: the minimum of the
    convex gap function over the unit square is among the four edge minima, the
    two smooth stationary points and the segments' own closest points (which
    catch a minimum where the axes cross).
    """
    u, v = a1 - a0, b1 - b0
    dr, drho = ra1 - ra0, rb1 - rb0
    if not (np.any(dr) or np.any(drho)):     # capsules: the axes' closest points decide
        s, t = closest_params(a0, u, b0, v)
        diff = a0 + s[..., None] * u - b0 - t[..., None] * v
        return np.linalg.norm(diff, axis=-1) - ra0 - rb0, s, t

    def gap(s, t):
        diff = a0 + s[..., None] * u - b0 - t[..., None] * v
        return np.linalg.norm(diff, axis=-1) - (ra0 + s * dr) - (rb0 + t * drho)

    one, zero = np.ones_like(ra0), np.zeros_like(ra0)
    candidates = []
    # edges s = 0, s = 1 (t free) and t = 0, t = 1 (s free)
    for s_fixed in (zero, one):
        t = _edge_minimum(b0 - a0 - s_fixed[..., None] * u, v, drho)
        candidates.append((s_fixed, t))
    for t_fixed in (zero, one):
        s = _edge_minimum(a0 - b0 - t_fixed[..., None] * v, u, dr)
        candidates.append((s, t_fixed))
    candidates.append(closest_params(a0, u, b0, v))
    for sign in (1.0, -1.0):
        s, t = _interior_stationary(a0, u, b0, v, dr, drho, sign)
        found = ~np.isnan(s)
        candidates.append((np.where(found, s, 0.0), np.where(found, t, 0.0)))
    s_all = np.stack([c[0] for c in candidates])
    t_all = np.stack([c[1] for c in candidates])
    values = gap(s_all, t_all)
    best = np.argmin(values, axis=0)
    pick = (best, *np.indices(best.shape))
    return values[pick], s_all[pick], t_all[pick]


# -- chains ---------------------------------------------------------------------
class Chain:
    """A union of round-cone units: ``centers[i] -> centers[j]`` for each edge.

    Parameters
    ----------
    centers : (N, 3) float array
        Ball centres (a pipe's path points).
    radii : (N,) float array
        Ball radii (a pipe's ring radii).
    edges : (U, 2) int array
        The units, as index pairs into ``centers`` (``(i, i)`` is a lone ball).
    """

    def __init__(self, centers, radii, edges):
        self.centers, self.radii, self.edges = centers, radii, edges
        self.starts, self.ends = centers[edges[:, 0]], centers[edges[:, 1]]
        self.start_radii, self.end_radii = radii[edges[:, 0]], radii[edges[:, 1]]

    @classmethod
    def along(cls, points, radii, closed=False):
        """Units between consecutive points (and back to the first when ``closed``)."""
        points = np.asarray(points, np.float64)
        n = len(points)
        if n == 1:
            edges = np.zeros((1, 2), np.int64)
        else:
            i = np.arange(n if closed else n - 1)
            edges = np.stack([i, (i + 1) % n], axis=1)
        return cls(points, np.broadcast_to(np.asarray(radii, np.float64), (n,)).copy(), edges)

    @classmethod
    def of_units(cls, starts: np.ndarray, ends: np.ndarray, start_radii: np.ndarray,
                 end_radii: np.ndarray) -> "Chain":
        """A chain of separate units, each given by its own two end balls.

        Parameters
        ----------
        starts, ends : (U, 3) float
            Ball centres, e.g. from :meth:`cadpipe.Pipe.collision_units`.
        start_radii, end_radii : (U,) float

        Returns
        -------
        chain : Chain
        """
        count = len(starts)
        edges = np.stack([np.arange(count), count + np.arange(count)], axis=1)
        return cls(np.concatenate([starts, ends]), np.concatenate([start_radii, end_radii]),
                   edges)

    def moved(self, matrix):
        """The chain moved by a rigid 4x4 matrix."""
        return Chain(self.centers @ matrix[:3, :3].T + matrix[:3, 3], self.radii, self.edges)

    @cached_property
    def unit_spheres(self):
        """(U, 3) centre and (U,) radius of a ball around each unit."""
        centre = 0.5 * (self.starts + self.ends)
        half = 0.5 * np.linalg.norm(self.ends - self.starts, axis=1)
        return centre, half + np.maximum(self.start_radii, self.end_radii)

    @cached_property
    def unit_bounds(self):
        """(U, 2, 3) axis-aligned box of each unit."""
        r0, r1 = self.start_radii[:, None], self.end_radii[:, None]
        lo = np.minimum(self.starts - r0, self.ends - r1)
        hi = np.maximum(self.starts + r0, self.ends + r1)
        return np.stack([lo, hi], axis=1)

    @cached_property
    def tree(self):
        """The chain's :class:`~cadpipe.collision.hierarchy.CapsuleTree`."""
        from cadpipe.collision.hierarchy import CapsuleTree

        return CapsuleTree(self)

    # queries
    def signed_distance(self, points):
        """Signed distance of ``(P, 3)`` points (negative inside); see
        :func:`chain_signed_distance`."""
        return chain_signed_distance(points, self.starts, self.ends, self.start_radii,
                                     self.end_radii)

    def gaps(self, other, poses, stop_below=None):
        """Smallest unit-pair gap to ``other`` placed at each of ``poses`` (P, 4, 4) in
        this chain's frame, and the two nearest surface points (in this frame).

        See :func:`cadpipe.collision.hierarchy.chain_gaps`; with ``stop_below``
        only ``gap <= stop_below`` is meaningful, and the points are NaN where
        the search stopped early. Returns ``(gap, point_self, point_other)``.
        """
        from cadpipe.collision.hierarchy import chain_gaps

        poses = np.asarray(poses, np.float64)
        gap, units, params = chain_gaps(self, other, poses, stop_below)
        near, far = np.full((len(gap), 3), np.nan), np.full((len(gap), 3), np.nan)
        k = np.flatnonzero(units[:, 0] >= 0)
        i, j, s, t = units[k, 0], units[k, 1], params[k, 0], params[k, 1]
        p = self.starts[i] + s[:, None] * (self.ends[i] - self.starts[i])
        q = other.starts[j] + t[:, None] * (other.ends[j] - other.starts[j])
        q = (poses[k, :3, :3] @ q[:, :, None])[:, :, 0] + poses[k, :3, 3]
        r = self.start_radii[i] + s * (self.end_radii[i] - self.start_radii[i])
        rho = other.start_radii[j] + t * (other.end_radii[j] - other.start_radii[j])
        d = q - p
        norm = np.linalg.norm(d, axis=1, keepdims=True)
        d = np.where(norm > 0, d / np.where(norm > 0, norm, 1.0), [1.0, 0.0, 0.0])
        near[k], far[k] = p + r[:, None] * d, q - rho[:, None] * d
        return gap, near, far

    def gap(self, other, pose=None, stop_below=None):
        """:meth:`gaps` at one pose (default: both chains in the same frame):
        ``(gap, point_self, point_other)``, the points None where unknown."""
        pose = np.eye(4) if pose is None else pose
        gap, near, far = self.gaps(other, np.asarray(pose, np.float64)[None], stop_below)
        known = not np.isnan(near[0, 0])
        return float(gap[0]), near[0] if known else None, far[0] if known else None
