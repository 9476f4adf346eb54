"""4x4 placement matrices from the shorthand people write: translate, rotate, scale."""

import numpy as np

from cadpipe.errors import InputError


def as_matrix(value, name="transform"):
    """``value`` as a finite 4x4 float64 matrix whose last row is ``0 0 0 1``."""
    try:
        matrix = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"expected a 4x4 matrix of numbers, got {value!r}", key=name) from None
    if matrix.shape != (4, 4) or not np.isfinite(matrix).all():
        raise InputError(f"expected a finite 4x4 matrix, got shape {matrix.shape}", key=name)
    if not np.allclose(matrix[3], [0, 0, 0, 1]):
        raise InputError("the last row must be 0 0 0 1 (an affine placement), "
                         f"got {matrix[3].tolist()}", key=name)
    if abs(np.linalg.det(matrix[:3, :3])) < 1e-12:
        raise InputError("the matrix flattens space (determinant 0)", key=name)
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
