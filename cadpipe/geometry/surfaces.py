"""The ring-surface layout of pipes: rings, side bands, ball joints and caps laid out as
one :class:`~cadpipe.geometry.loft.Surface`.

A pipe's mesh, a clean piece of its swept solid and every pipe of a splice are laid
out here the same way, so no piece can miss a joint or a cap and a splice meets each
pipe's own rings.
"""

from functools import partial

import numpy as np

from cadpipe.geometry.frames import as_direction
from cadpipe.geometry.loft import write_fan
from cadpipe.geometry.path import polylines
from cadpipe.geometry.rings import Tubes, ring_basis


def tubes_of(pipes, ring_radii=None):
    """The pipes' rings, frames and checks as one :class:`~cadpipe.geometry.rings.Tubes`
    batch (``ring_radii``: per pipe, instead of their own)."""
    return Tubes(polylines([p.path for p in pipes]),
                 np.concatenate([p.ring_radii for p in pipes] if ring_radii is None
                                else ring_radii),
                 [p.sides for p in pipes],
                 [p.miter_limit if p.corners == "miter" else np.inf for p in pipes],
                 patent=[p.frame == "patent" for p in pipes],
                 normals=np.array([as_direction(p.normal, "normal") for p in pipes]),
                 end_normals=np.array([as_direction(p.end_normal, "end_normal") for p in pipes]),
                 gentle=True)


def cap_axes(tubes, row, sign, pipe, style):
    """The cap past the end ring at ``row`` (outward along ``sign`` times the tangent):
    its rings as axes and centres (see :func:`~cadpipe.geometry.rings.ring_basis`) and
    its pole (None: a flat fan closes the last ring); None for a plain flat cap.

    A round cap's rings lie on the sphere of the end ring's radius; with
    ``envelope=True`` its faces are instead tangent to the sphere of the ball it must
    hold (the end ring's inradius ``rho``): in each meridian the cap is the polygon
    circumscribing that circle with sides tangent at ``0, D, 2D, ...`` and a vertex on
    the axis, ``D = pi / (2m - 1)``, so ring ``j`` sits at angle ``(j - 1/2) D`` and
    distance ``rho / cos(D/2)``. An envelope's flat cap lies ``r`` past the end.
    """
    centre, tangent = tubes.lines.xyz[:, row], sign * tubes.lines.tangents[:, row]
    ring = tubes.axes[row]
    if style == "flat":
        if not pipe.envelope:
            return None
        axes = ring[None].copy()
        axes[0, 2] = centre + _end_radius(pipe, sign) * tangent
        return axes, None
    radius = tubes.ring_radii[row]
    if pipe.envelope:
        m = max(2, pipe.cap_steps)
        step = np.pi / (2 * m - 1)
        lat = (np.arange(1, m) - 0.5) * step
        scale = np.cos(lat) / np.cos(step / 2)
        rise = np.sin(lat) / np.cos(step / 2) * radius * np.cos(np.pi / pipe.sides)
        pole = radius * np.cos(np.pi / pipe.sides) / np.cos(step / 2)
    else:
        m = pipe.cap_steps
        lat = (np.pi / 2) * np.arange(1, m) / m
        scale, rise, pole = np.cos(lat), np.sin(lat) * radius, radius
    axes = np.empty((len(lat), 3, 3))
    axes[:, :2] = scale[:, None, None] * ring[:2]
    axes[:, 2] = centre + rise[:, None] * tangent
    return axes, centre + pole * tangent


def cap_reach(pipe, style, sign):
    cap = cap_axes(pipe._tubes, 0 if sign < 0 else len(pipe.path) - 1, sign, pipe, style)
    if cap is None:
        return 0.0
    end = pipe.path.points[0 if sign < 0 else -1]
    tip = cap[0][-1, 2] if cap[1] is None else cap[1]
    return float(np.linalg.norm(tip - end))


def _end_radius(pipe, sign):
    return float(pipe.envelope_radii[0 if sign < 0 else -1])


def add_pipe_surfaces(surface, tubes, pipes, *, cap_start, cap_end, parts=None, windows=None,
                      cut=None):
    """Lay out the pipes (``tubes``' groups, in order) in ``surface``: their rings, side
    faces, ball joints and the requested caps (see :meth:`Pipe.surface`).

    ``windows`` (per pipe ``(first, last)``, or None for all of it) lays out only the
    segments ``first..last`` of a pipe (around a closed one they may wrap, ``last <
    first``): the same rings, joints and caps, closed by a flat fan on the ring where the
    window cuts the tube. The clean pieces of a swept solid are built here, as the
    whole pipe is, so no piece can miss a joint or a cap. ``cut`` (per pipe ``(start,
    end)`` bools) closes those of its own ends by a flat fan too, instead of its cap.

    Returns the vertex index of each pipe's first and last ring laid out (its own, not a
    cap's).
    """
    groups, sides = tubes.groups, tubes.sides
    runs, rolls, rows_of, closed, ends = [], [], [], [], []
    for g, pipe in enumerate(pipes):
        first, last = int(groups.first[g]), int(groups.last[g])
        window = None if windows is None else windows[g]
        if window is None:
            rows = np.arange(first, last + 1)
        else:
            count = last - first + 1
            a, b = window
            rows = first + (a + np.arange((b - a) % (count if pipe.closed else count - 1)
                                          + 2)) % count
        axes, roll = _window_axes(tubes, rows, int(tubes.seam_shift[g]), pipe.sides)
        runs.append(axes)
        rolls.append(roll)
        rows_of.append(rows)
        closed.append(pipe.closed and window is None)
        cuts = (False, False) if cut is None else cut[g]
        ends.append((not pipe.closed and rows[0] == first and not cuts[0],
                     not pipe.closed and rows[-1] == last and not cuts[1]))
    # caps: at most the two ends of a chain, or a lone pipe's; a cut end is a flat fan
    capped = [g for g in range(len(pipes)) if (cap_start[g] or cap_end[g]) and not closed[g]]
    caps, rings_before = {}, np.zeros(len(pipes), np.int64)
    for g in capped:
        pipe, (at_start, at_end) = pipes[g], ends[g]
        styles, rows = pipe.cap_styles, rows_of[g]
        start = cap_axes(tubes, rows[0], -1, pipe, styles[0]) \
            if cap_start[g] and at_start else None
        end = cap_axes(tubes, rows[-1], +1, pipe, styles[1]) if cap_end[g] and at_end else None
        if start is not None or end is not None:
            run = runs[g]
            runs[g] = np.concatenate([run[:0] if start is None else start[0][::-1], run,
                                      run[:0] if end is None else end[0]])
            rings_before[g] = 0 if start is None else len(start[0])
        caps[g] = (start, end)
    jointed = {}
    for g, pipe in enumerate(pipes):
        first, rows = int(groups.first[g]), rows_of[g]
        mask = joint_rows_of(tubes, first, int(groups.last[g]), pipe)[rows - first]
        if not closed[g]:                          # a cut or an end is a plain ring
            mask[[0, -1]] = False
        at = np.flatnonzero(mask)
        if at.size:
            jointed[g] = {int(k + rings_before[g]): (int(rows[k]), int(rolls[g][k]))
                          for k in at.tolist()}
    plain = [g for g in range(len(pipes)) if g not in jointed]
    row_start = [None] * len(pipes)
    if plain:
        starts = surface.add_rings([runs[g] for g in plain], sides[plain],
                                   None if parts is None else np.asarray(parts)[plain],
                                   closed=np.asarray(closed)[plain],
                                   seam_shift=tubes.seam_shift[plain])
        for g, start in zip(plain, starts.tolist()):
            row_start[g] = start + int(sides[g]) * np.arange(len(runs[g]))
    for g, rows in jointed.items():
        row_start[g] = _add_jointed_run(surface, tubes, pipes[g], runs[g], rows, closed[g],
                                        int(tubes.seam_shift[g]),
                                        None if parts is None else int(parts[g]))
    for g in capped:
        n, part = int(sides[g]), None if parts is None else int(parts[g])
        for wanted, cap, ring, at_end in (
                (cap_start[g], caps[g][0], int(row_start[g][0]), False),
                (cap_end[g], caps[g][1], int(row_start[g][-1]), True)):
            if not wanted:
                continue
            apex = None if cap is None or cap[1] is None else surface.add_vertices(
                1, lambda out, pole=cap[1]: np.copyto(out[0], pole))
            surface.add_faces(n if apex is not None else n - 2, partial(
                write_fan, ring, n, apex, at_end), part)
    own = [rs[b:b + len(r)] for rs, b, r in zip(row_start, rings_before.tolist(), rows_of)]
    return np.array([o[0] for o in own]), np.array([o[-1] for o in own])


def _window_axes(tubes, rows, shift, sides):
    """(K, 3, 3) ring axes at tube ``rows`` of one pipe and (K,) the vertex roll of each:
    rings past a closed pipe's seam are turned by its seam ``shift`` (their vertex k is
    the ring's vertex k + shift), so they continue the rings before the seam."""
    axes = tubes.axes[rows]
    roll = np.zeros(len(rows), np.int64)
    past = np.flatnonzero(np.diff(rows) < 0)
    if past.size:
        after = slice(int(past[0]) + 1, None)
        alpha = 2 * np.pi * shift / sides
        axes = axes.copy()
        a0, a1 = axes[after, 0].copy(), axes[after, 1].copy()
        axes[after, 0] = np.cos(alpha) * a0 + np.sin(alpha) * a1
        axes[after, 1] = np.cos(alpha) * a1 - np.sin(alpha) * a0
        roll[after] = shift
    return axes, roll


# -- ball joints (corners="round") -------------------------------------------------
def joint_rows_of(tubes, first, last, pipe):
    """(n,) bool: which of ``pipe``'s rings (tube rows ``first..last``) are laid out as
    a ball joint (:func:`ball_joint`): with ``corners="round"`` and no envelope, the
    corners that :func:`round_corner_rows` names. An envelope's round corners are
    balls that circumscribe the ball of the path's radius, united with the segments
    cut square at the corner (see :meth:`Pipe._swept_plan`): the swept joint's faces
    beside the bend axis fan from one unswept vertex and would cut across that ball."""
    rows = round_corner_rows(tubes, first, last, pipe)
    return rows & (not pipe.envelope)


def round_corner_rows(tubes, first, last, pipe):
    """(n,) bool: with ``corners="round"``, the corners of ``pipe`` (tube rows
    ``first..last``) whose miter tip would stick out farther than the ring polygon's
    own chordal deviation, ``stretch - 1 > 1 - cos(pi / sides)``: they become ball
    joints; gentler corners keep their miter, which already holds the corner's ball."""
    if pipe.corners != "round":
        return np.zeros(last - first + 1, bool)
    return tubes.miter_stretch[first:last + 1] - 1.0 > 1.0 - np.cos(np.pi / pipe.sides)


def _rotate(v, axis, angle):
    """Rodrigues: (..., 3) vectors ``v`` turned by ``angle`` about the unit ``axis``."""
    c, s = np.cos(angle), np.sin(angle)
    return v * c + np.cross(axis, v) * s + np.outer(v @ axis, axis) * (1 - c)


def ball_joint(tubes, row, pipe):
    """A ball joint at corner ``row``: the rings that sweep the corner's ring about the
    bend axis through the corner point, from the plane across the incoming segment to
    the plane across the outgoing one.

    Only the outside of the bend sweeps (the sphere of the ring radius about the
    corner point, as a ball joint has); the inside keeps the miter ring's vertices,
    where the two segments' cylinders meet.

    Returns ``(outer, rings)``: the (sides,) bool mask of swept vertices and the
    (K, sides, 3) ring vertices (inner vertices repeated; they are one vertex).
    """
    lines = tubes.lines
    n = pipe.sides
    centre = lines.xyz[:, row]
    d_in, d_out = lines.incoming[:, row], lines.directions[:, row]
    turn = float(lines.turning_angles[row])
    axis = np.cross(d_in, d_out)
    axis /= np.linalg.norm(axis)
    miter = ring_basis(n) @ tubes.axes[row]
    outer = (miter - centre) @ lines.bend_directions[:, row] < 0
    radius = tubes.ring_radii[row]
    normal = tubes.normals[:, row]
    binormal = np.cross(lines.tangents[:, row], normal)
    a = 2 * np.pi * np.arange(n) / n
    offsets = radius * (np.cos(a)[:, None] * _rotate(normal[None], axis, -turn / 2)
                        + np.sin(a)[:, None] * _rotate(binormal[None], axis, -turn / 2))
    steps = max(1, int(np.ceil(turn / (np.pi / 2) * pipe.cap_steps)))
    angles = turn * np.arange(steps + 1) / steps
    along = np.outer(offsets @ axis, axis)
    rings = np.empty((len(angles), n, 3))
    for k, angle in enumerate(angles.tolist()):
        rings[k] = centre + along + _rotate(offsets - along, axis, angle)
    rings[:, ~outer] = miter[~outer]
    return outer, rings


def _add_jointed_run(surface, tubes, pipe, run, rows, closed, seam_shift, part):
    """Lay out a run of rings (axes, as :meth:`Surface.add_rings` takes them) whose
    ``rows`` (index in ``run`` -> tube row and vertex roll, see :func:`_window_axes`) get
    ball joints: every ring a row of vertex
    indices (a joint's inner vertices shared by its rings), faces between every two
    rows as for plain rings, those made degenerate by a shared vertex dropped.

    Returns the vertex index of each run row's first ring.
    """
    n, basis = pipe.sides, ring_basis(pipe.sides)
    first = surface.vertex_count
    blocks, table, row_start, count = [], [], np.empty(len(run), np.int64), 0
    for r, axes in enumerate(run):
        if r in rows:
            row, roll = rows[r]
            outer, rings = ball_joint(tubes, row, pipe)
            outer, rings = np.roll(outer, -roll), np.roll(rings, -roll, axis=1)
            extra = rings[1:, outer].reshape(-1, 3)
            ids = np.empty((len(rings), n), np.int64)
            ids[:] = first + count + np.arange(n)
            ids[1:, outer] = (first + count + n + np.arange(len(extra))).reshape(
                len(rings) - 1, -1)
            blocks += [rings[0], extra]
        else:
            ids = (first + count + np.arange(n))[None]
            blocks.append(basis @ axes)
        row_start[r] = ids[0, 0]
        count += sum(len(b) for b in blocks[-2 if r in rows else -1:])
        table.append(ids)
    vertices = np.concatenate(blocks)
    table = np.concatenate(table)
    upper, lower = table[:-1], table[1:]
    if closed:
        upper = np.vstack([upper, table[-1:]])
        lower = np.vstack([lower, np.roll(table[:1], -seam_shift, axis=1)])
    a, b = upper, np.roll(upper, -1, axis=1)
    c, d = lower, np.roll(lower, -1, axis=1)
    # a swept quad is not flat: split it along the diagonal that folds outwards, so
    # both triangles lie outside the band between its rings (an envelope's joint must
    # not cut into the ball it holds)
    at = [vertices[v - first] for v in (a, b, c, d)]
    fold = np.einsum("...i,...i->...", np.cross(at[1] - at[0], at[2] - at[0]), at[3] - at[0])
    flip = (fold > 0)[..., None]
    faces = np.stack([np.where(flip, np.stack([a, b, d], -1), np.stack([a, b, c], -1)),
                      np.where(flip, np.stack([a, d, c], -1), np.stack([b, d, c], -1))],
                     axis=2).reshape(-1, 3)
    faces = faces[(faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2])
                  & (faces[:, 0] != faces[:, 2])]
    surface.add_vertices(len(vertices), lambda out: np.copyto(out, vertices))
    surface.add_faces(len(faces), lambda out: np.copyto(out, faces), part)
    return row_start


