"""Step S5: joining pipes of different mouth shapes into one seamless solid.

Between pipe1 (an n1-gon mouth) and pipe2 (n2-gon) a transition pipe follows a
cubic Hermite curve from pipe1's end to pipe2's start, tangent to both, its radius
easing from one to the other. With ``transition="lcm"`` (the source's method) its
rings have ``lcm(n1, n2)`` vertices and meet each pipe through an n-to-1 stitch;
with ``transition="merge"`` its rings keep n1 then n2 vertices and the two sizes
meet once, by angle. The frames run on from pipe1's end and are eased to pipe2's
start, so a transition never twists.
"""

import math

import numpy as np

from ._validate import as_choice
from .errors import GeometryError, InputError
from .loft import band_faces, zipper_faces
from .mesh import Mesh
from .path import Path
from .pipe import Pipe

TRANSITIONS = ("lcm", "merge")

#: transition rings per smallest radius of length (at least MIN_RINGS)
RINGS_PER_RADIUS = 2.0
MIN_RINGS = 3


def splice(*pipes, transition="lcm", closed=False):
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
    pipes = _make_room(list(pipes), closed)
    junctions = list(zip(range(len(pipes)), range(1, len(pipes))))
    if closed:
        junctions.append((len(pipes) - 1, 0))

    chain = _Chain()
    ends = []                                        # (first ring, last ring) of each pipe
    for i, p in enumerate(pipes):
        problems = p.self_intersections()
        if problems:
            raise GeometryError(f"splice: pipe {i} intersects itself: {problems[0]}")
        cap_start, cap_end = (i == 0 and not closed), (i == len(pipes) - 1 and not closed)
        vertices, faces = p.surface(cap_start=cap_start, cap_end=cap_end)
        first = chain.add(f"pipe{i}", vertices, faces)
        poles = sum(1 for c in (cap_start, cap_end) if c and p.caps == "round")
        ring_start = first + (p.cap_ring_count * p.sides if cap_start else 0)
        ends.append((ring_start, first + len(vertices) - poles - p.sides))
    for a, b in junctions:
        _join(chain, pipes[a], pipes[b], ends[a][1], ends[b][0], f"transition{a}", transition)
    return chain.mesh()


class _Chain:
    """Vertex and face blocks with part labels, concatenated once at the end."""

    def __init__(self):
        self.vertices, self.faces, self.labels, self.names = [], [], [], []
        self.count = 0

    def add(self, name, vertices, faces):
        first = self.count
        self.vertices.append(vertices)
        self.count += len(vertices)
        self.add_faces(name, faces + first)
        return first

    def add_faces(self, name, faces):
        if name not in self.names:
            self.names.append(name)
        self.faces.append(faces)
        self.labels.append(np.full(len(faces), self.names.index(name), np.int32))

    def mesh(self):
        return Mesh(np.concatenate(self.vertices), np.concatenate(self.faces),
                    face_part=np.concatenate(self.labels), part_names=self.names,
                    attributes={"kind": "chain", "parts": len(self.names)})


def _make_room(pipes, closed):
    """Pipes whose ends touch give up a little length for the transition between them."""
    pairs = list(zip(range(len(pipes) - 1), range(1, len(pipes))))
    if closed:
        pairs.append((len(pipes) - 1, 0))
    trim = np.zeros((len(pipes), 2))
    for a, b in pairs:
        gap = np.linalg.norm(pipes[b].path.points[0] - pipes[a].path.points[-1])
        room = min(pipes[a].ring_radii[-1], pipes[b].ring_radii[0])
        if gap < 0.5 * room:
            trim[a, 1] = trim[b, 0] = 0.5 * room
    return [p.trimmed(*t) if t.any() else p for p, t in zip(pipes, trim)]


def _transition_pipe(p1, p2, sides):
    """The transition from ``p1``'s end to ``p2``'s start as a Pipe (its end rings are
    ``p1``'s and ``p2``'s own, so only its inner rings are used)."""
    e, s = p1.path.points[-1], p2.path.points[0]
    t1, t2 = p1.path.directions[-1], p2.path.directions[0]
    chord = float(np.linalg.norm(s - e))
    r1, r2 = p1.ring_radii[-1], p2.ring_radii[0]
    count = max(MIN_RINGS + 1, math.ceil(RINGS_PER_RADIUS * chord / min(r1, r2)))
    u = np.linspace(0.0, 1.0, count + 1)[:, None]
    h00, h10 = 2 * u**3 - 3 * u**2 + 1, u**3 - 2 * u**2 + u
    h01, h11 = -2 * u**3 + 3 * u**2, u**3 - u**2
    points = h00 * e + h10 * chord * t1 + h01 * s + h11 * chord * t2
    ease = (3 * u**2 - 2 * u**3).ravel()
    radii = r1 + (r2 - r1) * ease
    pipe = Pipe(Path(points), radii, sides=sides, normal=p1.normals[-1],
                end_normal=p2.normals[0], miter_limit=p1.miter_limit)
    if len(pipe.path) != count + 1:
        raise GeometryError("splice: the transition is too short for its rings; "
                            "leave more room between the pipes")
    return pipe


def _join(chain, p1, p2, ring1, ring2, name, mode):
    """Transition rings between ``p1``'s last ring and ``p2``'s first, and their faces."""
    n1, n2 = p1.sides, p2.sides
    n3 = math.lcm(n1, n2) if mode == "lcm" else n2
    trans = _transition_pipe(p1, p2, n3)
    problems = trans.self_intersections()
    if problems:
        raise GeometryError(f"splice: the {name} would intersect itself: {problems[0]}; "
                            "move the pipes apart or align their ends")
    inner = len(trans.path) - 2
    # merge: n1-gon rings for the first half, n2-gon after; lcm: all lcm-gon rings
    sizes = [n1] * (inner // 2) + [n2] * (inner - inner // 2) if mode == "merge" else [n3] * inner
    blocks = []
    for size in dict.fromkeys(sizes):
        idx = [k + 1 for k, n in enumerate(sizes) if n == size]
        blocks.append((size, trans.rings(size)[idx].reshape(-1, 3), len(idx)))
    # the transition frames meet p2's ring with a whole-step offset on the n3 grid
    offset_b = -trans.seam_shift * n2 / n3
    prev_start, prev_n = ring1, n1
    for size, vertices, rings in blocks:
        first = chain.add(name, vertices, band_faces(rings, size))
        chain.add_faces(name, zipper_faces(prev_start, prev_n, first, size))
        prev_start, prev_n = first + (rings - 1) * size, size
    chain.add_faces(name, zipper_faces(prev_start, prev_n, ring2, n2, offset_b))
