"""The flat faces between rings, as planes: how far a tube's surface lies from a point.

A tube's side is bands of triangles between consecutive rings
(:func:`~cadpipe.geometry.loft.zipper_faces`; pipes of one ring size use the same
pattern as :meth:`~cadpipe.geometry.loft.Surface.add_rings`). Where rings are mitred,
tapered or twisted the faces lean and the quads bend, so the distance from the path to
the surface, and from a bore to the outer surface, is measured on those very faces
rather than from the rings' radii: an envelope grows its rings until every face clears
the balls at its rings, a bore shrinks its rings until each of its vertices lies a wall
inside every face plane of the outer bands it belongs to.
"""

import numpy as np

from cadpipe.geometry.loft import zipper_pattern


def band_planes(rings_a, rings_b, offset=0.0):
    """Unit outward normals and offsets of the faces between ring pairs.

    Parameters
    ----------
    rings_a, rings_b : (B, na, 3), (B, nb, 3) float
        Each band's upstream and downstream ring, counter-clockwise about the path.
    offset : float
        The angular offset of ring b's vertex 0, in its steps (see
        :func:`~cadpipe.geometry.loft.zipper_faces`).

    Returns
    -------
    normals : (B, na + nb, 3) float
    offsets : (B, na + nb) float
        ``normals . x = offsets`` on each face; a degenerate face has offset ``inf``
        (no constraint).
    """
    tri = band_triangles(rings_a, rings_b, offset)
    normal = np.cross(tri[:, :, 1] - tri[:, :, 0], tri[:, :, 2] - tri[:, :, 0])
    size = np.linalg.norm(normal, axis=2)
    flat = size > 0
    normal = normal / np.where(flat, size, 1.0)[..., None]
    return normal, np.where(flat, np.einsum("bfc,bfc->bf", normal, tri[:, :, 0]), np.inf)


def band_triangles(rings_a, rings_b, offset=0.0):
    """(B, na + nb, 3, 3) the faces between ring pairs, as :func:`band_planes` has them."""
    pattern = zipper_pattern(rings_a.shape[1], rings_b.shape[1], offset)
    return np.concatenate([rings_a, rings_b], axis=1)[:, pattern]


def clearance(triangles, points):
    """(B,) least distance from each band's point ``points`` (B, 3) to its faces
    ``triangles`` (B, F, 3, 3): to the face's plane where the point's foot falls inside
    it, else to its nearest edge."""
    p = points[:, None]
    a, b, c = triangles[:, :, 0], triangles[:, :, 1], triangles[:, :, 2]
    normal = np.cross(b - a, c - a)
    area = np.einsum("bfc,bfc->bf", normal, normal)
    inside = area > 0
    for u, v in ((a, b), (b, c), (c, a)):       # the foot on the inner side of each edge
        inside &= np.einsum("bfc,bfc->bf", np.cross(v - u, p - u), normal) >= 0
    with np.errstate(divide="ignore", invalid="ignore"):
        plane = np.abs(np.einsum("bfc,bfc->bf", p - a, normal)) / np.sqrt(area)
    edges = np.minimum.reduce([_to_edge(p, u, v) for u, v in ((a, b), (b, c), (c, a))])
    return np.where(inside, plane, edges).min(axis=1)


def _to_edge(p, u, v):
    """(B, F) distance from points ``p`` (B, 1, 3) to segments ``u``-``v`` (B, F, 3)."""
    d = v - u
    size = np.einsum("bfc,bfc->bf", d, d)
    t = np.clip(np.einsum("bfc,bfc->bf", p - u, d) / np.where(size > 0, size, 1.0), 0.0, 1.0)
    off = p - u - t[..., None] * d
    return np.sqrt(np.einsum("bfc,bfc->bf", off, off))


def support(normals, axes, sides):
    """(B, F) how far each ring's polygon reaches from its centre along each normal:
    ``max_k n . (v_k - c)`` for ring vertices ``c + cos(a_k) e0 + sin(a_k) e1``,
    ``a_k = 2 pi k / sides`` (``axes`` (B, 3, 3): e0, e1, c)."""
    u = np.einsum("bfc,bc->bf", normals, axes[:, 0])
    v = np.einsum("bfc,bc->bf", normals, axes[:, 1])
    step = 2 * np.pi / sides
    off = np.mod(np.arctan2(v, u), step)
    return np.hypot(u, v) * np.cos(np.minimum(off, step - off))


def wall_scales(normals, offsets, axes, sides, wall, centres):
    """(B,) largest scale of each ring about its centre that keeps all its vertices
    ``wall`` inside every face plane of a band it belongs to (``normals``,
    ``offsets`` of those faces, (B, F, 3) and (B, F)).

    A face whose plane passes within ``wall`` of either of its band's ring centres
    (``centres``, (B, 2, 3)) stands across the tube rather than along it (a stitch
    between rings that lean apart): its plane says nothing of the wall, and it is left
    out."""
    inside = offsets[:, None] - np.einsum("bfc,bkc->bkf", normals, centres)
    offsets = np.where((inside > wall).all(axis=1), offsets, np.inf)
    room = offsets - wall - np.einsum("bfc,bc->bf", normals, axes[:, 2])
    reach = support(normals, axes, sides)
    with np.errstate(divide="ignore", invalid="ignore"):
        limit = np.where(reach > 0, room / reach, np.inf)
    return limit.min(axis=1)
