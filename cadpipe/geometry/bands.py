"""The flat faces between rings, as planes: how far a tube's surface lies from a point.

A tube's side is bands of triangles between consecutive rings
(:func:`~cadpipe.geometry.loft.zipper_faces`; pipes of one ring size use the same
pattern as :meth:`~cadpipe.geometry.loft.Surface.add_rings`). Where rings are mitred,
tapered or twisted the faces lean and the quads bend, so the distance from the path to
the surface, and from a bore to the outer surface, is measured on those very faces
rather than from the rings' radii: an envelope grows its rings until every face clears
the balls it must hold, a bore shrinks its rings until each of its vertices lies a wall
inside every face plane of the outer bands it belongs to.
"""

import numpy as np

from cadpipe.geometry.loft import _zipper_pattern


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
    na, nb = rings_a.shape[1], rings_b.shape[1]
    pattern = _zipper_pattern(na, nb, offset)
    tri = np.concatenate([rings_a, rings_b], axis=1)[:, pattern]          # (B, F, 3, 3)
    normal = np.cross(tri[:, :, 1] - tri[:, :, 0], tri[:, :, 2] - tri[:, :, 0])
    size = np.linalg.norm(normal, axis=2)
    flat = size > 0
    normal = normal / np.where(flat, size, 1.0)[..., None]
    return normal, np.where(flat, np.einsum("bfc,bfc->bf", normal, tri[:, :, 0]), np.inf)


def clearance(normals, offsets, points):
    """(B,) least distance, inside, from each band's point ``points`` (B, 3) to the
    planes of its faces."""
    return (offsets - np.einsum("bfc,bc->bf", normals, points)).min(axis=1)


def support(normals, axes, sides):
    """(B, F) how far each ring's polygon reaches from its centre along each normal:
    ``max_k n . (v_k - c)`` for ring vertices ``c + cos(a_k) e0 + sin(a_k) e1``,
    ``a_k = 2 pi k / sides`` (``axes`` (B, 3, 3): e0, e1, c)."""
    u = np.einsum("bfc,bc->bf", normals, axes[:, 0])
    v = np.einsum("bfc,bc->bf", normals, axes[:, 1])
    step = 2 * np.pi / sides
    off = np.mod(np.arctan2(v, u), step)
    return np.hypot(u, v) * np.cos(np.minimum(off, step - off))


def wall_scales(normals, offsets, axes, sides, wall):
    """(B,) largest scale of each ring about its centre that keeps all its vertices
    ``wall`` inside every face plane of a band it belongs to (``normals``,
    ``offsets`` of those faces, (B, F, 3) and (B, F))."""
    room = offsets - wall - np.einsum("bfc,bc->bf", normals, axes[:, 2])
    reach = support(normals, axes, sides)
    with np.errstate(divide="ignore", invalid="ignore"):
        limit = np.where(reach > 0, room / reach, np.inf)
    return limit.min(axis=1)
