"""The one family of segment distances, vectorized: numpy forms of ``csrc/distance.h``.

Callers hold their coordinates in one of two layouts: rows ``(..., 3)`` (``axis=-1``)
or component-first ``(3, P)`` (``axis=0``, the batch geometry's layout,
:mod:`cadpipe.core.vec`); every function takes either, and all compute the closest
points the same way: Ericson's clamping ("Real-Time Collision Detection", 5.1.9),
``s`` always recomputed from the clamped ``t``. That pair is never farther apart than
his, so it is a closest pair too, and zero-length segments (inverse 0) need no branch
of their own. The compiled walks use the same formulas in scalars.
"""

import numpy as np

from cadpipe.core.vec import dot, norm


def inverse(x):
    """``1 / x``, and 0 where ``x`` is too small to invert (a zero-length segment's
    squared length)."""
    usable = x > np.finfo(np.float64).tiny
    return np.where(usable, 1.0 / np.where(usable, x, 1.0), 0.0)


def segment_params(uu, vv, uv, ur, vr, inv_uu, inv_vv):
    """Parameters ``(s, t)`` of the closest points of segments ``p + s u`` and ``q + t v``
    from the dot products of ``u``, ``v`` and ``r = p - q`` and the :func:`inverse`
    squared lengths (any shapes that broadcast).

    Returns
    -------
    s, t : arrays
        In [0, 1]: the closest points are ``p + s u`` and ``q + t v``.
    """
    square = uu * vv
    den = square - uv * uv
    s = np.clip((uv * vr - ur * vv) / np.maximum(den, 1e-300), 0.0, 1.0)
    s = np.where(den > 1e-14 * square, s, 0.0)
    t = np.clip((uv * s + vr) * inv_vv, 0.0, 1.0)
    return np.clip((uv * t - ur) * inv_uu, 0.0, 1.0), t


def closest_params(p, u, q, v, axis=-1):
    """``(s, t)`` of the closest points of segments ``p + s u`` and ``q + t v``.

    Parameters
    ----------
    p, u, q, v : (..., 3) or (3, ...) float
        Segment starts and vectors, their components along ``axis`` (-1 or 0).

    Returns
    -------
    s, t : (...) float
    """
    r = p - q
    uu, vv = dot(u, u, axis), dot(v, v, axis)
    return segment_params(uu, vv, dot(u, v, axis), dot(u, r, axis), dot(v, r, axis),
                          inverse(uu), inverse(vv))


def segment_distance(p, u, q, v, axis=-1):
    """Closest distance between segments ``p + s u`` and ``q + t v`` (s, t in [0, 1]; a
    segment may be a point).

    Parameters
    ----------
    p, u, q, v : (..., 3) or (3, ...) float
        Segment starts and vectors, their components along ``axis`` (-1 or 0).

    Returns
    -------
    distance : (...) float
    """
    s, t = closest_params(p, u, q, v, axis)
    s, t = np.expand_dims(s, axis), np.expand_dims(t, axis)
    return norm(p + s * u - q - t * v, axis)


def point_segment_distance(x, p, u, axis=-1):
    """Distance from points ``x`` to segments ``p + s u`` (s in [0, 1]), all in one
    layout (components along ``axis``)."""
    w = x - p
    uu = dot(u, u, axis)
    s = np.clip(dot(w, u, axis) * inverse(uu), 0.0, 1.0)
    return norm(w - np.expand_dims(s, axis) * u, axis)
