"""Step S33: stitching rings of vertices into triangle surfaces.

Rings are stored one after another in a vertex array, ``sides`` vertices each,
counter-clockwise about the direction of travel. The functions here only make
face index arrays, so every surface built from rings (pipe sides, caps, splice
transitions) shares one orientation rule: faces point away from the axis.
"""

import numpy as np


def band_faces(n_rings, sides, *, closed=False, seam_shift=0, first=0, out=None):
    """Side faces joining consecutive rings of equal size.

    Ring ``i`` starts at vertex ``first + i * sides``. For a closed tube the last
    ring joins the first, its vertex ``k`` meeting the first ring's vertex
    ``k + seam_shift``. ``out`` (an ``(F, 3)`` int64 array) receives the faces
    without an extra copy; its length must be :func:`band_face_count`.
    """
    k = np.arange(sides)
    k1 = (k + 1) % sides
    # one band between ring 0 and ring 1: quads (a, b, d, c) as triangles (a,b,c), (b,d,c)
    tri = np.stack([np.stack([k, k1, k + sides], 1), np.stack([k1, k1 + sides, k + sides], 1)],
                   1).reshape(-1, 3) + first
    n_bands = n_rings - 1
    if out is None:
        out = np.empty((band_face_count(n_rings, sides, closed), 3), np.int64)
    offsets = np.arange(n_bands, dtype=np.int64) * sides
    np.add(offsets[:, None, None], tri[None], out=out[: n_bands * 2 * sides].reshape(n_bands,
                                                                                    2 * sides, 3))
    if closed:
        last = (n_rings - 1) * sides + first
        ks = (k + seam_shift) % sides + first
        ks1 = (k1 + seam_shift) % sides + first
        out[n_bands * 2 * sides:] = np.concatenate([np.stack([last + k, last + k1, ks], 1),
                                                    np.stack([last + k1, ks1, ks], 1)])
    return out


def band_face_count(n_rings, sides, closed=False):
    return 2 * sides * (n_rings if closed else n_rings - 1)


def fan_faces(ring_start, sides, *, apex=None, at_end=False):
    """Cap faces closing one ring: a fan from its vertex 0, or to an ``apex`` vertex.

    A cap at the start of a tube faces backwards, one at the end forwards.
    """
    k = np.arange(sides)
    if apex is None:
        k = k[1:-1]
        tri = np.stack([np.zeros_like(k), k, k + 1], 1) + ring_start
    else:
        tri = np.stack([np.full(sides, apex - ring_start), k, (k + 1) % sides], 1) + ring_start
        tri[:, 0] = apex
    return tri if at_end else tri[:, ::-1]
