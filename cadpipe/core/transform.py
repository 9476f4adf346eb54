"""4x4 placements: the one check of a placement matrix, the shorthand people write
(translate, rotate, scale), and points and poses moved by them.

Points are moved by an explicit product in a compiled pass (``csrc/transform.c``),
never through BLAS: numpy's ``points @ M.T`` on (N, 3) rows runs OpenBLAS threads
that spin on a busy machine (a 1M-triangle STL write spent 0.21 s of 0.35 s there at
a load of 2 on 2 cores, 0.016 s in one thread; docs/performance.md).
"""

import numpy as np

from cadpipe.core.kernels import native
from cadpipe.errors import InputError


def as_matrix(value, key="transform", *, part=None, stack=False, rigid=False):
    """``value`` as finite 4x4 affine placement matrices: the one check of a 4x4 input.

    Parameters
    ----------
    value : (4, 4) array_like, or (..., 4, 4) when ``stack``
    key : str
        The argument or spec key, named in the error.
    part : str, optional
        The part or object it places (the error's ``part``).
    stack : bool
        Accept any number of leading axes (one matrix per configuration, say).
    rigid : bool
        Also require rotation plus translation only (no scale, shear or mirror).

    Returns
    -------
    matrix : (4, 4) or (..., 4, 4) float64
        A new array; each last row is ``0 0 0 1`` and no matrix is singular.

    Raises
    ------
    InputError
        Naming ``name`` and what is wrong.
    """
    def fail(message):
        return InputError(message, key=key, part=part)

    try:
        matrix = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise fail(f"expected a 4x4 matrix of numbers, got {value!r}") from None
    if matrix.shape[-2:] != (4, 4) or (not stack and matrix.ndim != 2):
        raise fail(f"expected a finite 4x4 matrix, got shape {matrix.shape}")
    problem = native.matrix_problem(np.ascontiguousarray(matrix).reshape(-1, 4, 4), rigid)
    if problem == _NOT_FINITE:
        raise fail("expected a finite 4x4 matrix, got NaN or infinite entries")
    if problem == _NOT_AFFINE:
        raise fail("the last row must be 0 0 0 1 (an affine placement), got "
                   f"{matrix[..., 3, :].tolist()}")
    if problem == _NOT_RIGID:
        raise fail("must be rigid (a rotation and a translation); scale or mirror the mesh "
                   "itself instead")
    if problem == _FLAT:
        raise fail("the matrix flattens space (determinant 0)")
    return matrix


def is_rigid(matrix):
    """Whether a 4x4 ``matrix`` (or every one of a stack) only rotates and translates
    (no scale, shear or mirror)."""
    m = np.asarray(matrix, np.float64)
    if m.shape[-2:] != (4, 4) or not np.isfinite(m).all():
        return False
    return native.matrix_problem(np.ascontiguousarray(m).reshape(-1, 4, 4), True) == 0


#: what ``native.matrix_problem`` finds first in a stack of matrices (0: nothing), in the
#: order :func:`as_matrix` reports them: finite entries; a last row of ``0 0 0 1`` (as
#: ``np.allclose``); with ``rigid``, that row within 1e-9, ``R^T R`` within 1e-6 of the
#: identity and ``det R > 0``; ``|det R| >= 1e-12``
_NOT_FINITE, _NOT_AFFINE, _NOT_RIGID, _FLAT = 1, 2, 3, 4


def placed_points(points, matrix):
    """(N, 3) float ``points`` (any strides) moved by the 4x4 ``matrix``, as float64.

    Parameters
    ----------
    points : (N, 3) float array
    matrix : (4, 4) array_like
        An affine placement.

    Returns
    -------
    placed : (N, 3) float64
        A new array, or ``points`` themselves for the identity.
    """
    matrix = np.ascontiguousarray(matrix, dtype=np.float64)
    if np.array_equal(matrix, np.eye(4)):
        return points
    points = np.asarray(points)
    if points.dtype not in (np.float32, np.float64):
        points = points.astype(np.float64)
    out = np.empty((len(points), 3))
    native.place_points(points.reshape(-1, 3), matrix, out)
    return out


def relative(pose_a, pose_b):
    """Poses of b in a's frame, ``inv(pose_a) @ pose_b``, vectorized over leading axes.

    Parameters
    ----------
    pose_a, pose_b : (..., 4, 4) array_like
        Rigid poses (the inverse is the transposed rotation); they broadcast.

    Returns
    -------
    poses : (..., 4, 4) float64
    """
    pose_a, pose_b = np.asarray(pose_a, np.float64), np.asarray(pose_b, np.float64)
    shape = np.broadcast_shapes(pose_a.shape, pose_b.shape)
    pose_a, pose_b = (np.ascontiguousarray(np.broadcast_to(p, shape)) for p in (pose_a, pose_b))
    out = np.empty(shape)
    native.relative_poses(pose_a.reshape(-1, 4, 4), pose_b.reshape(-1, 4, 4),
                          out.reshape(-1, 4, 4))
    return out


def _three(value, name):
    """Three finite numbers; one number stands for three equal ones."""
    try:
        arr = np.broadcast_to(np.asarray(value, dtype=np.float64), (3,))
    except (TypeError, ValueError):
        arr = None
    if isinstance(value, str) or arr is None or not np.isfinite(arr).all():
        raise InputError(f"expected 3 finite numbers, got {value!r}", key=name)
    return arr


def placement(translate=(0, 0, 0), rotate=(0, 0, 0), scale=1.0):
    """The matrix that scales, then rotates, then translates.

    ``rotate`` is three angles in degrees about the fixed x, y and z axes, applied
    in that order; ``scale`` is one factor or three (non-zero; negative mirrors).
    """
    from scipy.spatial.transform import Rotation

    factors = _three(scale, "scale")
    if (factors == 0).any():
        raise InputError(f"factors must be non-zero, got {scale!r}", key="scale")
    matrix = np.eye(4)
    matrix[:3, :3] = Rotation.from_euler("xyz", _three(rotate, "rotate"),
                                         degrees=True).as_matrix() * factors
    matrix[:3, 3] = _three(translate, "translate")
    return matrix
