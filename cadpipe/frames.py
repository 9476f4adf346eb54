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

from ._vec import dot, norm, unit
from .errors import InputError

FRAME_MODES = ("rmf", "patent")


def _reference(tangents):
    """A perpendicular to each tangent, from the coordinate axis least aligned with it."""
    axis = np.zeros_like(tangents)
    axis[np.arange(len(tangents)), np.argmin(np.abs(tangents), axis=1)] = 1.0
    u = unit(np.cross(tangents, axis))
    return u, np.cross(tangents, u)


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


def rotation_minimizing_frames(points, tangents, *, closed=False, normal=None, symmetry=None):
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
    symmetry : float, optional
        Angle by which a ring is symmetric. Defaults to a full turn.

    Returns
    -------
    normals : (N, 3) array
    seam_shift : int
        For a closed curve: whole ``symmetry`` steps the frame turned around the loop
        (the last ring's vertex k meets the first ring's vertex ``k + seam_shift``).
    """
    u, w = _reference(tangents)
    phi0 = 0.0
    if normal is not None:
        n0 = np.asarray(normal, dtype=np.float64)
        if n0.shape != (3,) or not np.isfinite(n0).all():
            raise InputError(f"normal: expected 3 finite numbers, got {normal!r}")
        n0 = n0 - tangents[0] * (n0 @ tangents[0])
        if np.linalg.norm(n0) < 1e-9 * max(np.linalg.norm(normal), 1e-300):
            raise InputError("normal: is parallel to the path's first tangent; "
                             "give a direction across the path")
        phi0 = float(np.arctan2(n0 @ w[0], n0 @ u[0]))
    delta = _step_angles(points, tangents, u, w, closed)
    phi = phi0 + np.concatenate([[0.0], np.cumsum(delta[: len(points) - 1])])
    seam_shift = 0
    if closed:
        symmetry = 2 * np.pi if symmetry is None else float(symmetry)
        mismatch = float(delta.sum())
        seam_shift = int(np.round(mismatch / symmetry))
        excess = mismatch - seam_shift * symmetry
        arc = np.concatenate([[0.0], np.cumsum(norm(np.diff(points, axis=0)))])
        total = arc[-1] + np.linalg.norm(points[0] - points[-1])
        phi = phi - excess * arc / total
    normals = np.cos(phi)[:, None] * u + np.sin(phi)[:, None] * w
    return normals, seam_shift


def patent_frames(points, tangents):
    """The source's rule: the first ring vertex points along ``unit(OP x L)``.

    Where ``OP x L`` vanishes (the tangent points at or away from the origin, or P
    is the origin) the rotation-minimizing normal is used instead.
    """
    normals = np.cross(points, tangents)
    size = norm(normals)
    scale = np.maximum(norm(points), 1.0)
    bad = size <= 1e-9 * scale
    normals = unit(normals)
    if bad.any():
        fallback, _ = rotation_minimizing_frames(points, tangents)
        normals[bad] = fallback[bad]
    return normals


def frames(points, tangents, mode="rmf", *, closed=False, normal=None, symmetry=None):
    """Normals for ``mode`` (``"rmf"`` or ``"patent"``), and the closed-loop seam shift."""
    if mode == "rmf":
        return rotation_minimizing_frames(points, tangents, closed=closed, normal=normal,
                                          symmetry=symmetry)
    if mode == "patent":
        if closed:
            raise InputError("frame='patent' cannot close a loop seam; use frame='rmf'")
        return patent_frames(points, tangents), 0
    raise InputError(f"frame: expected one of {FRAME_MODES}, got {mode!r}")
