"""Step S5: joining pipes of different mouth shapes into one seamless solid.

Between pipe1 (an n1-gon mouth) and pipe2 (n2-gon) a transition pipe follows a
cubic Hermite curve from pipe1's end to pipe2's start, tangent to both, its radius
easing from one to the other. With ``transition="lcm"`` (the source's method) its
rings have ``lcm(n1, n2)`` vertices and meet each pipe through an n-to-1 stitch;
with ``transition="merge"`` its rings keep n1 then n2 vertices and the two sizes
meet once, by angle. The frames run on from pipe1's end and are eased to pipe2's
start, so a transition never twists.
"""

import numpy as np

from cadpipe._validate import as_choice
from cadpipe._vec import norm
from cadpipe.errors import GeometryError, InputError
from cadpipe.geometry.loft import Surface, zipper_faces
from cadpipe.geometry.mesh import Mesh
from cadpipe.geometry.path import Polylines
from cadpipe.geometry.pipe import Pipe, add_pipe_surfaces, tubes_of
from cadpipe.geometry.ragged import Groups
from cadpipe.geometry.rings import Tubes

TRANSITIONS = ("lcm", "merge")

#: transition rings per smallest radius of length (at least MIN_RINGS)
RINGS_PER_RADIUS = 2.0
MIN_RINGS = 3


def splice(*pipes: Pipe, transition: str = "lcm", closed: bool = False) -> Mesh:
    """One watertight mesh: the pipes in order, joined by transitions.

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
        Faces labelled by part: ``pipe<i>`` and ``transition<i>`` (from pipe i to the
        next).

    All pipes are built as one batch, and all transitions as another
    (:class:`~cadpipe.geometry.rings.Tubes`): a chain of a thousand pipes costs a few numpy
    calls per stage, not a few per pipe.
    """
    if not pipes:
        raise InputError("splice: expected at least one Pipe, got none")
    for i, p in enumerate(pipes):
        if not isinstance(p, Pipe):
            raise InputError(f"splice: argument {i} is a {type(p).__name__}, not a cadpipe.Pipe")
        if p.closed:
            raise InputError(f"splice: pipe {i} is a closed loop and has no ends to join")
    transition = as_choice(transition, "transition", TRANSITIONS)
    if len(pipes) == 1 and not closed:
        return pipes[0].mesh().with_parts(["pipe0"])
    before, after = _junctions(len(pipes), closed)
    pipes, tubes = _room_for_transitions(list(pipes), tubes_of(pipes), before, after)
    for i, problems in enumerate(tubes.self_intersection_findings()):
        if problems:
            raise GeometryError(f"splice: pipe {i} intersects itself: {problems[0]}")
    sides = tubes.sides
    n3 = np.lcm(sides[before], sides[after]) if transition == "lcm" else sides[after]
    bridges = _transition_tubes(tubes, before, after, n3)
    for k, problems in enumerate(bridges.self_intersection_findings()):
        if problems:
            raise GeometryError(f"splice: the transition{before[k]} would intersect itself: "
                                f"{problems[0]}; move the pipes apart or align their ends")

    surface = Surface()
    last = len(pipes) - 1
    ends = add_pipe_surfaces(surface, tubes, pipes, parts=[surface.part(f"pipe{i}")
                                                           for i in range(len(pipes))],
                             cap_start=[i == 0 and not closed for i in range(len(pipes))],
                             cap_end=[i == last and not closed for i in range(len(pipes))])
    _add_transitions(surface, bridges, before, after, ends, sides, transition)
    vertices, faces, face_part = surface.build()
    return Mesh.trusted(vertices, faces, face_part=face_part, part_names=surface.part_names,
                        attributes={"kind": "chain", "parts": len(surface.part_names)})


def _junctions(count, closed):
    """(J,) index of the pipe before and after each junction."""
    before = np.arange(count - 1 + closed)
    return before, (before + 1) % count


def make_room(pipes, closed=False):
    """The pipes, those whose ends touch trimmed to leave room for a transition (as
    :func:`splice` does, so other chains can follow the same ends)."""
    return _room_for_transitions(pipes, tubes_of(pipes), *_junctions(len(pipes), closed))[0]


def _room_for_transitions(pipes, tubes, before, after):
    """Pipes whose ends touch give up a little length for the transition between them.

    Returns the pipes and their batch, rebuilt if any pipe was trimmed.
    """
    groups = tubes.groups
    end, start = groups.last[before], groups.first[after]
    gap = norm(tubes.lines.xyz[:, start] - tubes.lines.xyz[:, end], 0)
    room = np.minimum(tubes.ring_radii[end], tubes.ring_radii[start])
    touching = gap < 0.5 * room
    if not touching.any():
        return pipes, tubes
    trim = np.zeros((len(pipes), 2))
    trim[before[touching], 1] = trim[after[touching], 0] = 0.5 * room[touching]
    pipes = [p.trimmed(*t) if t.any() else p for p, t in zip(pipes, trim)]
    return pipes, tubes_of(pipes)


def _transition_tubes(tubes, before, after, sides):
    """The transitions from each pipe's end to the next one's start, as one batch.

    Each follows a cubic Hermite curve tangent to both pipes, its radius eased from
    one to the other; its frames start from the first pipe's end ring and end on the
    second's start ring (up to a whole ``2*pi/sides`` step). Its end rings are the
    pipes' own, so only its inner rings are used.
    """
    lines, groups = tubes.lines, tubes.groups
    end, start = groups.last[before], groups.first[after]
    e, s = lines.xyz[:, end], lines.xyz[:, start]
    t1, t2 = lines.directions[:, end], lines.directions[:, start]
    chord = norm(s - e, 0)
    r1, r2 = tubes.ring_radii[end], tubes.ring_radii[start]
    count = np.maximum(MIN_RINGS + 1,
                       np.ceil(RINGS_PER_RADIUS * chord / np.minimum(r1, r2)).astype(np.int64))
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
    if (is_segment & (bridges.segment_lengths <= spread(tolerance))).any():
        raise GeometryError("splice: the transition is too short for its rings; "
                            "leave more room between the pipes")
    return Tubes(bridges, radii, sides, tubes.miter_limit[before],
                 normals=tubes.normals[:, end].T, end_normals=tubes.normals[:, start].T)


def _add_transitions(surface, bridges, before, after, ends, pipe_sides, mode):
    """Lay out each transition's inner rings, their side faces and the stitches that
    join them to each other and to the pipes' end rings (``ends``: each pipe's first
    and last ring)."""
    groups = bridges.groups
    part = np.array([surface.part(f"transition{a}") for a in before.tolist()])
    n1, n2, n3 = pipe_sides[before], pipe_sides[after], bridges.sides
    first, last = groups.first + 1, groups.last                       # inner rings
    # merge: n1-gon rings for the first half, n2-gon after; lcm: all lcm-gon rings
    two = (n1 != n2) & (mode == "merge")
    cut = np.where(two, first + (last - first) // 2, first)
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
