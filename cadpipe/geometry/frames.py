"""Frames along paths: the direction each ring's first vertex points to.

The default is the rotation-minimizing frame of the polyline itself: discrete
parallel transport (Bishop frame), which rotates only at corners, by the minimal
rotation taking the incoming direction to the outgoing one, and never along a
straight segment. A mitered ring sits in the bisector plane, so it takes half of
each corner's rotation, and the step from ring i to ring i+1 is the minimal
rotation from tangent ``t_i`` to the segment direction ``d`` followed by the one
from ``d`` to ``t_{i+1}``. (The double reflection of Wang et al. 2008 maps
``t_i`` to ``t_{i+1}`` directly and so twists a straight segment between two
non-coplanar corners; on finely sampled smooth curves both converge to the
curve's rotation-minimizing frame.) Each step is a rotation that does not depend
on the frame it moves, so the frame's angle against a local reference is a
cumulative sum of per-step angles: the whole frame comes from vectorized numpy,
with no loop over path points, and a batch of paths is one running sum restarted
at each path's first point (:class:`~cadpipe.geometry.ragged.Groups`).

The source document's rule, ``unit(OP x L)``, is kept as ``frame="patent"`` for
comparison. Its sign is chosen to keep the frame continuous (the raw rule flips
180 degrees where the tangent swings through OP), and it is refused where it is
undefined (OP parallel to the tangent) or turns a ring by more than
:data:`MAX_TWIST_STEP` in one step.
"""

import numpy as np

from cadpipe.core.vec import cross, dot, norm
from cadpipe.errors import InputError
from cadpipe.geometry.ragged import blocks

FRAME_MODES = ("rmf", "patent")

#: stands for "no direction given" in a batch's (G, 3) array of directions
NO_DIRECTION = np.full(3, np.nan)

#: most twist between neighbouring rings (radians): a band twisted by delta sags to
#: cos(delta / 2) of its radius between the rings, so 16.2 degrees pinches it by 1%
MAX_TWIST_STEP = 2 * np.arccos(0.99)


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


def _minimal_rotation(a, b, x):
    """Rotate each ``x`` by the smallest rotation taking unit ``a`` to unit ``b``
    (``a . b > 0`` here: a tangent and a segment beside it are less than 90 degrees
    apart): ``x + 2 (a.x) b - ((a + b).x) / (1 + a.b) (a + b)``."""
    s = a + b
    return x + 2.0 * dot(a, x, 0) * b - (dot(s, x, 0) / (1.0 + dot(a, b, 0))) * s


def _turns(v1, t, t_next, u, u_next, w_next):
    """Angle the parallel transport along segment ``v1`` turns ``u`` by, against ``u_next``:
    half of the corner at the segment's start (``t`` to the segment), then half of the
    one at its end (the segment to ``t_next``); nothing along the segment itself."""
    d = v1 / norm(v1, 0)
    moved = _minimal_rotation(d, t_next, _minimal_rotation(t, d, u))
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


def frames(lines, tangents, *, patent=False, normals=None, end_normals=None, symmetry=None,
           gentle=False):
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
    gentle : bool
        Refuse (:class:`InputError`, key ``end_normal``) an end normal whose twist
        would turn neighbouring rings by more than :data:`MAX_TWIST_STEP`.

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
        if gentle:
            _require_gentle_twist(lines, np.where(ends, excess / total, 0.0))
        phi = phi + g.spread(excess) * lines.arc_length / g.spread(total)
        shift = -steps.astype(np.int64)
    out = np.empty((3, g.size))
    for rows in blocks(g.size):
        np.add(np.cos(phi[rows]) * u[:, rows], np.sin(phi[rows]) * w[:, rows], out=out[:, rows])
    if patent.any():
        rows = patent[g.index]
        out[:, rows] = _patent_normals(lines, tangents, out, rows)
    return out, shift


def _refuse_first(bad, groups, key, message):
    """Raise :class:`InputError` at the first ``bad`` row: ``message(row, local)`` says
    what is wrong there, ``local`` the row's index within its path."""
    if bad.any():
        i = int(np.argmax(bad))
        local = i - int(groups.first[groups.index[i]])
        raise InputError(message(i, local), key=key, index=local)


def _require_gentle_twist(lines, rate):
    """Raise :class:`InputError` where spreading an end normal's twist (``rate``, (G,)
    radians per metre) turns neighbouring rings by more than :data:`MAX_TWIST_STEP`."""
    g = lines.groups
    is_step = np.ones(g.size, bool)
    is_step[g.last] = g.closed
    twist = np.abs(g.spread(rate)) * lines.segment_lengths
    _refuse_first(is_step & (twist > MAX_TWIST_STEP), g, "end_normal", lambda i, local: (
        f"meeting it twists the rings by {np.degrees(twist[i]):.1f} degrees between path "
        f"points {local} and {local + 1}, which would pinch the tube (at most "
        f"{np.degrees(MAX_TWIST_STEP):.1f}); add points to the path there (Path.resample) "
        "or leave end_normal out"))


def _patent_normals(lines, tangents, transported, rows):
    """The source's rule at ``rows`` (whole open paths): the first ring vertex points
    along ``unit(OP x L)``, its sign chosen so the frame is continuous.

    The rule's normal is measured against the ``transported`` (rotation-minimizing)
    one in each ring's plane; a step of more than 90 degrees against it is the rule's
    sign flip and is taken back. Raises :class:`InputError` where the rule is
    undefined (OP parallel to the tangent) or turns a ring by more than
    :data:`MAX_TWIST_STEP` against the transported frame in one step.
    """
    g = lines.groups
    points, t, n = lines.xyz, tangents, transported
    raw = cross(points, t, 0)
    size = norm(raw, 0)
    undefined = rows & (size <= 1e-9 * np.maximum(norm(points, 0), 1.0))
    _refuse_first(undefined, g, "frame", lambda i, local: (
        f"frame='patent' is undefined at path point {local} ({points[:, i].tolist()}): the "
        "path there points at or away from the origin, so OP x L vanishes; use "
        "frame='rmf' or move the path off the origin's line"))
    raw = np.divide(raw, size, out=np.zeros_like(raw), where=size > 0)
    psi = np.arctan2(dot(raw, cross(t, n, 0), 0), dot(raw, n, 0))
    step = g.following(psi) - psi
    step -= np.pi * np.round(step / np.pi)                # a half turn is the rule's sign flip
    is_step = rows.copy()
    is_step[g.last] = False
    _refuse_first(is_step & (np.abs(step) > MAX_TWIST_STEP), g, "frame", lambda i, local: (
        f"frame='patent' turns the rings by {np.degrees(abs(step[i])):.1f} degrees between "
        f"path points {local} and {local + 1} (the path passes close to the origin's line), "
        "which would pinch the tube; use frame='rmf' or sample the path more finely there"))
    angle = g.spread(psi[g.first]) + g.exclusive_cumsum(np.where(is_step, step, 0.0))
    b = cross(t, n, 0)
    return (np.cos(angle) * n + np.sin(angle) * b)[:, rows]
