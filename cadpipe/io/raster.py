"""A z-buffer over triangles in numpy: which triangle each pixel sees, and how far.

Previews must render where there is no GPU or display (CI, servers), so the
visibility step is plain numpy. Each triangle's pixel bounding box is expanded
into candidate pixels, tested against the triangle's three edge functions and
kept when it is nearer than what the buffer holds. The work is vectorized over
all triangles of a batch; batches only bound the memory of the candidate arrays,
so a mesh of any size costs a handful of numpy passes, never a loop per triangle
or per pixel. Shading is left to the caller: with the index of the visible
triangle per pixel, flat shading is one lookup.
"""

import numpy as np

from cadpipe.geometry.ragged import Groups

#: candidate pixels handled per batch (bounds the temporary arrays to ~ 100 MB, and
#: keeps offsets within a batch exact in float32)
BATCH = 1 << 21


def rasterize(screen, width, height):
    """Index of the nearest triangle at every pixel centre.

    Parameters
    ----------
    screen : (F, 3, 3) array_like
        Triangle corners as ``(x, y, depth)``: ``x`` and ``y`` in pixels (pixel
        ``(i, j)`` covers ``[i, i + 1) x [j, j + 1)``, ``y`` pointing down the
        image), smaller ``depth`` nearer the viewer. Either winding is drawn.
    width, height : int
        Size of the image in pixels.

    Returns
    -------
    index : (height, width) int32 array
        The visible triangle's index, or -1 where no triangle covers the pixel.
    depth : (height, width) float32 array
        Its depth at the pixel centre, ``inf`` where ``index`` is -1.
    """
    screen = np.asarray(screen, dtype=np.float64)
    xy, z = screen[:, :, :2], screen[:, :, 2]
    a, b, c = xy[:, 0], xy[:, 1], xy[:, 2]
    low = np.minimum(np.minimum(a, b), c)                        # (pairwise: faster than
    high = np.maximum(np.maximum(a, b), c)                       # a reduce over 3 corners)
    lo = np.maximum(np.floor(low - 0.5).astype(np.int64) + 1, 0)  # first centre >= min
    hi = np.minimum(np.floor(high - 0.5).astype(np.int64), [width - 1, height - 1])
    span = hi - lo + 1
    # corners relative to the box's first pixel centre keep float32 planes exact enough
    a, b, c = a - (lo + 0.5), b - (lo + 0.5), c - (lo + 0.5)
    area = _cross(b - a, c - a)
    count = np.where((span[:, 0] > 0) & (span[:, 1] > 0) & (area != 0),
                     span[:, 0] * span[:, 1], 0)
    keep = np.flatnonzero(count)

    # barycentric weights and depth are affine in the pixel's offset (u, v) in its box:
    # value = coef[0] * u + coef[1] * v + coef[2]
    inv = 1.0 / area[keep]
    a, b, c = a[keep], b[keep], c[keep]
    w_a = _edge_plane(b, c, inv)
    w_b = _edge_plane(c, a, inv)
    w_c = np.array([0.0, 0.0, 1.0]) - w_a - w_b
    zk = z[keep]
    plane_z = w_a * zk[:, :1] + w_b * zk[:, 1:2] + w_c * zk[:, 2:]
    planes = np.concatenate([w_a, w_b, plane_z], axis=1).T                    # (9, K)

    # a box larger than a batch is cut into bands of rows, so every batch stays bounded
    box_width, box_rows = span[keep, 0], span[keep, 1]
    band_rows = np.maximum(BATCH // box_width, 1)
    bands = -(-box_rows // band_rows)
    runs = Groups(bands)
    box = runs.index                                            # the box of each band
    first_row = runs.local() * band_rows[box]
    rows = np.minimum(band_rows[box], box_rows[box] - first_row)
    planes = planes[:, box]
    planes[[2, 5, 8]] += planes[[1, 4, 7]] * first_row          # v counted from the band's top
    planes = planes.astype(np.float32)
    origin = (lo[keep, 1][box] + first_row) * width + lo[keep, 0][box]
    count = rows * box_width[box]

    depth = np.full(width * height, np.inf, dtype=np.float32)
    index = np.full(width * height, -1, dtype=np.int32)
    starts = np.concatenate([[0], np.cumsum(count)])
    for first, last in _batches(starts):
        band = slice(first, last)
        _draw(keep[box[band]], planes[:, band], origin[band], box_width[box[band]],
              count[band], width, depth, index)
    return index.reshape(height, width), depth.reshape(height, width)


def _cross(u, v):
    return u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]


def _edge_plane(p, q, inv_area):
    """Coefficients of the barycentric weight of the corner opposite edge ``p -> q``."""
    return np.stack([(p[:, 1] - q[:, 1]) * inv_area,
                     (q[:, 0] - p[:, 0]) * inv_area,
                     (p[:, 0] * q[:, 1] - p[:, 1] * q[:, 0]) * inv_area], axis=1)


def _batches(starts):
    """``(first, last)`` band ranges whose candidate pixels add up to about BATCH."""
    bounds = np.searchsorted(starts, np.arange(0, starts[-1], BATCH), side="right") - 1
    bounds = np.unique(np.concatenate([bounds, [len(starts) - 1]]))
    return zip(bounds[:-1], bounds[1:])


def _draw(tri, planes, origin, span_x, count, width, depth, index):
    """Write one batch of triangles into the flat ``depth``/``index`` buffers."""
    owner = np.repeat(np.arange(len(tri)), count)
    first = (np.cumsum(count) - count).astype(np.float32)
    offset = np.arange(len(owner), dtype=np.float32) - first[owner]   # exact below 2**24
    box_width = span_x[owner].astype(np.float32)
    v = np.floor((offset + 0.5) / box_width)
    u = offset - v * box_width
    w_a = planes[0, owner] * u + planes[1, owner] * v + planes[2, owner]
    w_b = planes[3, owner] * u + planes[4, owner] * v + planes[5, owner]
    inside = np.flatnonzero((w_a >= 0) & (w_b >= 0) & (w_a + w_b <= 1))
    owner, u, v = owner[inside], u[inside], v[inside]
    z = planes[6, owner] * u + planes[7, owner] * v + planes[8, owner]
    pixel = origin[owner] + v.astype(np.int64) * width + u.astype(np.int64)
    np.minimum.at(depth, pixel, z)
    won = z <= depth[pixel]             # the nearest fragment of its pixel (ties: any)
    index[pixel[won]] = tri[owner[won]]
