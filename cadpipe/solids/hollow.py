"""Printable pipes with a wall: outer solids minus bores.

Two hollow tubes must never be unioned as they are: each wall plugs the other's
bore and leaves sealed voids. A hollow part therefore hands an assembly two lists
(:meth:`HollowPipe.solids`): the outer solids it adds and the bores it cuts, and
the assembly computes ``union(outer solids) - union(bores)``. A
:class:`Junction` (T, Y, any branching) is several hollow pipes treated as one
part; a :class:`HollowChain` is spliced pipes with a spliced bore. Bores of open
ends run a little past the pipe, so the cut leaves no skin.
"""

import dataclasses
from dataclasses import dataclass
from collections.abc import Mapping, Sequence
from types import MappingProxyType
from functools import cached_property, partial
from typing import Any

import numpy as np

from cadpipe._validate import as_choice, as_flag, as_positive
from cadpipe.solids.booleans import carve
from cadpipe.errors import InputError
from cadpipe.geometry.bands import band_planes, wall_scales
from cadpipe.geometry.clearance import local_folds
from cadpipe.geometry.mesh import Mesh
from cadpipe.geometry.path import Path
from cadpipe.geometry.cover import laid_rings
from cadpipe.geometry.pipe import Pipe, envelope_factor
from cadpipe.geometry.splice import TRANSITIONS, chain_members

END_STYLES = ("open", "closed")
#: most times a bore's round closed end is pulled back to fit inside the outer cap
ROOM_STEPS = 8


def _ends(ends):
    """``(start, end)`` styles from one style or a pair."""
    pair = (ends, ends) if isinstance(ends, str) else tuple(ends) \
        if isinstance(ends, (tuple, list)) else ()
    if len(pair) != 2:
        raise InputError(f"expected 'open', 'closed' or a pair of them, got {ends!r}", key="ends")
    return tuple(as_choice(e, "ends", END_STYLES) for e in pair)


def _wall(wall, pipes):
    """``wall`` as a float, thinner than every pipe's smallest inradius (the distance
    from its axis to its flat faces)."""
    wall = float(as_positive(wall, "wall"))
    thinnest = min(float(p.ring_radii.min()) / envelope_factor(p.sides) for p in pipes)
    if wall >= thinnest:
        raise InputError(f"{wall:g} must be less than the smallest pipe radius "
                         f"{thinnest:g} (measured to the flat faces)", key="wall")
    return wall


def mouths(pipe, start="open", end="open"):
    """The outer pipe of a hollow part: an open end is a mouth and ends flat, whatever
    ``caps`` says, so the rim there is a flat ring of the full wall thickness (a round
    cap cut by the bore would leave a knife edge)."""
    styles = tuple("flat" if e == "open" else c for c, e in zip(pipe.cap_styles, (start, end)))
    return pipe if styles == pipe.cap_styles else pipe.replace(caps=styles, sides=pipe.sides)


def bore_scales(pipe, wall):
    """(N,) the scale of each of ``pipe``'s rings about its centre that puts every vertex
    of the bore's ring ``wall`` inside each face plane of the bands beside it
    (:func:`~cadpipe.geometry.bands.wall_scales`): then every bore face lies ``wall``
    inside the outer faces of its segment, whatever leans them (a taper, a mitred ring
    on a taper, a twist). On a straight duct that is ``1 - wall / (rho cos(pi / n))``:
    the wall across the flat faces."""
    tubes = pipe._tubes
    count = len(pipe.path)
    starts, ends, joints = laid_rings(pipe)
    first = np.arange(len(pipe.path.segments))
    second = (first + 1) % count
    ahead = ends[second]
    if pipe.closed:                                     # the seam meets ring 0 turned
        ahead[-1] = np.roll(ahead[-1], -pipe.seam_shift, axis=0)
    normals, offsets = band_planes(starts[first], ahead)
    # bands that fold, or end at a corner beyond the miter limit, are built from their
    # convex units (the swept solid): their ring planes say nothing there
    swept = local_folds(tubes)[0][first] | tubes.over_limit[first] | tubes.over_limit[second]
    offsets = np.where(swept[:, None], np.inf, offsets)
    scales = np.full(count, np.inf)
    centres = np.stack([tubes.axes[first, 2], tubes.axes[second, 2]], axis=1)
    for rows in (first, second):
        np.minimum.at(scales, rows, wall_scales(normals, offsets, tubes.axes[rows],
                                                pipe.sides, wall, centres))
    # a ball joint's bore is its rings scaled about the corner: every vertex of them a
    # wall inside the planes of the joint's own faces and of the bands beside it
    centres = pipe.path.points
    for row, (_, rings) in joints.items():
        vertices = rings.reshape(-1, 3) - centres[row]
        for normal, offset in (band_planes(rings[:-1], rings[1:]),
                               (normals[[row - 1, row % len(first)]],
                                offsets[[row - 1, row % len(first)]])):
            normal, offset = normal.reshape(-1, 3), offset.reshape(-1)
            reach = (normal @ vertices.T).max(axis=1)
            room = offset - wall - normal @ centres[row]
            with np.errstate(divide="ignore", invalid="ignore"):
                scales[row] = min(scales[row], float(np.where(reach > 0, room / reach,
                                                              np.inf).min()))
    # a ring only of swept bands: the wall across a straight duct's faces
    plain = 1 - wall * envelope_factor(pipe.sides) / tubes.ring_radii
    return np.where(np.isfinite(scales), scales, plain)


def bore(pipe, wall, start="open", end="open"):
    """The :class:`Pipe` cut out of ``pipe`` (an outer pipe, see :func:`mouths`) to
    leave walls ``wall`` thick across the flat faces.

    Same path, sides, frames and caps, rings aligned with the outer rings and
    scaled by :func:`bore_scales`, so each face of the bore lies ``wall`` inside the
    outer faces of its segment, on tapers and mitred corners too. Per end:
    ``"open"`` runs the bore ``wall`` past the outer solid's end, ``"closed"`` stops it
    ``wall`` short of a flat cap (a round cap gets its own round cap inside),
    ``"flush"`` ends it with the pipe (where a splice continues it).
    """
    ends = (start, end)
    run = [0.0 if pipe.closed or e == "flush" else reach + wall if e == "open"
           else reach - wall if style == "flat" else 0.0
           for e, style, reach in zip(ends, pipe.cap_styles, pipe.cap_reach)]
    path = pipe.path
    radii = pipe.ring_radii * bore_scales(pipe, wall)
    if radii.min() <= 0:
        raise InputError(f"{wall:g} leaves no bore where the pipe tapers steeply (path point "
                         f"{int(np.argmin(radii))}); use a thinner wall", key="wall")
    extend = [max(r, 0.0) for r in run]
    if any(extend):
        head = [path.points[0] - extend[0] * path.directions[0]] if extend[0] else []
        tail = [path.points[-1] + extend[1] * path.directions[-1]] if extend[1] else []
        path = Path(np.vstack([*head, path.points, *tail]))
        radii = np.concatenate([radii[:len(head)], radii, radii[len(radii) - len(tail):]])
    inner = pipe.replace(path=path, radius=radii, sides=pipe.sides, envelope=False,
                         normal=pipe.normals[0])
    cut = [max(-r, 0.0) for r in run]
    for k, (e, style) in enumerate(zip(ends, pipe.cap_styles)):
        if e == "closed" and style == "round" and not pipe.closed:
            # on a taper the pulled-back cap has another radius: pull again until it
            # fits; the shortfalls shrink geometrically, so each pull takes the rest of
            # their series too (a pull too far only thickens the end wall)
            before = None
            for _ in range(ROOM_STEPS):
                trimmed = inner.trimmed(*[cut[k] if j == k else 0.0 for j in range(2)])
                room = _round_end_room(pipe, trimmed, wall, -1 if k == 0 else 1)
                if room <= 1e-9 * wall:
                    break
                ratio = 0.0 if before is None else min(room / before, 0.5)
                cut[k] += room / (1.0 - ratio)
                before = room
    if not any(cut):
        return inner
    if sum(cut) >= path.length:
        raise InputError(f"closed ends {wall:g} thick leave no bore in a pipe "
                         f"{path.length:g} long; use a thinner wall or open ends", key="wall")
    return inner.trimmed(*cut)


def _cap_points(pipe, sign):
    """(K, 3) vertices of ``pipe``'s round cap at one end (``sign`` -1: start), its
    end ring included."""
    from cadpipe.geometry.surfaces import cap_axes
    from cadpipe.geometry.rings import ring_basis

    row = 0 if sign < 0 else len(pipe.path) - 1
    axes, pole = cap_axes(pipe._tubes, row, sign, pipe, "round")
    rings = np.matmul(ring_basis(pipe.sides), axes).reshape(-1, 3)
    return np.concatenate([pipe.rings()[row], rings, pole[None]])


def _round_end_room(outer, inner, wall, sign):
    """How far to pull a bore's round cap back from a closed round end of ``outer`` so
    that it lies ``wall`` inside every face of the outer cap.

    Both caps are convex; the bore's cap vertices must lie ``wall`` inside each
    outer cap face's plane (outward normal n, facing along the end tangent t by
    ``n . t > 0``); moving the bore back by ``d`` gains ``d (n . t)``.
    """
    from scipy.spatial import ConvexHull

    t = sign * outer.path.directions[0 if sign < 0 else -1]
    hull = ConvexHull(_cap_points(outer, sign))
    normal, offset = hull.equations[:, :3], -hull.equations[:, 3]
    facing = normal @ t
    caps = facing > 1e-9
    bore_points = _cap_points(inner, sign)
    need = (bore_points @ normal[caps].T).max(axis=0) - offset[caps] + wall
    return float(max(0.0, (need / facing[caps]).max()))


def _narrowed_ends(bore_pipe, outer, scales):
    """``bore_pipe`` with its end rings no wider than ``scales`` (first, last; ``inf``:
    as it is) times ``outer``'s, where a transition's stitch leans its outer faces in
    (see :func:`~cadpipe.geometry.splice.bore_of_chain`); its other rings as they are."""
    radii = np.array(bore_pipe.radii)
    for row, scale in ((0, scales[0]), (-1, scales[1])):
        radii[row] = min(radii[row], float(outer.ring_radii[row]) * scale)
    if np.array_equal(radii, bore_pipe.radii):
        return bore_pipe
    return bore_pipe.replace(radius=radii, sides=bore_pipe.sides)


class Hollow:
    """A part that adds outer solids and cuts bores; subclasses give :meth:`solids`."""

    def mesh(self):
        """The part on its own: a closed solid (with voids where ends are closed)."""
        bodies, bores = self.solids()
        return carve(bodies, bores, self.attributes["kind"], attributes=self.attributes)


def _members(args, keyword):
    """The members of a Junction or HollowChain: given as arguments (``splice``'s
    convention), or as the one sequence ``pipes=`` (what :meth:`replace` passes)."""
    if keyword is not None:
        if not isinstance(keyword, (list, tuple)):
            raise InputError(f"expected a list of pipes, got {type(keyword).__name__}",
                             key="pipes")
        return tuple(keyword)
    return tuple(args)


@dataclass(frozen=True, eq=False)
class HollowPipe(Hollow):
    """A pipe with a wall of thickness ``wall``: its outer solid minus its bore.

    An immutable value; change it with :meth:`replace`.

    Parameters
    ----------
    pipe : Pipe
        The outer surface.
    wall : float
        Wall thickness in metres, measured across the flat faces (between each outer
        face and the bore face parallel to it), less than the pipe's smallest
        inradius.
    ends : {"open", "closed"} or pair of them
        Per end (start, end) of an open path. An open end's bore runs ``wall`` past
        the end (plus the cap's reach for round caps), so the end is cut clean; use
        "open" for an end that meets another pipe in a :class:`Junction`. A closed
        end keeps a wall: the bore stops ``wall`` short of a flat cap, or ends in
        its own round cap inside a round one.
    """

    pipe: Pipe
    wall: float
    ends: tuple[str, str] | str = "open"

    def __post_init__(self):
        if not isinstance(self.pipe, Pipe):
            raise InputError(f"expected a cadpipe.Pipe, got {type(self.pipe).__name__}",
                             key="pipe")
        object.__setattr__(self, "wall", _wall(self.wall, [self.pipe]))
        object.__setattr__(self, "ends", _ends(self.ends))

    def replace(self, **changes: Any) -> "HollowPipe":
        """This hollow pipe with some settings changed.

        Parameters
        ----------
        **changes
            New values of ``pipe``, ``wall``, ``ends``.

        Returns
        -------
        hollow : HollowPipe
        """
        return dataclasses.replace(self, **changes)

    def __repr__(self):
        ends = "/".join(self.ends)
        return f"<cadpipe.HollowPipe wall {self.wall:g}, ends {ends}, {self.pipe!r}>"

    @cached_property
    def outer(self) -> Pipe:
        """The outer :class:`Pipe`: :attr:`pipe` with flat mouths (see :func:`mouths`)."""
        return mouths(self.pipe, *self.ends)

    @cached_property
    def bore(self) -> Pipe:
        """The :class:`Pipe` cut out of the outer one (see :func:`bore`)."""
        return bore(self.outer, self.wall, *self.ends)

    def solids(self) -> tuple[list[Mesh], list[Mesh]]:
        """What an assembly adds and what it cuts.

        Returns
        -------
        solids, bores : list of Mesh
            ``[outer mesh]`` and ``[bore mesh]``.
        """
        return [self.outer.mesh()], [self.bore.mesh()]

    @property
    def attributes(self) -> Mapping[str, Any]:
        """Read-only mapping of the parameters that made this part."""
        return MappingProxyType({**self.pipe.attributes, "kind": "hollow pipe",
                                 "wall": self.wall, "ends": "/".join(self.ends)})


@dataclass(frozen=True, eq=False, init=False)
class Junction(Hollow):
    """Hollow pipes joined into one part (a T, a Y, any branching).

    ``Junction(*hollow_pipes)``: the union of every outer solid minus the union of
    every bore, so each bore runs through the others' walls and the channels
    connect. Give an end that meets another pipe ``ends="open"`` so its bore reaches
    into that pipe's bore. Pipes may cross anywhere: the unions make one solid, and
    where a bore crosses another pipe the channels meet.

    Parameters
    ----------
    *hollow_pipes : HollowPipe
        The branches, one or more.
    pipes : sequence of HollowPipe, optional
        The branches as one sequence instead (what :meth:`replace` passes).
    """

    pipes: tuple[HollowPipe, ...]

    def __init__(self, *hollow_pipes: HollowPipe,
                 pipes: Sequence[HollowPipe] | None = None) -> None:
        members = _members(hollow_pipes, pipes)
        if not members:
            raise InputError("expected one or more cadpipe.HollowPipe, got none", key="pipes")
        for i, p in enumerate(members):
            if not isinstance(p, HollowPipe):
                raise InputError(f"argument {i} is a {type(p).__name__}, not a "
                                 "cadpipe.HollowPipe", key="pipes", index=i)
        object.__setattr__(self, "pipes", members)

    def replace(self, **changes: Any) -> "Junction":
        """This junction with some settings changed.

        Parameters
        ----------
        **changes
            ``pipes=``: a new sequence of :class:`HollowPipe`.

        Returns
        -------
        junction : Junction
        """
        return dataclasses.replace(self, **changes)

    def __repr__(self):
        return f"<cadpipe.Junction of {len(self.pipes)} hollow pipes>"

    def solids(self) -> tuple[list[Mesh], list[Mesh]]:
        """What an assembly adds and what it cuts.

        Returns
        -------
        solids, bores : list of Mesh
            Every pipe's outer mesh, and every pipe's bore mesh.
        """
        outer, bores = zip(*(p.solids() for p in self.pipes))
        return [m for ms in outer for m in ms], [m for ms in bores for m in ms]

    @property
    def attributes(self) -> Mapping[str, Any]:
        """Read-only mapping of the parameters that made this part."""
        return MappingProxyType({"kind": "junction", "pipes": len(self.pipes),
                                 "wall": max(p.wall for p in self.pipes)})


@dataclass(frozen=True, eq=False, init=False)
class HollowChain(Hollow):
    """Pipes spliced into one chain (:func:`cadpipe.splice`) with a wall ``wall`` thick.

    ``HollowChain(*pipes, wall=..., ends=..., transition=..., closed=...)``, the
    pipes as :func:`~cadpipe.splice` takes them. The outer chain minus the chain of
    bores. The pipes first give up room for the transitions the way
    :func:`~cadpipe.splice` does, so both chains splice between the same end points
    and tangents and each bore transition runs inside its outer one, ``wall`` in
    from it; where a ball joint joins two pipes (see :func:`~cadpipe.splice`) the bore
    has a ball joint ``wall`` smaller, and where pieces cross, both chains are their
    pieces' unions, so the bores of crossing pipes meet as a junction's do. ``ends``
    applies to the chain's two ends; a closed chain has none.

    Parameters
    ----------
    *args : Pipe
        The pipes, open, in order along the chain.
    pipes : sequence of Pipe, optional
        The pipes as one sequence instead (what :meth:`replace` passes).
    wall : float
        Wall thickness in metres, across the flat faces (see :class:`HollowPipe`).
    ends : {"open", "closed"} or pair of them
        The chain's two ends (see :class:`HollowPipe`).
    transition : {"lcm", "merge"}
        As for :func:`~cadpipe.splice`.
    closed : bool
        Also join the last pipe's end to the first pipe's start.
    """

    pipes: tuple[Pipe, ...]
    wall: float
    ends: tuple[str, str] | str = "open"
    transition: str = "lcm"
    closed: bool = False

    def __init__(self, *args: Pipe, wall: float, pipes: Sequence[Pipe] | None = None,
                 ends: str | tuple[str, str] = "open", transition: str = "lcm",
                 closed: bool = False) -> None:
        members = tuple(chain_members(_members(args, pipes)))
        set_ = partial(object.__setattr__, self)
        set_("pipes", members)
        set_("wall", _wall(wall, members))
        set_("ends", _ends(ends))
        set_("transition", as_choice(transition, "transition", TRANSITIONS))
        set_("closed", as_flag(closed, "closed"))

    def replace(self, **changes: Any) -> "HollowChain":
        """This chain with some settings changed.

        Parameters
        ----------
        **changes
            New values of ``pipes`` (a sequence), ``wall``, ``ends``, ``transition``,
            ``closed``.

        Returns
        -------
        chain : HollowChain
        """
        return dataclasses.replace(self, **changes)

    def __repr__(self):
        return f"<cadpipe.HollowChain of {len(self.pipes)} pipes, wall {self.wall:g}>"

    def solids(self) -> tuple[list[Mesh], list[Mesh]]:
        """What an assembly adds and what it cuts.

        Returns
        -------
        solids, bores : list of Mesh
            ``[the spliced outer pipes]`` and ``[the spliced bores]``.
        """
        from cadpipe.geometry.splice import junctions, bore_of_chain, chain_mesh, make_room

        plan = make_room(list(self.pipes), self.closed, self.transition)
        outers = list(plan.pipes)
        last = len(outers) - 1
        open_ends = not self.closed
        if open_ends:
            outers[0] = mouths(outers[0], self.ends[0], "closed")
            outers[last] = mouths(outers[last], "closed", self.ends[1])
        bores = [bore(p, self.wall, self.ends[0] if i == 0 and open_ends else "flush",
                      self.ends[1] if i == last and open_ends else "flush")
                 for i, p in enumerate(outers)]
        if len(outers) == 1 and not self.closed:
            return [outers[0].mesh()], [bores[0].mesh()]
        bridges = None
        if plan.bridges is not None:
            before, after = (j[~plan.joint] for j in junctions(len(outers), self.closed))
            ends, bridges = bore_of_chain(plan.tubes, plan.bridges, before, after,
                                          self.transition, self.wall)
            bores = [_narrowed_ends(b, o, scales) for b, o, scales in zip(bores, outers, ends)]
        options = {"joint": plan.joint, "transition": self.transition, "closed": self.closed}
        return ([chain_mesh(outers, **options, tubes=plan.tubes, bridges=plan.bridges)],
                [chain_mesh(bores, **options, bridges=bridges)])

    @property
    def attributes(self) -> Mapping[str, Any]:
        """Read-only mapping of the parameters that made this part."""
        return MappingProxyType({"kind": "hollow chain", "pipes": len(self.pipes),
                                 "wall": self.wall, "ends": "/".join(self.ends),
                                 "transition": self.transition, "closed": self.closed})
