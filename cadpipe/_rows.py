"""Distinct points, in first-seen order, by hashing (compiled): welding a file's vertices.

Files store a vertex once per triangle (STL) or once per normal or colour (GLB,
PLY); which of their points are the same point is one pass through a hash
table, keyed on the coordinates rounded to a number of decimals, that keeps the
points in the order they were first met. ``np.unique(axis=0)`` would sort
24-byte rows with a generic comparison (seconds for millions), and a table of
keys made first would cost a full-size pass and array more.
"""

import numba
import numpy as np


def unique_points(points, decimals=8):
    """The distinct points of ``points``, equal where they agree to ``decimals`` decimals.

    Parameters
    ----------
    points : (N, 3) float array
    decimals : int
        Points are compared as ``np.round(points, decimals)`` (nearest, ties to
        even; -0.0 is 0.0), as trimesh's ``merge_vertices`` does.

    Returns
    -------
    first : (U,) int64
        Index of the first of each distinct point, in increasing order.
    inverse : (N,) int64
        Which distinct point each point is: ``points[first][inverse]`` rounds as
        ``points`` does.
    """
    return _unique_points(np.ascontiguousarray(points, np.float64), 10.0 ** decimals)


@numba.njit(cache=True, nogil=True)
def _unique_points(points, scale):
    n = len(points)
    size = 1
    while size < 2 * n:
        size *= 2
    # open addressing, linear probing; a slot holds 31 more bits of the hash above the
    # row, so a probe of another point's slot rarely reads that point (half the time
    # of a table of rows alone, whose every probe read a random point)
    table = np.full(size, -1, np.int64)
    first = np.empty(n, np.int64)
    inverse = np.empty(n, np.int64)
    rounded = np.empty(3)
    bits = rounded.view(np.int64)                    # the rounded coordinates' bit patterns
    count = 0
    for i in range(n):
        for axis in range(3):
            rounded[axis] = np.rint(points[i, axis] * scale) + 0.0
        h = ((bits[0] * np.int64(-7046029254386353131)) ^ (bits[1] * np.int64(-4658895280553007687))
             ^ (bits[2] * np.int64(-3372029247567499371)))
        h ^= h >> 29
        tag = (h >> 32) & 0x7FFFFFFF
        slot = h & (size - 1)
        while True:
            entry = table[slot]
            if entry == -1:
                table[slot] = (tag << 32) | count
                first[count] = i
                inverse[i] = count
                count += 1
                break
            if entry >> 32 == tag:
                row = entry & 0xFFFFFFFF
                j = first[row]
                if np.rint(points[j, 0] * scale) == rounded[0] and \
                        np.rint(points[j, 1] * scale) == rounded[1] and \
                        np.rint(points[j, 2] * scale) == rounded[2]:
                    inverse[i] = row
                    break
            slot = (slot + 1) & (size - 1)
    return first[:count].copy(), inverse
