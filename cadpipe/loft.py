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


def zipper_faces(a_start, n_a, b_start, n_b, b_offset=0):
    """Faces joining ring A (upstream) to ring B (downstream) of any sizes.

    Vertex ``i`` of A sits at angle ``2*pi*i/n_a`` and vertex ``j`` of B at
    ``2*pi*(j + b_offset)/n_b`` about the common axis. Walking both rings in angle
    order, each A edge gets one triangle to the current B vertex and each B edge one
    to the current A vertex: ``n_a + n_b`` triangles, every vertex used. When
    ``n_b`` is a multiple of ``n_a`` and the rings are aligned, this is the source's
    n-to-1 stitch: each A vertex fans over ``n_b / n_a`` B edges.
    """
    mid_a = (np.arange(n_a) + 0.5) / n_a
    mid_b = ((np.arange(n_b) + 0.5 + b_offset) / n_b) % 1.0
    first_b = int(np.argmin(mid_b))                   # the B vertex current at angle 0
    mid_b = np.roll(mid_b, -first_b)
    is_a = np.concatenate([np.ones(n_a, bool), np.zeros(n_b, bool)])
    order = np.lexsort((~is_a, np.concatenate([mid_a, mid_b])))   # by angle, A first on ties
    is_a = is_a[order]
    a_cur = np.cumsum(is_a) - is_a                    # A edges passed before each event
    b_cur = np.cumsum(~is_a) - ~is_a
    a0, a1 = a_start + a_cur % n_a, a_start + (a_cur + 1) % n_a
    b0 = b_start + (first_b + b_cur) % n_b
    b1 = b_start + (first_b + b_cur + 1) % n_b
    return np.where(is_a[:, None], np.stack([a0, a1, b0], 1), np.stack([a0, b1, b0], 1))
