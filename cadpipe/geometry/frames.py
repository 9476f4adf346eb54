"""Frames along paths: the direction each ring's first vertex points to.

The default is the rotation-minimizing frame of Wang et al. (2008, "double
reflection"), which does not twist. Each step's double reflection is a rotation
that does not depend on the frame it moves, so the frame's angle against a local
reference is a cumulative sum of per-step angles: the whole frame comes from
vectorized numpy, with no loop over path points, and a batch of paths is one
running sum restarted at each path's first point (:class:`~cadpipe.geometry.ragged.Groups`).

The source document's rule, ``unit(OP x L)``, is kept as ``frame="patent"`` for
comparison; it twists and is undefined where a tangent points at the origin.
"""

import numpy as np

from cadpipe._vec import cross, dot, norm, unit
from cadpipe.errors import InputError
from cadpipe.geometry.ragged import blocks

FRAME_MODES = ("rmf", "patent")

#: stands for "no direction given" in a batch's (G, 3) array of directions
NO_DIRECTION = np.full(3, np.nan)


def as_direction(value, name):
    """``value`` as 3 finite floats, or :data:`NO_DIRECTION` for None."""
    if value is None:
        return NO_DIRECTION
    v = np.asarray(value, dtype=np.float64)
    if v.shape != (3,) or not np.isfinite(v).all():
        raise InputError(f"expected 3 finite numbers, got {value!r}", key=name)
    return v


def _reference(tangents):
    """A perpendicular to each tangent, from the coordinate axis least aligned with it.

    ``t x e_k`` for the axis ``e_k`` with the smallest ``|t_k|`` (the first on ties),
    built from the components it picks rather than from a one-hot axis.
    """
    x, y, z = tangents
    a = np.abs(tangents)
    on_x = (a[0] <= a[1]) & (a[0] <= a[2])
    on_y = ~on_x & (a[1] <= a[2])
    on_z = ~(on_x | on_y)
    u = np.empty_like(tangents)
    np.subtract(on_z * y, on_y * z, out=u[0])          # t x e_x = (0, z, -y), and so on
    np.subtract(on_x * z, on_z * x, out=u[1])
    np.subtract(on_y * x, on_x * y, out=u[2])
    size = norm(u, 0)
    u /= np.where(size > 0, size, 1.0)                 # zero only for a zero tangent
    return u, cross(tangents, u, 0)


def _reflect(v, normal, normal_sq):
    """Reflect each vector ``v`` in the plane through the origin with normal ``normal``."""
    factor = np.divide(2.0 * dot(normal, v, 0), normal_sq,
                       out=np.zeros(v.shape[1]), where=normal_sq > 1e-300)
    return v - factor * normal


def _turns(v1, t, t_next, u, u_next, w_next):
    """Angle the double reflection along segment ``v1`` turns ``u`` by, against ``u_next``."""
    c1 = dot(v1, v1, 0)
    v2 = t_next - _reflect(t, v1, c1)
    moved = _reflect(_reflect(u, v1, c1), v2, dot(v2, v2, 0))
    return np.arctan2(dot(moved, w_next, 0), dot(moved, u_next, 0))


def _step_angles(lines, tuw):
    """(N,) angle of each step, from each point to the next on its path (a closed
    path's last point to its first; an open path's last value is unused).

    ``tuw`` holds each point's tangent, reference u and reference w (rows 0-2, 3-5, 6-8).
    """
    groups = lines.groups
    delta = np.empty(groups.size)
    for rows in blocks(groups.size):
        here, after = tuw[:, rows], groups.following(tuw, rows.start, rows.stop)
        delta[rows] = _turns(lines.segments[:, rows], here[:3], after[:3], here[3:6],
                             after[3:6], after[6:])
    return delta


def _angles_in_plane(vectors, tangents, u, w, name):
    """Angle of each of the (G, 3) ``vectors`` (projected across its tangent) against
    ``u``; the other arguments are component-first (3, G)."""
    v = vectors.T
    across = v - tangents * dot(v, tangents, 0)
    parallel = norm(across, 0) <= 1e-9 * np.maximum(norm(v, 0), 1e-300)
    if parallel.any():
        raise InputError("is parallel to the path's tangent there; "
                         "give a direction across the path", key=name)
    return np.arctan2(dot(across, w, 0), dot(across, u, 0))


def frames(lines, tangents, *, patent=False, normals=None, end_normals=None, symmetry=None):
    """Unit normals (ring vertex 0 directions) along a batch of paths, and seam shifts.

    Parameters
    ----------
    lines : Polylines
        The paths (points, segments, arc lengths) and their groups.
    tangents : (3, N) array
        Unit tangents, component-first.
    patent : bool or (G,) array of bool
        Paths that use the source's ``OP x L`` rule instead of rotation-minimizing
        frames; it cannot match a seam or an end normal.
    normals, end_normals : (G, 3) arrays, optional
        Per path, the direction the first ring's vertex 0 takes (projected into the
        normal plane), and the direction the last ring's vertex 0 must take up to
        ``symmetry``; :data:`NO_DIRECTION` rows for none. The twist an end normal (or
        a closed path's holonomy) needs is spread evenly by arc length; only the part
        of it beyond a multiple of ``symmetry`` is spread.
    symmetry : float or (G,) array, optional
        Angle by which each path's ring is symmetric (``2*pi/sides``); a full turn
        by default.

    Returns
    -------
    normals : (3, N) array
    seam_shift : (G,) int array
        Whole ``symmetry`` steps left at each path's far end: the last ring's vertex k
        meets vertex ``k + seam_shift`` of the ring it must match (the first ring of a
        loop, or the ring whose vertex 0 points along its end normal).
    """
    g = lines.groups
    count = len(g)
    patent = np.broadcast_to(np.asarray(patent, dtype=bool), (count,))
    normals = np.tile(NO_DIRECTION, (count, 1)) if normals is None else normals
    end_normals = np.tile(NO_DIRECTION, (count, 1)) if end_normals is None else end_normals
    symmetry = np.broadcast_to(2 * np.pi if symmetry is None else symmetry, (count,))
    ends = ~np.isnan(end_normals[:, 0])
    if (patent & (g.closed | ends)).any():
        raise InputError("frame='patent' cannot match a seam or an end_normal; "
                         "use frame='rmf'")
    first, last = g.first, g.last
    tuw = np.empty((9, g.size))                  # tangent, reference u, reference w
    tuw[:3] = tangents
    for rows in blocks(g.size):
        tuw[3:6, rows], tuw[6:, rows] = _reference(tangents[:, rows])
    u, w = tuw[3:6], tuw[6:]
    starts = ~np.isnan(normals[:, 0]) & ~patent
    phi0 = np.zeros(count)
    if starts.any():
        rows = first[starts]
        phi0[starts] = _angles_in_plane(normals[starts], tangents[:, rows], u[:, rows],
                                        w[:, rows], "normal")
    delta = _step_angles(lines, tuw)
    phi = g.spread(phi0) + g.exclusive_cumsum(delta)
    shift = np.zeros(count, np.int64)
    adjust = g.closed | ends
    if adjust.any():
        mismatch = np.zeros(count)
        mismatch[g.closed] = -g.sums(delta)[g.closed]
        if ends.any():
            rows = last[ends]
            target = _angles_in_plane(end_normals[ends], tangents[:, rows], u[:, rows],
                                      w[:, rows], "end_normal")
            mismatch[ends] = target - phi[last[ends]]
        steps = np.round(mismatch / symmetry)
        excess = np.where(adjust, mismatch - steps * symmetry, 0.0)
        total = np.where(adjust, lines.lengths, 1.0)
        phi = phi + g.spread(excess) * lines.arc_length / g.spread(total)
        shift = -steps.astype(np.int64)
    out = np.empty((3, g.size))
    for rows in blocks(g.size):
        np.add(np.cos(phi[rows]) * u[:, rows], np.sin(phi[rows]) * w[:, rows], out=out[:, rows])
    if patent.any():
        rows = patent[g.index]
        out[:, rows] = _patent_normals(lines.xyz[:, rows], tangents[:, rows], out[:, rows])
    return out, shift


def _patent_normals(points, tangents, fallback):
    """The source's rule: the first ring vertex points along ``unit(OP x L)``.

    Where ``OP x L`` vanishes (the tangent points at or away from the origin, or P
    is the origin) the rotation-minimizing normal ``fallback`` is used instead.
    """
    normals = cross(points, tangents, 0)
    bad = norm(normals, 0) <= 1e-9 * np.maximum(norm(points, 0), 1.0)
    return np.where(bad, fallback, unit(normals, 0))
