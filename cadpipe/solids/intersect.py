"""Faces of a mesh that cut through each other (self-intersections).

Broad phase: an implicit bounding-volume hierarchy. Triangles are sorted along
a Morton (Z-order) curve and grouped into leaves of :data:`LEAF` triangles;
level ``k`` node ``i`` covers leaves ``[i * 2**k, (i + 1) * 2**k)``, so the tree
is a list of box arrays, one per level. Overlapping node pairs are expanded
level by level, one numpy operation per level for all pairs at once.
(rtree's bulk query spends ~30 us per triangle in Python-facing calls: a
minute for a million triangles; this takes seconds.)

Narrow phase: two triangles that share no vertex intersect when an edge of
one passes through the interior of the other. Touching (within
:func:`touching_tolerance`) does not count, and neither do neighbouring faces that
share a vertex or coplanar overlaps (those show up as non-manifold edges).
"""

import numpy as np

from cadpipe.solids.booleans import float32_step

#: triangles per leaf of the hierarchy
LEAF = 4
#: leaf pairs expanded into triangle pairs at once (bounds memory)
_BLOCK = 1 << 15


def self_intersections(mesh):
    """(K, 2) int array of face index pairs ``i < j`` whose triangles cut through each other."""
    faces = mesh.faces
    if len(faces) < 2:
        return np.empty((0, 2), np.int64)
    tri = mesh.triangles
    tol = touching_tolerance(mesh)
    found = []
    for pairs in box_pairs(tri.min(axis=1), tri.max(axis=1)):
        shared = (faces[pairs[:, 0]][:, :, None] == faces[pairs[:, 1]][:, None, :]).any(axis=(1, 2))
        pairs = pairs[~shared]
        a, b = tri[pairs[:, 0]], tri[pairs[:, 1]]
        na, nb = mesh.face_normals[pairs[:, 0]], mesh.face_normals[pairs[:, 1]]
        # signed distances of each triangle's corners from the other's plane; a
        # triangle wholly on one side of the other's plane cannot cut it (most pairs)
        db = np.einsum("pkc,pc->pk", b - a[:, :1], na)
        da = np.einsum("pkc,pc->pk", a - b[:, :1], nb)
        keep = _straddles(da, tol) & _straddles(db, tol)
        pairs, a, b, na, nb, da, db = (x[keep] for x in (pairs, a, b, na, nb, da, db))
        hit = _edges_pierce(b, db, a, na, tol) | _edges_pierce(a, da, b, nb, tol)
        found.append(pairs[hit])
    found = np.concatenate(found) if found else np.empty((0, 2), np.int64)
    found = np.sort(found, axis=1)
    return found[np.lexsort((found[:, 1], found[:, 0]))]


def touching_tolerance(mesh):
    """Distance below which faces touch rather than cross: 1e-9 of the mesh's size, or,
    for coordinates that are all float32 values (read from STL, 3MF, GLB, USD), a
    few float32 steps at the mesh's largest coordinate, so rounding to float32 does not
    turn touching faces into crossing ones."""
    vertices = mesh.vertices
    tol = 1e-9 * float(np.linalg.norm(mesh.bounds[1] - mesh.bounds[0]))
    if len(vertices) and np.array_equal(vertices.astype(np.float32), vertices):
        tol = max(tol, 2 * float32_step(mesh.bounds))
    return tol


def _straddles(d, tol):
    """(P,) True where the three signed distances ``d`` (P, 3) are not all on one side."""
    return ~((d > tol).all(axis=1) | (d < -tol).all(axis=1))


def _edges_pierce(edges_of, d, target, normal, tol):
    """(P,) True where an edge of triangle ``edges_of`` crosses the interior of ``target``.

    ``edges_of``, ``target``: (P, 3, 3) triangles; ``d``: (P, 3) signed distances of
    ``edges_of``'s corners from the plane of ``target``; ``normal``: (P, 3) unit
    normals of ``target``.
    """
    start, end = edges_of, np.roll(edges_of, -1, axis=1)            # (P, 3, 3) edges
    d_start, d_end = d, np.roll(d, -1, axis=1)
    crosses = ((d_start > tol) & (d_end < -tol)) | ((d_start < -tol) & (d_end > tol))
    with np.errstate(invalid="ignore", divide="ignore"):
        t = np.where(crosses, d_start / (d_start - d_end), 0.0)
    point = start + t[..., None] * (end - start)                    # (P, 3 edges, 3)
    # the crossing point must lie inside the target, beyond tol from each of its sides
    u = target[:, None, :, :]                                      # (P, 1, 3 sides, 3)
    side = np.roll(target, -1, axis=1)[:, None] - u
    inward = np.einsum("pesc,pc->pes", np.cross(side, point[:, :, None, :] - u), normal)
    length = np.linalg.norm(side, axis=-1)
    inside = (inward > tol * length).all(axis=2)
    return (crosses & inside).any(axis=1)


def box_pairs(lo, hi):
    """Yield (M, 2) arrays of index pairs ``i != j`` of boxes that overlap (each pair once).

    ``lo``, ``hi``: (N, 3) box corners. Touching boxes count as overlapping.
    """
    n = len(lo)
    order = np.argsort(_morton((lo + hi) / 2), kind="stable")
    n_leaves = 1 << int(np.ceil(np.log2(max(1, -(-n // LEAF)))))
    size = n_leaves * LEAF
    # padding boxes are empty (lo = +inf, hi = -inf): they overlap nothing
    sorted_lo = np.full((3, size), np.inf)
    sorted_hi = np.full((3, size), -np.inf)
    sorted_lo[:, :n], sorted_hi[:, :n] = lo[order].T, hi[order].T
    levels = [(sorted_lo.reshape(3, n_leaves, LEAF).min(axis=2),
               sorted_hi.reshape(3, n_leaves, LEAF).max(axis=2))]
    while levels[-1][0].shape[1] > 1:
        below_lo, below_hi = levels[-1]
        levels.append((np.minimum(below_lo[:, 0::2], below_lo[:, 1::2]),
                       np.maximum(below_hi[:, 0::2], below_hi[:, 1::2])))
    children = np.array([[0, 0], [0, 1], [1, 0], [1, 1]])
    nodes = np.zeros((1, 2), np.int64)                              # (root, root)
    for level_lo, level_hi in reversed(levels[:-1]):
        nodes = (2 * nodes[:, None, :] + children).reshape(-1, 2)
        nodes = nodes[nodes[:, 0] <= nodes[:, 1]]
        nodes = _overlapping(level_lo, level_hi, nodes)
    slots = np.stack(np.meshgrid(np.arange(LEAF), np.arange(LEAF), indexing="ij"),
                     axis=-1).reshape(-1, 2)
    for start in range(0, len(nodes), _BLOCK):
        leaves = nodes[start:start + _BLOCK]
        pairs = (leaves[:, None, :] * LEAF + slots).reshape(-1, 2)
        pairs = pairs[(pairs[:, 0] < pairs[:, 1]) & (pairs[:, 1] < n)]
        pairs = _overlapping(sorted_lo, sorted_hi, pairs)
        if len(pairs):
            yield order[pairs]


def _overlapping(lo, hi, pairs):
    """The rows of ``pairs`` whose boxes overlap, testing one axis at a time.

    ``lo``, ``hi``: (3, N) per-axis box bounds. Each axis drops most pairs that
    fail, so the later axes gather far fewer values.
    """
    for axis in range(3):
        a, b = pairs[:, 0], pairs[:, 1]
        low, high = lo[axis], hi[axis]
        pairs = pairs[(low[a] <= high[b]) & (low[b] <= high[a])]
    return pairs


def _morton(points):
    """Z-order curve key of each point (21 bits per axis over the points' bounds)."""
    low, span = points.min(axis=0), np.ptp(points, axis=0)
    cells = ((points - low) / np.where(span > 0, span, 1.0) * (2**21 - 1)).astype(np.uint64)
    key = np.zeros(len(points), np.uint64)
    for bit in range(21):
        for axis in range(3):
            key |= ((cells[:, axis] >> np.uint64(bit)) & np.uint64(1)) << np.uint64(3 * bit
                                                                                    + axis)
    return key
