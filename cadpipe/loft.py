"""Step S33: stitching rings of vertices into triangle surfaces.

Rings are stored one after another in a vertex array, ``sides`` vertices each,
counter-clockwise about the direction of travel. The functions here only make
face index arrays, so every surface built from rings (pipe sides, caps, splice
transitions) shares one orientation rule: faces point away from the axis.
"""

import numpy as np


def band_faces(n_rings, sides, *, closed=False, seam_shift=0, first=0):
    """Side faces joining consecutive rings of equal size.

    Ring ``i`` starts at vertex ``first + i * sides``. For a closed tube the last
    ring joins the first, its vertex ``k`` meeting the first ring's vertex
    ``k + seam_shift``.
    """
    k = np.arange(sides)
    k1 = (k + 1) % sides
    # one band between ring 0 and ring 1: quads (a, b, d, c) as triangles (a,b,c), (b,d,c)
    tri = np.stack([np.stack([k, k1, k + sides], 1), np.stack([k1, k1 + sides, k + sides], 1)],
                   1).reshape(-1, 3)
    n_bands = n_rings - 1
    faces = (np.arange(n_bands, dtype=np.int64) * sides)[:, None, None] + tri[None]
    faces = faces.reshape(-1, 3)
    if closed:
        last = (n_rings - 1) * sides
        ks = (k + seam_shift) % sides
        ks1 = (k1 + seam_shift) % sides
        seam = np.concatenate([np.stack([last + k, last + k1, ks], 1),
                               np.stack([last + k1, ks1, ks], 1)])
        faces = np.concatenate([faces, seam])
    return faces + first


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
