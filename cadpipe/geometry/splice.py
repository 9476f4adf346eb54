"""Step S5: joining pipes of different mouth shapes into one seamless solid.

Between pipe1 (an n1-gon mouth) and pipe2 (n2-gon) a transition pipe follows a
cubic Hermite curve from pipe1's end to pipe2's start, tangent to both, its radius
easing from one to the other. With ``transition="lcm"`` (the source's method) its
rings have ``lcm(n1, n2)`` vertices and meet each pipe through an n-to-1 stitch;
with ``transition="merge"`` its rings keep n1 then n2 vertices and the two sizes
meet once, by angle. The frames run on from pipe1's end and are eased to pipe2's
start, so a transition never twists.

Where no transition fits (the pipes meet at a corner, or one starts before the
previous one ends) the two are joined by a ball joint instead, and where pieces of
the chain (pipes, transitions, joints) cross each other the chain is their union
through manifold3d: the result is always one valid solid (see :func:`splice`).
"""

from dataclasses import dataclass

import numpy as np

from cadpipe import limits
from cadpipe._validate import as_choice, as_flag
from cadpipe.core.kernels import native
from cadpipe.core.vec import norm
from cadpipe.errors import GeometryError, InputError
from cadpipe.geometry.loft import Surface, fan_faces, zipper_faces
from cadpipe.geometry.mesh import Mesh, reserve_ids
from cadpipe.geometry.path import Polylines
from cadpipe.geometry.pipe import Pipe
from cadpipe.geometry.ragged import Groups
from cadpipe.geometry.rings import Tubes
from cadpipe.geometry.surfaces import add_pipe_surfaces, tubes_of
from cadpipe.geometry.swept import hull_solid, float32_solid

TRANSITIONS = ("lcm", "merge")

#: transition rings per smallest radius of length (at least MIN_RINGS)
RINGS_PER_RADIUS = 2.0
MIN_RINGS = 3
#: how far (a fraction of the ring radius, at most a quarter of the neighbouring
#: segments) the cone closing a piece cut at a ring reaches into the next piece
CUT_DEPTH = 0.1
#: subdivisions of the icosphere a ball joint is built from (320 faces)
BALL_SUBDIVISIONS = 2


def splice(*pipes: Pipe, transition: str = "lcm", closed: bool = False) -> Mesh:
    """One valid solid: the pipes in order, joined by transitions.

    Parameters
    ----------
    *pipes : Pipe
        Open pipes; each one's end is joined to the next one's start. Only the chain's
        two ends keep their caps.
    transition : {"lcm", "merge"}
        ``"lcm"``: transition rings of ``lcm(n1, n2)`` vertices, n-to-1 stitches (the
        source's S5; smooth, but lcm grows fast: (16, 17) -> 272). ``"merge"``: rings
        of n1 then n2 vertices merged once by angle (``n1 + n2`` triangles).
    closed : bool
        Also join the last pipe's end to the first pipe's start.

    Returns
    -------
    Mesh
        A closed, outward, self-intersection-free 2-manifold. Faces labelled by part:
        ``pipe<i>``, ``transition<i>`` (from pipe i to the next) and ``joint<i>``.
        ``attributes["merged"]`` (absent for a chain stitched as it is) says which
        pieces were united.

    Where a transition would fold (the pipes meet at a corner, at any radius, or one
    starts before or beside the previous one's end), the two pipes keep their ends as
    given and are joined by a ball joint: the convex hull of a ball of each end's
    ring radius about each end point (one ball where the ends touch), so every point
    of both ends stays covered, as ``corners="round"`` covers a polyline's corner.
    Pieces that cross each other (a pipe running through another, a joint) are
    united through manifold3d, as a single pipe that overlaps itself becomes its
    swept solid: the user asked for one solid along these paths, and their union is
    it. A pipe that overlaps itself is its swept solid in the chain too (cut flat
    where a transition goes on). Pieces are checked against each other through boxes
    of pieces, then of segments, so a clean chain is returned stitched as it is. A
    chain with a pipe made with ``strict=True`` refuses instead, with a
    :class:`GeometryError` naming the pieces (or the pipe that overlaps itself).

    All pipes are built as one batch, and all transitions as another
    (:class:`~cadpipe.geometry.rings.Tubes`): a chain of a thousand pipes costs a few numpy
    calls per stage, not a few per pipe.
    """
    pipes = chain_members(pipes)
    transition = as_choice(transition, "transition", TRANSITIONS)
    closed = as_flag(closed, "closed")
    if len(pipes) == 1 and not closed:
        return pipes[0].mesh().with_parts(["pipe0"])
    plan = make_room(pipes, closed, transition)
    return chain_mesh(plan.pipes, plan.joint, transition, closed, tubes=plan.tubes,
                      bridges=plan.bridges)


def chain_members(pipes):
    """``pipes`` as a list if it is a non-empty sequence of open :class:`Pipe` values;
    else an :class:`InputError` with ``key="pipes"`` and the index."""
    if not pipes:
        raise InputError("expected at least one Pipe, got none", key="pipes")
    for i, p in enumerate(pipes):
        if not isinstance(p, Pipe):
            raise InputError(f"argument {i} is a {type(p).__name__}, not a cadpipe.Pipe",
                             key="pipes", index=i)
        if p.closed:
            raise InputError(f"pipe {i} is a closed loop and has no ends to join",
                             key="pipes", index=i)
    return list(pipes)


def junctions(count, closed):
    """(J,) index of the pipe before and after each junction."""
    before = np.arange(count - 1 + closed)
    return before, (before + 1) % count


@dataclass(frozen=True)
class ChainPlan:
    """How a chain's pipes are joined.

    Attributes
    ----------
    pipes : list of Pipe
        The pipes, those whose ends touch trimmed to leave room for a transition.
    joint : (J,) bool array
        Per junction (pipe i to pipe i + 1, and the last to the first in a closed
        chain): True where a ball joint replaces a transition that would fold.
    tubes, bridges : Tubes
        The pipes' batch (caps aside, what :func:`chain_mesh` builds them from) and
        the transitions' (None without any).
    """

    pipes: list
    joint: np.ndarray
    tubes: Tubes
    bridges: Tubes | None


def make_room(pipes, closed=False, transition="lcm"):
    """The :class:`ChainPlan` of a chain: which junctions get transitions, for which
    touching ends give up a little length, and which get ball joints (ends as given).

    Other chains along the same ends (a hollow chain's bores) follow the same plan.
    """
    before, after = junctions(len(pipes), closed)
    # a safety envelope's ends stay where they are: touching ends get a ball joint
    envelope = np.array([p.envelope for p in pipes])
    joint = _touching(tubes_of(pipes), before, after) & (envelope[before] | envelope[after])
    while True:
        trimmed, tubes = _room_for_transitions(pipes, tubes_of(pipes), before[~joint],
                                               after[~joint])
        bridges, bent = _transition_tubes(tubes, before[~joint], after[~joint], transition,
                                          check=True)
        if not bent.any():
            return ChainPlan(trimmed, joint, tubes, bridges)
        joint[np.flatnonzero(~joint)[bent]] = True


def _pipe_folds(pipes, tubes, cap_start, cap_end):
    """Per pipe, where its tube folds (:class:`~cadpipe.geometry.clearance.Folds`), its
    caps included where it keeps them; a pipe made with ``strict=True`` that folds is
    a :class:`GeometryError` (the others become their swept solids)."""
    folds = [pipe._with_cap_folds(f, (start, end)) for pipe, f, start, end in
             zip(pipes, tubes.folds(), cap_start, cap_end)]
    for i, (pipe, f) in enumerate(zip(pipes, folds)):
        if f and pipe.strict:
            raise GeometryError(f"splice: pipe {i} intersects itself: {f.messages[0]}; "
                                "smooth its path, reduce its radius, or build its swept "
                                "solid (strict=False)", key="pipes", index=i,
                                fix={"strict": False})
    return folds


def _room_for_transitions(pipes, tubes, before, after):
    """Pipes whose ends touch give up a little length for the transition between them.

    Returns the pipes and their batch, rebuilt if any pipe was trimmed.
    """
    touching = _touching(tubes, before, after)
    if not touching.any():
        return pipes, tubes
    trim = np.zeros((len(pipes), 2))
    groups = tubes.groups
    room = np.minimum(tubes.ring_radii[groups.last[before]], tubes.ring_radii[groups.first[after]])
    trim[before[touching], 1] = trim[after[touching], 0] = 0.5 * room[touching]
    pipes = [p.trimmed(*t) if t.any() else p for p, t in zip(pipes, trim)]
    return pipes, tubes_of(pipes)


def _touching(tubes, before, after):
    """(J,) junctions whose ends are closer than half the smaller end radius: no room for
    a transition between them."""
    groups = tubes.groups
    end, start = groups.last[before], groups.first[after]
    gap = norm(tubes.lines.xyz[:, start] - tubes.lines.xyz[:, end], 0)
    return gap < 0.5 * np.minimum(tubes.ring_radii[end], tubes.ring_radii[start])


def chain_mesh(pipes, joint, transition, closed, tubes=None, bridges=None):
    """The solid of a chain whose junctions are planned (:func:`make_room`): stitched
    pipes and transitions, or, where a joint joins them or pieces cross, the union
    of the pieces.

    ``tubes``, ``bridges``: the pipes' and transitions' batches if already made
    (:class:`ChainPlan`; caps do not change them; a hollow chain's bore passes its
    transitions, see :func:`bore_of_chain`)."""
    strict = any(getattr(p, "strict", False) for p in pipes)
    before, after = junctions(len(pipes), closed)
    last = len(pipes) - 1
    cap_start = [(i == 0 and not closed) for i in range(len(pipes))]
    cap_end = [(i == last and not closed) for i in range(len(pipes))]
    for b, a in zip(before[joint].tolist(), after[joint].tolist()):
        cap_end[b] = cap_start[a] = True
    pipes = [_flat_at(p, cap_start[i] and not (i == 0 and not closed),
                      cap_end[i] and not (i == last and not closed))
             for i, p in enumerate(pipes)]
    tubes = tubes_of(pipes) if tubes is None else tubes
    sides = tubes.sides
    if bridges is None:
        bridges = _transition_tubes(tubes, before[~joint], after[~joint], transition)[0]

    surface = Surface()
    ends = add_pipe_surfaces(surface, tubes, pipes, parts=[surface.part(f"pipe{i}")
                                                           for i in range(len(pipes))],
                             cap_start=cap_start, cap_end=cap_end)
    if bridges is not None:
        _add_transitions(surface, bridges, before[~joint], after[~joint], ends, sides,
                         transition)
    balls = [surface.part(f"joint{b}") for b in before[joint].tolist()]
    vertices, faces, face_part = surface.build()
    attributes = {"kind": "chain", "parts": len(surface.part_names)}
    folds = _pipe_folds(pipes, tubes, cap_start, cap_end)
    swept = [i for i, f in enumerate(folds) if f]
    crossing = [] if joint.any() or swept else _crossing_pieces(
        _chain_segments(tubes, bridges, before, pipes, closed, surface), closed)
    if not crossing and not joint.any() and not swept:
        return Mesh.trusted(vertices, faces, face_part=face_part,
                            part_names=surface.part_names, attributes=attributes)
    names = surface.part_names
    joined = [f"pipe{b} and pipe{a} (a ball joint)"
              for b, a in zip(before[joint].tolist(), after[joint].tolist())]
    merged = [f"pipe{i} (its swept solid: it overlaps itself)" for i in swept] + [
        f"{names[i]} and {names[j]} (they cross)" for i, j in crossing] + joined
    if strict:
        raise GeometryError(f"splice: {merged[0]}" + (f" (and {len(merged) - 1} more)"
                                                      if len(merged) > 1 else "")
                            + "; move the pipes apart, or build the union (strict=False "
                            "on every pipe)", key="pipes", fix={"strict": False})
    if bridges is not None:
        cuts = _cuts(tubes, bridges, before[~joint], after[~joint], ends, sides, surface)
        vertices, faces, face_part = _close_cuts(vertices, faces, face_part, cuts)
    joints = [_ball_joint(tubes, b, a) for b, a in zip(before[joint].tolist(),
                                                        after[joint].tolist())]
    solids = {surface.part(f"pipe{i}"): Mesh.from_manifold(pipes[i]._swept_solid(
        folds[i], (cap_start[i], cap_end[i]))[0]) for i in swept}
    return united(vertices, faces, face_part, names, joints, balls,
                  {**attributes, "merged": "; ".join(merged)}, solids)


def _flat_at(pipe, start, end):
    """``pipe`` with flat caps at the ends a ball joint holds (a round cap there would
    run along the ball's surface)."""
    styles = tuple("flat" if at else c for c, at in zip(pipe.cap_styles, (start, end)))
    return pipe if styles == pipe.cap_styles else pipe.replace(caps=styles, sides=pipe.sides)


def _transition_tubes(tubes, before, after, transition, check=False):
    """The transitions from each pipe's end to the next one's start, as one batch, and
    which of them would fold.

    Each follows a cubic Hermite curve tangent to both pipes, its radius eased from
    one to the other; its frames start from the first pipe's end ring and end on the
    second's start ring (up to a whole ``2*pi/sides`` step). Its end rings are the
    pipes' own, so only its inner rings are used.

    Returns
    -------
    bridges : Tubes or None
        None when there are no junctions, or some transition is too short for its
        rings.
    bent : (J,) bool array
        Transitions that have no room, and with ``check`` those that would cut
        through themselves.
    """
    if not len(before):
        return None, np.zeros(0, bool)
    lines, groups = tubes.lines, tubes.groups
    sides = tubes.sides
    sides = np.lcm(sides[before], sides[after]) if transition == "lcm" else sides[after]
    end, start = groups.last[before], groups.first[after]
    e, s = lines.xyz[:, end], lines.xyz[:, start]
    t1, t2 = lines.directions[:, end], lines.directions[:, start]
    chord = norm(s - e, 0)
    r1, r2 = tubes.ring_radii[end], tubes.ring_radii[start]
    rings = RINGS_PER_RADIUS * chord / np.minimum(r1, r2)
    limits.check("max_triangles", float(np.sum(2 * rings * sides)),
                 f"the transitions across gaps of up to {chord.max():.6g}", key="pipes")
    count = np.maximum(MIN_RINGS + 1, np.ceil(rings).astype(np.int64))
    curves = Groups(count + 1)
    spread = curves.spread
    u = curves.local() * spread(1.0 / count)
    u[curves.last] = 1.0                                           # as np.linspace does
    h00, h10 = 2 * u**3 - 3 * u**2 + 1, u**3 - 2 * u**2 + u
    h01, h11 = -2 * u**3 + 3 * u**2, u**3 - u**2
    chord = spread(chord)
    points = (h00 * spread(e) + h10 * chord * spread(t1) + h01 * spread(s)
              + h11 * chord * spread(t2))
    ease = 3 * u**2 - 2 * u**3
    radii = spread(r1) + spread(r2 - r1) * ease
    bridges = Polylines(points, curves)
    extent = np.max(np.maximum.reduceat(points, curves.first, axis=1)
                    - np.minimum.reduceat(points, curves.first, axis=1), axis=0)
    tolerance = 1e-9 * np.maximum(extent, 1.0)                  # as Path drops duplicates
    is_segment = np.ones(len(u), bool)
    is_segment[curves.last] = False
    short = np.logical_or.reduceat(is_segment & (bridges.segment_lengths <= spread(tolerance)),
                                   curves.first)
    # a transition that reverses has no tangent to carry rings at the reversal
    reverses = np.logical_or.reduceat(bridges.turning_angles > np.pi - 1e-9, curves.first)
    if short.any() or reverses.any():
        return None, short | reverses
    bridges = Tubes(bridges, radii, sides, tubes.miter_limit[before],
                    normals=tubes.normals[:, end].T, end_normals=tubes.normals[:, start].T)
    if not check:
        return bridges, short
    bent = np.array([bool(f) for f in bridges.self_intersection_findings()])
    return bridges, bent | _ends_fold(bridges, t1, t2)


def _ends_fold(bridges, t1, t2):
    """(J,) True where a pipe's end ring (square to ``t1``, or ``t2`` at the far end) and
    the transition's nearest inner ring would meet inside the tube: the transition's
    own check sees rings square to its first and last segments there instead.

    Across a segment of direction d and length L, a ring plane of normal n sits at
    an axial offset ``y . g`` for a lateral offset y, ``g = (n - (n . d) d) / (n . d)``;
    the two planes meet inside radius rho when ``rho |g_a - g_b| >= L`` (as
    :mod:`~cadpipe.geometry.clearance` checks inside a tube), or when either ring
    faces backwards (``n . d <= 0``).
    """
    lines, groups = bridges.lines, bridges.groups
    reach = bridges.ring_radii * bridges.miter_stretch
    bent = np.zeros(len(groups), bool)
    for segment, inner, normal_a, normal_b in (
            (groups.first, groups.first + 1, t1, None),
            (groups.last - 1, groups.last - 1, None, t2)):
        d = lines.directions[:, segment]
        a = lines.tangents[:, inner] if normal_a is None else normal_a
        b = lines.tangents[:, inner] if normal_b is None else normal_b
        da, db = np.einsum("ij,ij->j", a, d), np.einsum("ij,ij->j", b, d)
        with np.errstate(divide="ignore", invalid="ignore"):
            lean = norm((a - da * d) / da - (b - db * d) / db, 0)
        bent |= (da <= 1e-9) | (db <= 1e-9) | ~(reach[inner] * lean
                                                 < lines.segment_lengths[segment] * (1 - 1e-9))
    return bent


def _blocks(bridges, n1, n2, mode):
    """Each transition's inner rings, rows ``first..last - 1``: with ``merge`` between
    pipes of ``n1`` and ``n2`` sides (``two``), n1-gon rings up to ``cut`` and n3-gon
    rings (the transition's own sides) from there; else all n3-gon rings."""
    groups = bridges.groups
    first, last = groups.first + 1, groups.last
    two = (n1 != n2) & (mode == "merge")
    return first, np.where(two, first + (last - first) // 2, first), last, two


def bore_of_chain(tubes, bridges, before, after, mode, wall):
    """A hollow chain's bore, where its pipes meet transitions: ``(pipe_scales,
    bore_bridges)``, (P, 2) the most each pipe's end rings (first, last) may be scaled,
    and the transitions' bore (the outer ``bridges`` with scaled rings).

    Every ring of the outer chain around a transition (the pipe's end ring, the
    transition's rings, the next pipe's start ring) is scaled so that each bore vertex
    lies ``wall`` inside every face plane of the outer bands beside it (the stitches
    between ring sizes lean both ways), as
    :func:`~cadpipe.solids.hollow.bore_scales` does along a pipe."""
    from cadpipe.geometry.bands import band_planes, wall_scales

    pipe_scales = np.full((len(tubes.groups), 2), np.inf)
    ring_scales = np.ones(bridges.groups.size)
    n1, n2, n3 = tubes.sides[before], tubes.sides[after], bridges.sides
    first, cut, last, two = _blocks(bridges, n1, n2, mode)
    for t, (b, a) in enumerate(zip(before.tolist(), after.tolist())):
        sizes = np.where(np.arange(first[t], last[t]) < cut[t], n1[t], n3[t])
        chain = ([(tubes, int(tubes.groups.last[b]), int(n1[t]))]
                 + [(bridges, row, int(n)) for row, n in zip(range(first[t], last[t]),
                                                             sizes.tolist())]
                 + [(tubes, int(tubes.groups.first[a]), int(n2[t]))])
        scale = np.full(len(chain), np.inf)
        for k, ((ta, ra, na), (tb, rb, nb)) in enumerate(zip(chain[:-1], chain[1:])):
            offset = -bridges.seam_shift[t] * nb / n3[t] if k == len(chain) - 2 else 0.0
            normals, offsets = band_planes(ta.rings([ra], na), tb.rings([rb], nb), offset)
            centres = np.stack([ta.axes[ra, 2], tb.axes[rb, 2]])[None]
            for j, (tube, row, n) in ((k, chain[k]), (k + 1, chain[k + 1])):
                scale[j] = min(scale[j], wall_scales(normals, offsets, tube.axes[[row]], n,
                                                     wall, centres)[0])
        pipe_scales[b, 1] = min(pipe_scales[b, 1], scale[0])
        pipe_scales[a, 0] = min(pipe_scales[a, 0], scale[-1])
        ring_scales[first[t]:last[t]] = scale[1:-1]
    return pipe_scales, bridges.with_radii(bridges.ring_radii * ring_scales)


def _add_transitions(surface, bridges, before, after, ends, pipe_sides, mode):
    """Lay out each transition's inner rings, their side faces and the stitches that
    join them to each other and to the pipes' end rings (``ends``: each pipe's first
    and last ring)."""
    part = np.array([surface.part(f"transition{a}") for a in before.tolist()])
    n1, n2, n3 = pipe_sides[before], pipe_sides[after], bridges.sides
    first, cut, last, two = _blocks(bridges, n1, n2, mode)
    # runs of rings: the n1-gon blocks of merged transitions, then every n3-gon block
    lo = np.concatenate([first[two], cut])
    hi = np.concatenate([cut[two], last])
    sides = np.concatenate([n1[two], n3])
    first_ring = surface.add_rings([bridges.axes[a:b] for a, b in zip(lo.tolist(), hi.tolist())],
                                   sides, np.concatenate([part[two], part]))
    last_ring = first_ring + (hi - lo - 1) * sides
    merged, main = slice(0, int(two.sum())), slice(int(two.sum()), None)
    start, end = first_ring[main], last_ring[main]           # each transition's n3 block
    opening = start.copy()                                   # each transition's first ring
    opening[two] = first_ring[merged]
    # the pipe's end ring to the first block; the n1 block to the n3 block; the n3 block
    # to the next pipe's start ring, which the transition frames meet with a whole-step
    # offset on the n3 grid
    a_start = np.concatenate([ends[1][before], last_ring[merged], end])
    n_a = np.concatenate([n1, n1[two], n3])
    b_start = np.concatenate([opening, start[two], ends[0][after]])
    n_b = np.concatenate([np.where(two, n1, n3), n3[two], n2])
    offset = np.concatenate([np.zeros(len(n1) + int(two.sum())), -bridges.seam_shift * n2 / n3])
    labels = np.concatenate([part, part[two], part])
    surface.add_faces(int((n_a + n_b).sum()), lambda out: np.copyto(
        out, zipper_faces(a_start, n_a, b_start, n_b, offset)),
                      np.repeat(labels.astype(np.int32), n_a + n_b))


# -- pieces against each other --------------------------------------------------------
def _chain_segments(tubes, bridges, before, pipes, closed, surface):
    """The chain's segments in order along it (pipe 0, transition 0, pipe 1, ...): per
    segment its start (S, 3), vector (S, 3), reach (S,) and part index (S,). A segment's
    reach is the larger of its ends' (how far the surface lies from each axis point:
    ring radius times miter stretch, and at an open chain's ends the hypotenuse with the
    cap's reach). Each batch's segments go straight to their places along the chain."""
    batches = [(tubes, [f"pipe{i}" for i in range(len(pipes))], 2 * np.arange(len(pipes)))]
    if bridges is not None:
        batches.append((bridges, [f"transition{b}" for b in before.tolist()],
                        2 * np.arange(len(before)) + 1))
    sizes = np.zeros(2 * len(pipes), np.int64)
    for batch, _, rank in batches:
        sizes[rank] = batch.groups.counts - 1            # an open piece's points less one
    offsets = np.cumsum(sizes) - sizes
    count = int(sizes.sum())
    start, seg, reach = np.empty((count, 3)), np.empty((count, 3)), np.empty(count)
    part = np.empty(count, np.int64)
    for batch, names, rank in batches:
        groups = batch.groups
        radii = batch.ring_radii * batch.miter_stretch
        if batch is tubes and not closed:
            radii = radii.copy()
            first, last = groups.first[0], groups.last[-1]
            radii[first] = np.hypot(radii[first], pipes[0].cap_reach[0])
            radii[last] = np.hypot(radii[last], pipes[-1].cap_reach[1])
        has_segment = np.ones(groups.size, bool)
        has_segment[groups.last] = False             # an open piece's last point
        cols = np.flatnonzero(has_segment)
        owner = groups.index[cols]
        at = offsets[rank[owner]] + cols - groups.first[owner]
        xyz = batch.lines.xyz
        start[at] = xyz[:, cols].T
        seg[at] = batch.lines.segments[:, cols].T
        reach[at] = np.maximum(radii[cols], radii[cols + 1])
        part[at] = np.array([surface.part(name) for name in names], np.int64)[owner]
    return start, seg, reach, part


def _crossing_pieces(segments, closed):
    """``[(i, j)]`` parts ``i < j`` whose tubes may cut through each other.

    Each segment of the chain (:func:`_chain_segments`) is held by the capsule of its
    reach. Segments of different pieces count when they come closer than their
    reaches' sum while lying at least ``pi/2`` times that sum apart along the chain:
    nearer ones are neighbours across a junction, kept apart by the checks of each
    piece and of each transition's ends (a tube that bends no tighter than its radius
    cannot come back to itself within half a turn). One compiled walk of a tree of the
    segments against itself (``csrc/clearance.c``), which stops looking at two pieces
    once they are known to cross: it costs what the pieces that come near each other
    cost, not a pass over all pairs.
    """
    start, seg, reach, part = segments
    length = norm(seg)
    arc = np.cumsum(length) - length                  # each segment's start along the chain
    budget = limits.current().max_swept_segments
    i, j, _, over = native.crossing_pairs(start, seg, reach, part, arc, length,
                                          float(length.sum()) if closed else 0.0, budget)
    if over >= 0:
        limits.check("max_swept_segments", float(budget) + 1,
                     "the search for pieces of a chain that cross (piece pairs)",
                     at_least=True, key="pipes")
    return sorted({(int(min(p, q)), int(max(p, q))) for p, q in zip(part[i], part[j])})


def _cuts(tubes, bridges, before, after, ends, sides, surface):
    """Where stitched pieces are cut apart for a union: per junction with a transition,
    the pipe's end ring (pipe, then transition) and the next pipe's start ring
    (transition, then pipe). Rows: ring start vertex, sides, centre, tangent, cone
    depth, upstream part, downstream part."""
    lines, groups = tubes.lines, tubes.groups
    b_lines, b_groups = bridges.lines, bridges.groups
    cuts = []
    for k, (b, a) in enumerate(zip(before.tolist(), after.tolist())):
        transition, pipe_b, pipe_a = (surface.part(f"transition{b}"), surface.part(f"pipe{b}"),
                                      surface.part(f"pipe{a}"))
        for ring, row, pipe_seg, bridge_seg, up, down in (
                (ends[1][b], groups.last[b], groups.last[b] - 1, b_groups.first[k],
                 pipe_b, transition),
                (ends[0][a], groups.first[a], groups.first[a], b_groups.last[k] - 1,
                 transition, pipe_a)):
            n = int(sides[b if up == pipe_b else a])
            depth = min(CUT_DEPTH * float(tubes.ring_radii[row]),
                        0.25 * float(lines.segment_lengths[pipe_seg]),
                        0.25 * float(b_lines.segment_lengths[bridge_seg]))
            cuts.append((int(ring), n, lines.xyz[:, row], lines.tangents[:, row], depth, up,
                         down))
    return cuts


def _close_cuts(vertices, faces, face_part, cuts):
    """The stitched surface with each cut ring closed twice: a cone reaching ``depth``
    forward into the downstream piece closes the upstream one, and one reaching back
    closes the downstream one, so the pieces overlap rather than share a face."""
    apexes = np.array([centre + sign * depth * tangent for _, _, centre, tangent, depth, *_
                       in cuts for sign in (1.0, -1.0)]).reshape(-1, 3)
    first = len(vertices)
    fans, labels = [], []
    for k, (ring, n, _, _, _, up, down) in enumerate(cuts):
        for j, (part, at_end) in enumerate(((up, True), (down, False))):
            fans.append(fan_faces(ring, n, apex=first + 2 * k + j, at_end=at_end))
            labels.append(np.full(n, part, np.int32))
    return (np.concatenate([vertices, apexes]), np.concatenate([faces, *fans]),
            np.concatenate([face_part, *labels]))


def _unit_ball():
    """(V, 3) icosphere vertices scaled so that its faces lie outside the unit sphere:
    the hull of it scaled by r about a point contains the ball of radius r there."""
    import trimesh

    sphere = trimesh.creation.icosphere(subdivisions=BALL_SUBDIVISIONS)
    inradius = float(np.min(np.einsum("ij,ij->i", sphere.face_normals,
                                      sphere.vertices[sphere.faces[:, 0]])))
    return np.asarray(sphere.vertices) / inradius


def _ball_joint(tubes, b, a):
    """(P, 3) points whose hull joins pipe ``b``'s end to pipe ``a``'s start: a ball of
    each end ring's radius about each end point."""
    groups = tubes.groups
    rows = [groups.last[b], groups.first[a]]
    ball = _unit_ball()
    return np.concatenate([tubes.lines.xyz[:, row] + float(tubes.ring_radii[row]) * ball
                           for row in rows])


def united(vertices, faces, face_part, names, hulls, hull_parts, attributes, pieces=None):
    """The union through manifold3d of the closed pieces of a surface (its faces by part)
    and of the convex hulls of ``hulls`` (point sets, parts ``hull_parts``), faces
    still labelled by the piece they came from, made float32-safe as a swept pipe is
    (:func:`~cadpipe.geometry.swept.float32_solid`). ``pieces`` ({part: Mesh}) replaces
    those parts' faces by a closed mesh of their own (a pipe's swept solid)."""
    import manifold3d

    pieces = {} if pieces is None else pieces
    ids = list(reserve_ids(len(names)))
    order = np.argsort(face_part, kind="stable")
    bounds = np.searchsorted(face_part[order], np.arange(len(names) + 1))
    solids = [piece.to_manifold(names[k], ids[k]) for k, piece in pieces.items()]
    for k in np.flatnonzero(np.diff(bounds) > 0).tolist():
        if k in pieces:
            continue
        used, local = np.unique(faces[order[bounds[k]:bounds[k + 1]]], return_inverse=True)
        solids.append(Mesh.trusted(vertices[used], local.reshape(-1, 3))
                      .to_manifold(names[k], ids[k]))
    solids += [hull_solid(points, names[k], ids[k]) for points, k in zip(hulls, hull_parts)]
    solid = manifold3d.Manifold.batch_boolean(solids, manifold3d.OpType.Add)
    return float32_solid(solid, dict(zip(ids, names)), attributes=attributes)
