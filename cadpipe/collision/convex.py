"""Clearance bounds between convex pieces, by GJK (C, ``csrc/convex.c``).

Every body has convex pieces whose union contains it: a mesh its convex hull,
a chain each of its units as the capsule of the unit's larger radius (what the
narrow phase collides against meshes; it contains the unit's round cone). A
convex piece is a padded point set -- points ``p_i`` with radii ``r_i``, the
hull of the balls ``B(p_i, r_i)``. It lies between ``hull(p) + B(min r)`` and
``hull(p) + B(max r)``, so the distance between two pieces is within their
pads of the distance between their cores ``hull(p)``, and equal to it less
the pads where each piece's pad is one radius (a hull: 0; a capsule: r).

GJK (Gilbert, Johnson and Keerthi 1988) walks a point ``v`` of the cores'
Minkowski difference ``D = A - B`` towards the origin, keeping the simplex of
support points (up to four) whose nearest point to the origin ``v`` is. Two
bounds come with every step:

* whatever ``v`` is, the support point ``w`` of ``D`` towards ``-v`` gives the
  plane ``x . v >= w . v`` that all of ``D`` lies beyond, so ``w . v / |v|`` is
  a **lower bound** of the distance -- true however far the iteration has
  come, and however the simplex was rounded;
* ``v`` is a point of ``D`` (a convex combination of support points), so
  ``|v|`` is an **upper bound**.

On polytopes the walk ends in finitely many steps with the two equal (to a
relative 1e-9); :func:`bounds` returns both, less the pads and a rounding slack.
A positive lower bound proves the pieces apart and the bodies inside them at
least that far apart. Where a body *is* its pieces (a convex mesh, a pipe of
one radius: :attr:`Pieces.exact`) the upper bound is one for the body too, so
the pair's clearance is known to within the iteration's tolerance without an
exact query.

Used by the funnel (:mod:`cadpipe.collision.funnel`, the ``"hull"`` stage: pairs
the boxes cannot separate but the hulls can) and by the motion check
(:mod:`cadpipe.collision.motion`: clearance bounds that need no exact query).
"""

import numpy as np

from cadpipe.core.kernels import native

#: GJK iterations before the best bounds so far are returned
ITERATIONS = 40
#: the funnel's budget: a pair its hulls have not proven apart by then goes on to
#: the exact phase (pairs clearly apart are proven in a few steps; touching ones never)
FUNNEL_ITERATIONS = 10
#: relative rounding slack taken off every bound (of the pieces' size and place; the C
#: kernels' GJK_SLACK)
SLACK = 1e-10
#: the walk has converged when the bounds agree to this fraction of the distance (the C
#: kernels' GJK_CONVERGED)
CONVERGED = 1e-9


def bounds(points, pads, lo_a, hi_a, m_a, lo_b, hi_b, m_b, enough, iterations=ITERATIONS):
    """``(lower, upper)`` bounds of the distance between the padded hulls of points
    ``lo_a:hi_a`` placed by ``m_a`` (4, 4) and ``lo_b:hi_b`` placed by ``m_b``.

    ``lower > 0`` proves them apart; ``upper`` is their distance or more (<= 0:
    they touch). The walk stops once the lower bound reaches ``enough``, when
    the bounds agree to :data:`CONVERGED`, or after ``iterations`` steps.
    """
    return native.gjk_bounds(points, pads, lo_a, hi_a, _matrix(m_a), lo_b, hi_b, _matrix(m_b),
                             enough, iterations)


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
    return native.body_bounds(points, pads, piece_starts, centre, radius, pieces, i,
                              _matrix(m_i), j, _matrix(m_j), enough, iterations)


def body_gaps(points, pads, piece_starts, centre, radius, pieces, first, poses_a, second,
              poses_b, enough, out):
    """The lower bound of :func:`body_bounds` (> 0 proves the objects apart) of each
    entry into ``out`` (E,): objects ``first[e]`` at ``poses_a[e]`` and ``second[e]`` at
    ``poses_b[e]`` (E, 4, 4), each needing no more than ``enough[e]``."""
    native.body_gaps(points, pads, piece_starts, centre, radius, pieces,
                     np.ascontiguousarray(first, np.int64), _matrix(poses_a),
                     np.ascontiguousarray(second, np.int64), _matrix(poses_b),
                     np.ascontiguousarray(enough, np.float64), ITERATIONS, out)


def _matrix(m):
    """``m`` as the C-ordered float64 array the kernels read (itself when it is one)."""
    return np.ascontiguousarray(m, np.float64)


class Pieces:
    """The convex pieces of a list of bodies, packed for :func:`body_bounds`: a mesh's
    hull (its hull vertices), a chain's units (two padded points each).

    Parameters
    ----------
    bodies : sequence of :class:`~cadpipe.collision.bodies.Body`
        Object ``k`` of :func:`body_bounds` is ``bodies[k]``.

    Attributes
    ----------
    exact : (N,) bool
        Whether body ``k`` is the union of its pieces, as the exact narrow phase
        takes it: a closed mesh with no vertex in front of any face's plane
        (convex, to :data:`CONVEX` of its size), or a chain whose units are
        capsules (one radius along each). For a pair of such bodies the upper
        bound of :func:`body_bounds` bounds the clearance too.
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
        self.exact = np.array([_is_its_pieces(b) for b in bodies], bool)

    def arrays(self):
        """The arguments of :func:`body_bounds` before the objects."""
        return self.points, self.pads, self.piece_starts, self.centre, self.radius, self.pieces


#: how far (relative to a mesh's size) a vertex may stand in front of a face's plane
#: for the mesh to count as convex: float64 rounding of exactly convex input
CONVEX = 1e-12


def _is_its_pieces(body):
    """Whether ``body`` is exactly its convex pieces (see :attr:`Pieces.exact`)."""
    if body.kind == "chain":
        c = body.chain
        return bool(np.array_equal(c.start_radii, c.end_radii))
    mesh = body.mesh
    if not body.closed:
        return False
    hull, _ = body.hull
    size = float(np.linalg.norm(mesh.bounds[1] - mesh.bounds[0]))
    normals, corners = mesh.face_normals, mesh.triangles[:, 0]
    for start in range(0, len(normals), 4096):      # faces in blocks: (F, H) can be large
        n, c = normals[start:start + 4096], corners[start:start + 4096]
        ahead = n @ hull.T - np.einsum("fi,fi->f", n, c)[:, None]
        if ahead.max(initial=0.0) > CONVEX * size:
            return False
    return True
