"""Which points are the same point: the weld of a file's vertices.

Files store a vertex once per triangle (STL) or once per normal or colour (GLB,
PLY); which of their points are the same point is one pass through a hash
table (compiled: ``csrc/points.c``), keyed on the coordinates rounded to a
number of decimals, that keeps the points in the order they were first met.
``np.unique(axis=0)`` would sort 24-byte rows with a generic comparison
(seconds for millions), and a table of keys made first would cost a full-size
pass and array more.
"""

import numpy as np

from cadpipe.core.kernels import native


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
    points = np.ascontiguousarray(points, np.float64).reshape(-1, 3)
    return native.unique_points(points, 10.0 ** decimals)


def renumbered(corners, inverse):
    """``inverse[corners]`` (int64 arrays of any shape), reading ``inverse`` only past its
    identity prefix: the copies a writer split off are mostly at the end (a GLB's crease
    vertices), so most corners keep their number."""
    corners = np.ascontiguousarray(corners, np.int64)
    out = np.empty_like(corners)
    native.renumber(corners.reshape(-1), np.ascontiguousarray(inverse, np.int64),
                    out.reshape(-1))
    return out
