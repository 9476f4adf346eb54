"""Vector helpers over an axis of 3 components (the last by default: rows of (N, 3)).

The batch code keeps vectors component-first, ``(3, N)`` with ``axis=0``: every
operation then runs over long contiguous rows. Measured by ``benchmarks/bench_vec.py``
(100,000 vectors, medians; docs/performance.md): these helpers run 1.7-2.8x faster
on ``(3, N)`` than on ``(N, 3)``; on ``(3, N)``, ``norm`` (einsum) is 1.2x
``np.linalg.norm``, ``dot`` 1.4-1.6x ``(a * b).sum``, ``cross`` 10-15x ``np.cross``
(9.7-15x over three runs). ``bounds`` is one compiled pass over ``(N, 3)`` rows:
numpy's ``min(axis=0)`` and ``max(axis=0)`` over rows of 3 took 28 ms for 500,000
rows, the kernel 0.45 ms.
"""

import numpy as np

from cadpipe.core.kernels import native

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
    in their own dtype (float64 or float32; other dtypes as float64)."""
    points = np.ascontiguousarray(points)
    if points.dtype not in (np.float64, np.float32):
        points = points.astype(np.float64)
    if len(points) == 0:
        return np.zeros((2, 3), points.dtype)
    return native.bounds(points)
