"""Frames along a path: the direction each ring's first vertex points to.

The default is the rotation-minimizing frame of Wang et al. (2008, "double
reflection"), which does not twist. Each step's double reflection is a rotation
that does not depend on the frame it moves, so the frame's angle against a local
reference is a cumulative sum of per-step angles: the whole frame comes from
vectorized numpy, with no loop over path points.

The source document's rule, ``unit(OP x L)``, is kept as ``frame="patent"`` for
comparison; it twists and is undefined where a tangent points at the origin.
"""

import numpy as np

from ._vec import cross, dot, norm, unit
from .errors import InputError

FRAME_MODES = ("rmf", "patent")


def _reference(tangents):
    """A perpendicular to each tangent, from the coordinate axis least aligned with it."""
    axis = np.zeros_like(tangents)
    axis[np.arange(len(tangents)), np.argmin(np.abs(tangents), axis=1)] = 1.0
    u = unit(cross(tangents, axis))
    return u, cross(tangents, u)


def _reflect(v, normal, normal_sq):
    """Reflect each row of ``v`` in the plane through the origin with normal ``normal``."""
    factor = np.divide(2.0 * dot(normal, v), normal_sq,
                       out=np.zeros(len(v)), where=normal_sq > 1e-300)
    return v - factor[:, None] * normal


def _step_angles(points, tangents, u, w, closed):
    """Angle each double-reflection step turns the reference ``u`` by, against the next ``u``."""
    def following(a):
        return np.roll(a, -1, axis=0) if closed else a[1:]

    def current(a):
        return a if closed else a[:-1]

    v1 = following(points) - current(points)
    c1 = dot(v1, v1)
    v2 = following(tangents) - _reflect(current(tangents), v1, c1)
    moved = _reflect(_reflect(current(u), v1, c1), v2, dot(v2, v2))
    return np.arctan2(dot(moved, following(w)), dot(moved, following(u)))


def _angle_in_plane(vector, tangent, u, w, name):
    """Angle of ``vector`` (projected across ``tangent``) against the reference ``u``."""
    v = np.asarray(vector, dtype=np.float64)
    if v.shape != (3,) or not np.isfinite(v).all():
        raise InputError(f"{name}: expected 3 finite numbers, got {vector!r}")
    across = v - tangent * (v @ tangent)
    if np.linalg.norm(across) <= 1e-9 * max(np.linalg.norm(v), 1e-300):
        raise InputError(f"{name}: is parallel to the path's tangent there; "
                         "give a direction across the path")
    return float(np.arctan2(across @ w, across @ u))


def rotation_minimizing_frames(points, tangents, *, closed=False, normal=None, end_normal=None,
                               symmetry=None):
    """Twist-free unit normals along a discretized curve.

    Parameters
    ----------
    points, tangents : (N, 3) arrays
        Curve points and unit tangents.
    closed : bool
        For a loop, the mismatch at the seam (the holonomy) is spread evenly by arc
        length so the frame closes; only the part of it beyond a multiple of
        ``symmetry`` (e.g. ``2*pi/sides`` for a regular n-gon ring) is spread.
    normal : (3,) array_like, optional
        Initial normal (projected into the first normal plane).
    end_normal : (3,) array_like, optional
        For an open curve, the normal the last frame must match up to ``symmetry``;
        the twist that needs is spread evenly by arc length, as for a loop's seam.
    symmetry : float, optional
        Angle by which a ring is symmetric. Defaults to a full turn.

    Returns
    -------
    normals : (N, 3) array
    seam_shift : int
        Whole ``symmetry`` steps left at the far end: the last ring's vertex k meets
        vertex ``k + seam_shift`` of the ring it must match (the first ring of a
        loop, or the ring whose vertex 0 points along ``end_normal``).
    """
    u, w = _reference(tangents)
    phi0 = 0.0 if normal is None else _angle_in_plane(normal, tangents[0], u[0], w[0], "normal")
    delta = _step_angles(points, tangents, u, w, closed)
    phi = phi0 + np.concatenate([[0.0], np.cumsum(delta[: len(points) - 1])])
    if not closed and end_normal is None:
        return np.cos(phi)[:, None] * u + np.sin(phi)[:, None] * w, 0
    arc = np.concatenate([[0.0], np.cumsum(norm(np.diff(points, axis=0)))])
    if closed:
        mismatch = -float(delta.sum())
        total = arc[-1] + np.linalg.norm(points[0] - points[-1])
    else:
        target = _angle_in_plane(end_normal, tangents[-1], u[-1], w[-1], "end_normal")
        mismatch = target - phi[-1]
        total = arc[-1]
    symmetry = 2 * np.pi if symmetry is None else float(symmetry)
    steps = int(np.round(mismatch / symmetry))
    phi = phi + (mismatch - steps * symmetry) * arc / total
    return np.cos(phi)[:, None] * u + np.sin(phi)[:, None] * w, -steps


def patent_frames(points, tangents):
    """The source's rule: the first ring vertex points along ``unit(OP x L)``.

    Where ``OP x L`` vanishes (the tangent points at or away from the origin, or P
    is the origin) the rotation-minimizing normal is used instead.
    """
    normals = cross(points, tangents)
    size = norm(normals)
    scale = np.maximum(norm(points), 1.0)
    bad = size <= 1e-9 * scale
    normals = unit(normals)
    if bad.any():
        fallback, _ = rotation_minimizing_frames(points, tangents)
        normals[bad] = fallback[bad]
    return normals


def frames(points, tangents, mode="rmf", *, closed=False, normal=None, end_normal=None,
           symmetry=None):
    """Normals for ``mode`` (``"rmf"`` or ``"patent"``), and the seam shift."""
    if mode == "rmf":
        return rotation_minimizing_frames(points, tangents, closed=closed, normal=normal,
                                          end_normal=end_normal, symmetry=symmetry)
    if mode == "patent":
        if closed or end_normal is not None:
            raise InputError("frame='patent' cannot match a seam or an end_normal; "
                             "use frame='rmf'")
        return patent_frames(points, tangents), 0
    raise InputError(f"frame: expected one of {FRAME_MODES}, got {mode!r}")
