"""Bounding volumes and the scene-level broad phase.

Three volumes per object, each a proof of "no contact" when two of them are
disjoint (the object lies inside its volume), tried from cheapest to tightest:

* AABB, the world-axis box, paired up for the whole scene by sweep-and-prune;
* 18-DOP, the slab on each of 9 fixed world directions (axes and face
  diagonals), recomputed from the object's convex-hull points each pose (its
  first three slabs are the AABB);
* OBB, a box fitted once in the object's own frame (trimesh's minimum-volume
  box) that moves with it, compared by the separating-axis theorem (15 axes).

Objects are described by points plus a per-point padding radius, so a mesh
(its hull vertices, pad 0) and a chain of balls (centres, pad = radius) share
every function here. All tests are vectorized over pairs.
"""

import numpy as np

#: the 9 directions of an 18-DOP: the axes and the 6 face diagonals
KDOP_DIRECTIONS = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1],
                            [1, 1, 0], [1, -1, 0], [1, 0, 1],
                            [1, 0, -1], [0, 1, 1], [0, 1, -1]], np.float64)
KDOP_DIRECTIONS /= np.linalg.norm(KDOP_DIRECTIONS, axis=1, keepdims=True)
#: below this many objects, testing all pairs at once beats sorting them
SWEEP_MIN_OBJECTS = 48


def aabb(points, pad):
    """(2, 3) box of balls ``B(points[i], pad[i])``."""
    return np.array([(points - pad[:, None]).min(axis=0), (points + pad[:, None]).max(axis=0)])


def kdop(points, pad):
    """(2, 9) slab of the balls on each of :data:`KDOP_DIRECTIONS`."""
    proj = points @ KDOP_DIRECTIONS.T
    return np.array([(proj - pad[:, None]).min(axis=0), (proj + pad[:, None]).max(axis=0)])


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


def boxes_overlap(lo_a, hi_a, lo_b, hi_b):
    """Whether intervals overlap on every axis, vectorized over the leading axes."""
    return np.all((lo_a <= hi_b) & (lo_b <= hi_a), axis=-1)


def obb_overlap(centre_a, axes_a, half_a, centre_b, axes_b, half_b):
    """Separating-axis test of oriented boxes, vectorized over pairs ``(K, ...)``.

    The 15 candidate axes (3 + 3 face normals, 9 edge cross products;
    Gottschalk et al. 1996) in the closed form of Ericson's "Real-Time
    Collision Detection" (4.4.1), all pairs at once. A small epsilon on the
    rotation keeps near-parallel edges from separating boxes that touch.
    """
    rot = np.swapaxes(axes_a, 1, 2) @ axes_b                       # B's axes in A's frame
    t = (np.swapaxes(axes_a, 1, 2) @ (centre_b - centre_a)[:, :, None])[:, :, 0]
    absr = np.abs(rot) + 1e-12
    reach_b = (absr @ half_b[:, :, None])[:, :, 0]
    sep = np.any(np.abs(t) > half_a + reach_b, axis=1)
    reach_a = (half_a[:, None, :] @ absr)[:, 0]
    sep |= np.any(np.abs((t[:, None, :] @ rot)[:, 0]) > reach_a + half_b, axis=1)
    # A_i x B_j for all i, j at once; index (i + 1) % 3 and (i + 2) % 3 by slicing
    # doubled arrays, which is far cheaper than fancy indexing
    t2, r2 = np.concatenate([t, t], axis=1), np.concatenate([rot, rot], axis=1)
    ar2, ac2 = np.concatenate([absr, absr], axis=1), np.concatenate([absr, absr], axis=2)
    ha2, hb2 = np.concatenate([half_a, half_a], axis=1), np.concatenate([half_b, half_b], axis=1)
    dist = np.abs(t2[:, 2:5, None] * r2[:, 1:4] - t2[:, 1:4, None] * r2[:, 2:5])
    reach = (ha2[:, 1:4, None] * ar2[:, 2:5] + ha2[:, 2:5, None] * ar2[:, 1:4]
             + hb2[:, None, 1:4] * ac2[:, :, 2:5] + hb2[:, None, 2:5] * ac2[:, :, 1:4])
    sep |= np.any(dist > reach, axis=(1, 2))
    return ~sep


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
    first = np.repeat(np.arange(n), counts)
    offsets = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    second = first + 1 + offsets
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
