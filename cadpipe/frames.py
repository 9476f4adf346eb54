"""Frames along paths: the direction each ring's first vertex points to.

The default is the rotation-minimizing frame of Wang et al. (2008, "double
reflection"), which does not twist. Each step's double reflection is a rotation
that does not depend on the frame it moves, so the frame's angle against a local
reference is a cumulative sum of per-step angles: the whole frame comes from
vectorized numpy, with no loop over path points, and a batch of paths is one
running sum restarted at each path's first point (:class:`~cadpipe.ragged.Groups`).

The source document's rule, ``unit(OP x L)``, is kept as ``frame="patent"`` for
comparison; it twists and is undefined where a tangent points at the origin.
"""

import numpy as np

from ._vec import cross, dot, norm, unit
from .errors import InputError

FRAME_MODES = ("rmf", "patent")

#: stands for "no direction given" in a batch's (G, 3) array of directions
NO_DIRECTION = np.full(3, np.nan)


def as_direction(value, name):
    """``value`` as 3 finite floats, or :data:`NO_DIRECTION` for None."""
    if value is None:
        return NO_DIRECTION
    v = np.asarray(value, dtype=np.float64)
    if v.shape != (3,) or not np.isfinite(v).all():
        raise InputError(f"{name}: expected 3 finite numbers, got {value!r}")
    return v


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


def _turns(v1, t, t_next, u, u_next, w_next):
    """Angle the double reflection along segment ``v1`` turns ``u`` by, against ``u_next``."""
    c1 = dot(v1, v1)
    v2 = t_next - _reflect(t, v1, c1)
    moved = _reflect(_reflect(u, v1, c1), v2, dot(v2, v2))
    return np.arctan2(dot(moved, w_next), dot(moved, u_next))


def _step_angles(lines, t, u, w):
    """(N,) angle of each step, from each point to the next on its path.

    Rows are paired with the following row in one pass; each path's last row (its
    closing step, or nothing for an open path) is then redone with the right partner.
    """
    v1 = lines.segments
    delta = np.empty(len(t))
    delta[:-1] = _turns(v1[:-1], t[:-1], t[1:], u[:-1], u[1:], w[1:])
    last = lines.groups.last
    nxt = lines.groups.wrap(last)
    delta[last] = _turns(v1[last], t[last], t[nxt], u[last], u[nxt], w[nxt])
    return delta


def _angles_in_plane(vectors, tangents, u, w, name):
    """Angle of each vector (projected across its tangent) against ``u``; NaN where
    no vector is given."""
    across = vectors - tangents * dot(vectors, tangents)[:, None]
    parallel = norm(across) <= 1e-9 * np.maximum(norm(vectors), 1e-300)
    if parallel.any():
        raise InputError(f"{name}: is parallel to the path's tangent there; "
                         "give a direction across the path")
    return np.arctan2(dot(across, w), dot(across, u))


def frames(lines, tangents, *, patent=False, normals=None, end_normals=None, symmetry=None):
    """Unit normals (ring vertex 0 directions) along a batch of paths, and seam shifts.

    Parameters
    ----------
    lines : Polylines
        The paths (points, segments, arc lengths) and their groups.
    tangents : (N, 3) array
        Unit tangents.
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
    normals : (N, 3) array
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
    u, w = _reference(tangents)
    starts = ~np.isnan(normals[:, 0]) & ~patent
    phi0 = np.zeros(count)
    if starts.any():
        phi0[starts] = _angles_in_plane(normals[starts], tangents[first[starts]],
                                        u[first[starts]], w[first[starts]], "normal")
    delta = _step_angles(lines, tangents, u, w)
    phi = g.spread(phi0) + g.exclusive_cumsum(delta)
    shift = np.zeros(count, np.int64)
    adjust = g.closed | ends
    if adjust.any():
        mismatch = np.zeros(count)
        mismatch[g.closed] = -g.sums(delta)[g.closed]
        if ends.any():
            target = _angles_in_plane(end_normals[ends], tangents[last[ends]], u[last[ends]],
                                      w[last[ends]], "end_normal")
            mismatch[ends] = target - phi[last[ends]]
        steps = np.round(mismatch / symmetry)
        excess = np.where(adjust, mismatch - steps * symmetry, 0.0)
        total = np.where(adjust, lines.lengths, 1.0)
        phi = phi + g.spread(excess) * lines.arc_length / g.spread(total)
        shift = -steps.astype(np.int64)
    out = np.cos(phi)[:, None] * u + np.sin(phi)[:, None] * w
    if patent.any():
        rows = patent[g.index]
        out[rows] = _patent_normals(lines.points[rows], tangents[rows], out[rows])
    return out, shift


def _patent_normals(points, tangents, fallback):
    """The source's rule: the first ring vertex points along ``unit(OP x L)``.

    Where ``OP x L`` vanishes (the tangent points at or away from the origin, or P
    is the origin) the rotation-minimizing normal ``fallback`` is used instead.
    """
    normals = cross(points, tangents)
    bad = norm(normals) <= 1e-9 * np.maximum(norm(points), 1.0)
    return np.where(bad[:, None], fallback, unit(normals))
