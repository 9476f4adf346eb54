"""Bounding volumes: what each object carries so the funnel can prove "apart".

Three volumes per object, each a proof of "no contact" when two of them are
disjoint (the object lies inside its volume), tried from cheapest to tightest
by :mod:`cadpipe.collision.funnel`:

* AABB, the world-axis box;
* 18-DOP, the slab on each of 9 fixed world directions (axes and face
  diagonals), recomputed each pose from the object's support points (its
  first three slabs are the AABB);
* OBB, a box fitted once in the object's own frame (trimesh's minimum-volume
  box) that moves with it, compared by the separating-axis theorem (15 axes).

Support points carry a per-point padding radius, so a mesh (the vertices of
its local 18-DOP cut by its OBB, pad 0: a few dozen points however fine the
mesh) and a chain of balls (centres, pad = radius: exact) are placed alike.
Every volume is widened by :func:`rounding_slack`, relative to the object's
size and coordinates, so it contains the object at any scale.
"""

import numpy as np

#: the 9 directions of an 18-DOP: the axes and the 6 face diagonals
KDOP_DIRECTIONS = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1],
                            [1, 1, 0], [1, -1, 0], [1, 0, 1],
                            [1, 0, -1], [0, 1, 1], [0, 1, -1]], np.float64)
KDOP_DIRECTIONS /= np.linalg.norm(KDOP_DIRECTIONS, axis=1, keepdims=True)
#: the eight corners of a box, as signs of its half extents
CORNER_SIGNS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)


def pair_index(i, j, n):
    """The index of pair ``(i, j)``, ``i < j``, in ``np.triu_indices(n, k=1)`` order."""
    return (i * (2 * n - i - 1)) // 2 + j - i - 1


def rounding_slack(points):
    """How far rounding can move a computed bound of ``points`` (N, 3): 1e-9 of their
    size plus a few units in the last place of their largest coordinate, so a
    1 um object far from the origin is padded as surely as a 1 m one at it."""
    points = np.asarray(points, np.float64)
    return 1e-9 * float(np.ptp(points, axis=0).max(initial=0.0)) \
        + 64 * np.finfo(float).eps * float(np.abs(points).max(initial=0.0))


def fit_obb(points, pad):
    """An oriented box in the points' own frame: ``(centre, axes, half_extents)``.

    ``axes`` holds the box axes as columns. trimesh's minimum-volume box picks
    the axes (of the points centred and scaled to unit size, so its hull
    tolerances suit any size); the extents are the points' own projections on
    them, widened by :func:`rounding_slack` and the largest ``pad``, so every
    point lies inside however small the object.
    """
    import trimesh

    points = np.asarray(points, np.float64)
    middle = 0.5 * (points.min(axis=0) + points.max(axis=0))
    size = float(np.ptp(points, axis=0).max(initial=0.0))
    axes = np.eye(3)
    if len(points) >= 4 and size > 0:
        unit = (points - middle) / size
        if np.linalg.matrix_rank(unit - unit.mean(axis=0), tol=1e-9) == 3:
            # whole-radian steps of the normals' directions: a third of the time of
            # tenths (30 against 88 ms for the Panda's links), boxes within 2 % of them
            to_origin, _ = trimesh.bounds.oriented_bounds(unit, angle_digits=0)
            axes = np.linalg.inv(to_origin)[:3, :3]
    local = (points - middle) @ axes
    lo, hi = local.min(axis=0), local.max(axis=0)
    centre = middle + axes @ (0.5 * (lo + hi))
    half = 0.5 * (hi - lo) + rounding_slack(points) + float(np.max(pad, initial=0.0))
    return centre, axes, half


def kdop_polytope(points, obb):
    """Vertices of the local 18-DOP of ``points`` cut by their OBB: a polytope that
    contains the points' hull with few vertices, so a mesh's world 18-DOP can be
    recomputed from it each pose at a fraction of the hull's cost.

    Every face is moved out by :func:`rounding_slack`, so rounding in the vertices
    never leaves part of the hull outside. Falls back to the OBB's corners where
    qhull cannot build the polytope (flat point sets).
    """
    from scipy.spatial import ConvexHull, HalfspaceIntersection, QhullError

    centre, axes, half = obb
    corners = centre + (CORNER_SIGNS * half) @ axes.T
    normals = np.concatenate([KDOP_DIRECTIONS, -KDOP_DIRECTIONS, axes.T, -axes.T])
    slack = rounding_slack(points)
    middle = points.mean(axis=0)
    # qhull works on coordinates about the interior point, scaled to unit size
    scale = max(float(np.ptp(points, axis=0).max(initial=0.0)), np.finfo(float).tiny)
    reach = (((points - middle) @ normals.T).max(axis=0) + slack) / scale
    try:
        vertices = HalfspaceIntersection(np.c_[normals, -reach], np.zeros(3)).intersections
        return middle + scale * vertices[ConvexHull(vertices).vertices]
    except (QhullError, ValueError):
        return corners
