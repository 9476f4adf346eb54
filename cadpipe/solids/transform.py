"""4x4 placement matrices from the shorthand people write: translate, rotate, scale."""

import numpy as np

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
    if not np.isfinite(matrix).all():
        raise fail("expected a finite 4x4 matrix, got NaN or infinite entries")
    if not np.allclose(matrix[..., 3, :], [0, 0, 0, 1]):
        raise fail("the last row must be 0 0 0 1 (an affine placement), got "
                   f"{matrix[..., 3, :].tolist()}")
    if rigid and not is_rigid(matrix):
        raise fail("must be rigid (a rotation and a translation); scale or mirror the mesh "
                   "itself instead")
    if (np.abs(np.linalg.det(matrix[..., :3, :3])) < 1e-12).any():
        raise fail("the matrix flattens space (determinant 0)")
    return matrix


def is_rigid(matrix):
    """Whether a 4x4 ``matrix`` (or every one of a stack) only rotates and translates
    (no scale, shear or mirror)."""
    m = np.asarray(matrix)
    rot = m[..., :3, :3]
    return bool(np.abs(m[..., 3, :] - (0.0, 0.0, 0.0, 1.0)).max(initial=0.0) <= 1e-9
                and np.abs(np.swapaxes(rot, -1, -2) @ rot - np.eye(3)).max(initial=0.0) <= 1e-6
                and np.all(np.linalg.det(rot) > 0))


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
