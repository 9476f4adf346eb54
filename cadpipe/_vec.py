"""Vector helpers over an axis of 3 components (the last by default: rows of (N, 3)).

The batch code keeps vectors component-first, ``(3, N)`` with ``axis=0``: every
operation then runs over long contiguous rows. Measured by ``benchmarks/bench_vec.py``
(100,000 vectors, medians; docs/performance.md): these helpers run 1.7-2.8x faster
on ``(3, N)`` than on ``(N, 3)``; on ``(3, N)``, ``norm`` (einsum) is 1.2x
``np.linalg.norm``, ``dot`` 1.4-1.6x ``(a * b).sum``, ``cross`` 10-15x ``np.cross``
(9.7-15x over three runs). ``bounds`` is one compiled pass over ``(N, 3)`` rows:
numpy's ``min(axis=0)`` and ``max(axis=0)`` over rows of 3 took 28 ms for 500,000
rows, this 0.45 ms.
"""

import numba
import numpy as np

_DOT = {0: "i...,i...->...", -1: "...i,...i->..."}


def norm(v, axis=-1):
    """Euclidean length of each vector."""
    return np.sqrt(dot(v, v, axis))


def dot(a, b, axis=-1):
    """Dot product of each pair of vectors (``axis`` is 0 or -1)."""
    return np.einsum(_DOT[axis], a, b)


def unit(v, axis=-1):
    """Vectors scaled to unit length (zero vectors stay zero)."""
    n = np.expand_dims(norm(v, axis), axis)
    return v / np.where(n > 0, n, 1.0)


def cross(a, b, axis=-1):
    """Cross product of each pair of vectors, without np.cross's axis juggling."""
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    if axis != 0:
        a, b, o = np.moveaxis(a, axis, 0), np.moveaxis(b, axis, 0), np.moveaxis(out, axis, 0)
    else:
        o = out
    o[0] = a[1] * b[2] - a[2] * b[1]
    o[1] = a[2] * b[0] - a[0] * b[2]
    o[2] = a[0] * b[1] - a[1] * b[0]
    return out


def bounds(points):
    """(2, 3) least and greatest coordinates of (N, 3) finite ``points`` (zeros if N = 0),
    in their own dtype."""
    points = np.ascontiguousarray(points)
    if len(points) == 0:
        return np.zeros((2, 3), points.dtype)
    return _bounds(points)


# fastmath: the points are finite, and without NaNs the running minima vectorize
@numba.njit(cache=True, nogil=True, fastmath=True)
def _bounds(points):
    lx = hx = points[0, 0]
    ly = hy = points[0, 1]
    lz = hz = points[0, 2]
    for i in range(1, len(points)):
        x, y, z = points[i, 0], points[i, 1], points[i, 2]
        lx, hx = min(lx, x), max(hx, x)
        ly, hy = min(ly, y), max(hy, y)
        lz, hz = min(lz, z), max(hz, z)
    out = np.empty((2, 3), points.dtype)
    out[0, 0], out[0, 1], out[0, 2] = lx, ly, lz
    out[1, 0], out[1, 1], out[1, 2] = hx, hy, hz
    return out
