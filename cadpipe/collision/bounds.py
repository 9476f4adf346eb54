"""Bounding volumes and the scene-level broad phase.

Three volumes per object, each a proof of "no contact" when two of them are
disjoint (the object lies inside its volume), tried from cheapest to tightest:

* AABB, the world-axis box, paired up for the whole scene by sweep-and-prune;
* 18-DOP, the slab on each of 9 fixed world directions (axes and face
  diagonals), recomputed each pose from the object's support points (its
  first three slabs are the AABB);
* OBB, a box fitted once in the object's own frame (trimesh's minimum-volume
  box) that moves with it, compared by the separating-axis theorem (15 axes).

Support points carry a per-point padding radius, so a mesh (the vertices of
its local 18-DOP cut by its OBB, pad 0: a few dozen points however fine the
mesh) and a chain of balls (centres, pad = radius: exact) share every function
here. All tests are vectorized over pairs.
"""

import numpy as np

from cadpipe.geometry.ragged import Groups

#: the 9 directions of an 18-DOP: the axes and the 6 face diagonals
KDOP_DIRECTIONS = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1],
                            [1, 1, 0], [1, -1, 0], [1, 0, 1],
                            [1, 0, -1], [0, 1, 1], [0, 1, -1]], np.float64)
KDOP_DIRECTIONS /= np.linalg.norm(KDOP_DIRECTIONS, axis=1, keepdims=True)
#: cross products by index: (a x b)_i = a_(i+1) b_(i+2) - a_(i+2) b_(i+1)
NEXT, AFTER = np.array([1, 2, 0]), np.array([2, 0, 1])
#: the eight corners of a box, as signs of its half extents
CORNER_SIGNS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
#: below this many objects, testing all pairs at once beats sorting them
SWEEP_MIN_OBJECTS = 48
#: placed objects per batched product in :meth:`Supports.place` (bounds memory)
PLACE_CHUNK = 4096


def fit_obb(points, pad):
    """An oriented box in the points' own frame: ``(centre, axes, half_extents)``.

    ``axes`` holds the box axes as columns. Padding is added to every side.
    """
    import trimesh

    points = np.asarray(points, np.float64)
    if len(points) >= 4 and np.linalg.matrix_rank(points - points.mean(axis=0), tol=1e-12) == 3:
        to_origin, extents = trimesh.bounds.oriented_bounds(points)
        frame = np.linalg.inv(to_origin)
        centre, axes = frame[:3, 3], frame[:3, :3]
    else:                              # flat or tiny point sets: the axis-aligned box
        lo, hi = points.min(axis=0), points.max(axis=0)
        centre, axes, extents = 0.5 * (lo + hi), np.eye(3), hi - lo
    return centre, axes, 0.5 * np.asarray(extents) + float(np.max(pad, initial=0.0))


def kdop_polytope(points, obb):
    """Vertices of the local 18-DOP of ``points`` cut by their OBB: a polytope that
    contains the points' hull with few vertices, so a mesh's world 18-DOP can be
    recomputed from it each pose at a fraction of the hull's cost.

    Every face is dilated by 1e-9 of the size, so rounding in the vertices never
    leaves part of the hull outside. Falls back to the OBB's corners where qhull
    cannot build the polytope (flat point sets).
    """
    from scipy.spatial import ConvexHull, HalfspaceIntersection, QhullError

    centre, axes, half = obb
    corners = centre + (CORNER_SIGNS * half) @ axes.T
    normals = np.concatenate([KDOP_DIRECTIONS, -KDOP_DIRECTIONS, axes.T, -axes.T])
    reach = (points @ normals.T).max(axis=0) + 1e-9 * max(float(np.ptp(points)), 1.0)
    try:
        vertices = HalfspaceIntersection(np.c_[normals, -reach], points.mean(axis=0))
        vertices = vertices.intersections
        return vertices[ConvexHull(vertices).vertices]
    except (QhullError, ValueError):
        return corners


def boxes_overlap(lo_a, hi_a, lo_b, hi_b):
    """Whether intervals overlap on every axis, vectorized over the leading axes."""
    return np.logical_and.reduce((lo_a <= hi_b) & (lo_b <= hi_a), axis=-1)


def obb_overlap(centre_a, axes_a, half_a, centre_b, axes_b, half_b):
    """Separating-axis test of oriented boxes, vectorized over pairs ``(K, ...)``.

    The 15 candidate axes (3 + 3 face normals, 9 edge cross products;
    Gottschalk et al. 1996) are built explicitly and everything is projected on
    them in a few stacked products. Any nonzero axis that separates the
    projections proves the boxes apart; a tolerance relative to the boxes' size
    keeps rounding on near-parallel edges (tiny cross products) from doing so.
    """
    rows_a, rows_b = axes_a.swapaxes(1, 2), axes_b.swapaxes(1, 2)
    a, b = rows_a[:, :, None], rows_b[:, None, :]
    crossed = (a[..., NEXT] * b[..., AFTER] - a[..., AFTER] * b[..., NEXT]).reshape(-1, 9, 3)
    axes = np.concatenate([rows_a, rows_b, crossed], axis=1)                # (K, 15, 3)
    offset = centre_b - centre_a
    gap = np.abs(axes @ offset[:, :, None])[:, :, 0]
    reach = (np.abs(axes @ axes_a) @ half_a[:, :, None] + np.abs(axes @ axes_b)
             @ half_b[:, :, None])[:, :, 0]
    slack = 1e-12 * (np.abs(offset) + half_a + half_b).sum(axis=1)
    return ~np.logical_or.reduce(gap > reach + slack[:, None], axis=1)


class Supports:
    """Every object's support points (whose padded hull contains it) and local OBB,
    packed so the bounds of many placed objects come out of a few batched products.

    Points are grouped by count (multiples of 8, padded by repeating a
    point), one array per group laid out as coordinates then points, so the
    reductions run along contiguous rows.
    """

    def __init__(self, supports, obbs):
        counts = [len(p) for p, _ in supports]
        sizes = [8 * -(-c // 8) for c in counts]
        self.groups = sorted(set(sizes))
        self.group = np.array([self.groups.index(size) for size in sizes], np.int64)
        self.row = np.zeros(len(supports), np.int64)
        self.points, self.pads = [], []
        for g, size in enumerate(self.groups):
            members = np.flatnonzero(self.group == g)
            self.row[members] = np.arange(len(members))
            fill = [np.r_[np.arange(counts[i]), np.zeros(size - counts[i], np.int64)]
                    for i in members]
            self.points.append(np.stack([supports[i][0][f].T for i, f in zip(members, fill)]))
            pad = np.stack([supports[i][1][f][None] for i, f in zip(members, fill)])
            self.pads.append(pad if pad.any() else None)
        self.centre = np.array([o[0] for o in obbs]).reshape(-1, 3)
        self.axes = np.array([o[1] for o in obbs]).reshape(-1, 3, 3)
        self.half = np.array([o[2] for o in obbs]).reshape(-1, 3)

    def place(self, ids, rot, shift):
        """Bounds of objects ``ids`` (E,) turned by ``rot`` (E, 3, 3) and moved by
        ``shift`` (E, 3): the world 18-DOP (E, 2, 9) (its first three slabs are
        the AABB) and OBB centre (E, 3) and axes (E, 3, 3)."""
        kdop = np.empty((len(ids), 2, 9))
        offset = shift @ KDOP_DIRECTIONS.T
        group = self.group[ids]
        for g in np.bincount(group, minlength=len(self.points)).nonzero()[0]:
            points, pad = self.points[g], self.pads[g]
            members = (group == g).nonzero()[0]
            for start in range(0, len(members), PLACE_CHUNK):
                e = members[start:start + PLACE_CHUNK]
                rows = self.row[ids[e]]
                # project the support points on the world directions turned into each frame
                proj = (KDOP_DIRECTIONS @ rot[e]) @ points[rows]                 # (k, 9, size)
                if pad is None:
                    low, high = proj.min(axis=2), proj.max(axis=2)
                else:
                    low, high = (proj - pad[rows]).min(axis=2), (proj + pad[rows]).max(axis=2)
                kdop[e, 0], kdop[e, 1] = low + offset[e], high + offset[e]
        centre = (rot @ self.centre[ids][:, :, None])[:, :, 0] + shift
        return kdop, centre, rot @ self.axes[ids]


def sweep_and_prune(lo, hi):
    """Index pairs ``(i, j)``, ``i < j``, of boxes that overlap, sorted.

    Sorts the boxes along the axis where their centres spread most, pairs each
    box with those whose start falls inside its interval there, then keeps the
    pairs that overlap on all three axes.
    """
    n = len(lo)
    if n < 2:
        return np.empty((0, 2), np.int64)
    axis = int(np.argmax(np.ptp(lo + hi, axis=0)))
    order = np.argsort(lo[:, axis], kind="stable")
    starts = lo[order, axis]
    reach = np.searchsorted(starts, hi[order, axis], side="right")
    counts = np.maximum(reach - np.arange(n) - 1, 0)
    runs = Groups(counts)
    first = runs.index
    second = first + 1 + runs.local()
    i, j = order[first], order[second]
    keep = boxes_overlap(lo[i], hi[i], lo[j], hi[j])
    pairs = np.sort(np.stack([i[keep], j[keep]], axis=1), axis=1)
    return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]


def overlapping_pairs(lo, hi, first, second):
    """Which of the pairs ``(first[k], second[k])`` (every ``i < j``) have overlapping
    boxes, as a mask: all at once for small scenes, by :func:`sweep_and_prune`
    from :data:`SWEEP_MIN_OBJECTS` objects on."""
    if len(lo) < SWEEP_MIN_OBJECTS:
        return boxes_overlap(lo[first], hi[first], lo[second], hi[second])
    hit = sweep_and_prune(lo, hi)
    n = len(lo)
    mask = np.zeros(len(first), bool)
    mask[(hit[:, 0] * (2 * n - hit[:, 0] - 1)) // 2 + hit[:, 1] - hit[:, 0] - 1] = True
    return mask
