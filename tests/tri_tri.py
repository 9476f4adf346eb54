"""A test-only oracle: does a triangle mesh intersect itself?

Written for the tests, sharing no code with cadpipe's own self-intersection
checks. Two triangles that share no vertex intersect (transversally) when an edge
of one crosses the other's interior; candidate pairs come from overlapping
bounding boxes (an rtree), and each edge-triangle test is vectorized over pairs.
Pairs that share a vertex are adjacent in a valid mesh and are not tested.
Touching within ``rel_tol`` of the mesh size is not counted (coplanar contact is
a matter of rounding, not a wrong result).
"""

import numpy as np


def _candidate_pairs(tri, pad):
    """Index pairs ``i < j`` of triangles whose padded boxes overlap (an rtree query)."""
    from rtree import index

    lo, hi = tri.min(axis=1) - pad, tri.max(axis=1) + pad
    properties = index.Property(dimension=3)
    tree = index.Index(((i, (*lo[i], *hi[i]), None) for i in range(len(tri))),
                       properties=properties)
    ids, counts = tree.intersection_v(lo, hi)
    first = np.repeat(np.arange(len(tri)), counts.astype(np.int64))
    ids = ids.astype(np.int64)
    keep = first < ids
    return first[keep], ids[keep]


def _edges_cross(p, q, a, b, c, eps):
    """(K,) bool: segment p-q crosses triangle abc's interior (strictly)."""
    n = np.cross(b - a, c - a)
    scale = np.linalg.norm(n, axis=1)
    dp = np.einsum("ij,ij->i", p - a, n)
    dq = np.einsum("ij,ij->i", q - a, n)
    tol = eps * scale
    crossing = ((dp > tol) & (dq < -tol)) | ((dp < -tol) & (dq > tol))
    t = np.divide(dp, dp - dq, out=np.zeros_like(dp), where=crossing)
    x = p + t[:, None] * (q - p)
    inside = np.ones(len(p), bool)
    for u, v in ((a, b), (b, c), (c, a)):
        inside &= np.einsum("ij,ij->i", np.cross(v - u, x - u), n) > tol * scale
    return crossing & inside


def self_intersections(vertices, faces, rel_tol=1e-9):
    """Number of face pairs (sharing no vertex) that cross each other."""
    vertices = np.asarray(vertices, np.float64)
    faces = np.asarray(faces, np.int64)
    tri = vertices[faces]
    size = float(np.ptp(vertices, axis=0).max()) or 1.0
    i, j = _candidate_pairs(tri, rel_tol * size)
    shared = (faces[i][:, :, None] == faces[j][:, None, :]).any(axis=(1, 2))
    i, j = i[~shared], j[~shared]
    if not len(i):
        return 0
    hit = np.zeros(len(i), bool)
    eps = rel_tol * size
    for s, o in ((i, j), (j, i)):
        t, u = tri[s], tri[o]
        for e in range(3):
            hit |= _edges_cross(t[:, e], t[:, (e + 1) % 3], u[:, 0], u[:, 1], u[:, 2], eps)
    return int(hit.sum())
