"""Distinct rows of an integer table, in first-seen order, by hashing (compiled).

Welding a file's vertices and sharing equal normals both ask which rows of a
large (N, 3) table are equal. ``np.unique(axis=0)`` sorts 24-byte rows with a
generic comparison (seconds for millions); one pass through a hash table costs
a fraction of that and keeps the rows in the order they were first met.
"""

import numba
import numpy as np


def unique_rows(keys):
    """The distinct rows of ``keys``.

    Parameters
    ----------
    keys : (N, 3) int64 array
        Rows to compare exactly (floats compare as their bit patterns:
        ``floats.view(np.int64)``, after adding 0.0 so -0.0 is 0.0).

    Returns
    -------
    first : (U,) int64
        Index of the first row of each distinct row, in increasing order.
    inverse : (N,) int64
        Which distinct row each row is: ``keys[first][inverse] == keys``.
    """
    return _unique_rows(np.ascontiguousarray(keys, np.int64))


@numba.njit(cache=True, nogil=True)
def _unique_rows(keys):
    n = len(keys)
    size = 1
    while size < 2 * n:
        size *= 2
    table = np.full(size, -1, np.int64)              # open addressing, linear probing
    first = np.empty(n, np.int64)
    inverse = np.empty(n, np.int64)
    count = 0
    for i in range(n):
        a, b, c = keys[i, 0], keys[i, 1], keys[i, 2]
        h = ((a * np.int64(-7046029254386353131)) ^ (b * np.int64(-4658895280553007687))
             ^ (c * np.int64(-3372029247567499371)))
        slot = (h ^ (h >> 29)) & (size - 1)
        while True:
            row = table[slot]
            if row == -1:
                table[slot] = count
                first[count] = i
                inverse[i] = count
                count += 1
                break
            j = first[row]
            if keys[j, 0] == a and keys[j, 1] == b and keys[j, 2] == c:
                inverse[i] = row
                break
            slot = (slot + 1) & (size - 1)
    return first[:count].copy(), inverse


def point_keys(points, decimals=8):
    """(N, 3) int64 keys of ``points`` (N, 3) float: equal where the points agree to
    ``decimals`` decimals (``np.round``'s rule: nearest, ties to even; -0.0 is 0.0),
    for :func:`unique_rows`. The bit patterns of ``rint(x * 10**decimals)``, in one
    pass with no temporaries."""
    return _point_keys(np.ascontiguousarray(points, np.float64), 10.0 ** decimals)


@numba.njit(cache=True, nogil=True)
def _point_keys(points, scale):
    keys = np.empty(points.shape, np.int64)
    bits = keys.view(np.float64)
    for i in range(len(points)):
        for axis in range(3):
            bits[i, axis] = np.rint(points[i, axis] * scale) + 0.0
    return keys
