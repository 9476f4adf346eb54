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
import warnings
from dataclasses import dataclass
from collections.abc import Mapping
from functools import cached_property, partial
from typing import Any

import numpy as np

from cadpipe import _deprecated
from cadpipe._validate import as_choice, as_positive
from cadpipe.solids.booleans import carve
from cadpipe.errors import InputError
from cadpipe.geometry.mesh import Mesh
from cadpipe.geometry.path import Path
from cadpipe.geometry.pipe import Pipe
from cadpipe.geometry.splice import TRANSITIONS

END_STYLES = ("open", "closed")


def _ends(ends):
    """``(start, end)`` styles from one style or a pair."""
    pair = (ends, ends) if isinstance(ends, str) else tuple(ends)
    if len(pair) != 2:
        raise InputError(f"expected 'open', 'closed' or a pair of them, got {ends!r}", key="ends")
    return tuple(as_choice(e, "ends", END_STYLES) for e in pair)


def _wall(wall, pipes):
    """``wall`` as a float, thinner than every pipe's smallest radius."""
    wall = float(as_positive(wall, "wall"))
    thinnest = min(float(p.radii.min()) for p in pipes)
    if wall >= thinnest:
        raise InputError(f"{wall:g} must be less than the smallest pipe radius "
                         f"{thinnest:g}", key="wall")
    return wall


def bore(pipe, wall, start="open", end="open"):
    """The :class:`Pipe` cut out of ``pipe`` to leave walls ``wall`` thick.

    Same path, sides, frames and caps, radius less ``wall``, rings aligned with the
    outer rings. Per end: ``"open"`` runs the bore ``wall`` past the end (plus the
    cap's reach for round caps), ``"closed"`` stops it ``wall`` short of a flat cap
    (a round cap gets its own round cap inside), ``"flush"`` ends it with the pipe
    (where a splice continues it).
    """
    reach = pipe.ring_radii.max() if pipe.caps == "round" else 0.0
    extend = {"open": wall + reach, "closed": 0.0, "flush": 0.0}
    trim = {"open": 0.0, "closed": wall if pipe.caps == "flat" else 0.0, "flush": 0.0}
    path, radii = pipe.path, pipe.radii - wall
    if not path.closed and (extend[start] or extend[end]):
        head = [path.points[0] - extend[start] * path.directions[0]] if extend[start] else []
        tail = [path.points[-1] + extend[end] * path.directions[-1]] if extend[end] else []
        path = Path(np.vstack([*head, path.points, *tail]))
        radii = np.concatenate([radii[:len(head)], radii, radii[len(radii) - len(tail):]])
    inner = pipe.replace(path=path, radius=radii, normal=pipe.normals[0])
    if path.closed or not (trim[start] or trim[end]):
        return inner
    if trim[start] + trim[end] >= path.length:
        raise InputError(f"closed ends {wall:g} thick leave no bore in a pipe "
                         f"{path.length:g} long; use a thinner wall or open ends", key="wall")
    return inner.trimmed(trim[start], trim[end])


class Hollow:
    """A part that adds outer solids and cuts bores; subclasses give :meth:`solids`."""

    def mesh(self):
        """The part on its own: a closed solid (with voids where ends are closed)."""
        bodies, bores = self.solids()
        return carve(bodies, bores, self.attributes["kind"], attributes=self.attributes)


def _members(args, kind, name, keyword):
    """The members of a Junction or HollowChain: given as arguments (``splice``'s
    convention), or, deprecated, as one list."""
    if keyword is not None:
        return tuple(keyword)
    if len(args) == 1 and not isinstance(args[0], kind) and hasattr(args[0], "__iter__"):
        warnings.warn(f"{name}([...]) with a list is deprecated: pass the pipes as arguments, "
                      f"{name}(*pipes, ...), as cadpipe.splice(*pipes) takes them",
                      DeprecationWarning, stacklevel=3)
        return tuple(args[0])
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
        Wall thickness, less than the pipe's smallest radius.
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
    def bore(self) -> Pipe:
        """The :class:`Pipe` cut out of the outer one (see :func:`bore`)."""
        return bore(self.pipe, self.wall, *self.ends)

    def solids(self) -> tuple[list[Mesh], list[Mesh]]:
        """What an assembly adds and what it cuts.

        Returns
        -------
        solids, bores : list of Mesh
            ``[outer mesh]`` and ``[bore mesh]``.
        """
        return [self.pipe.mesh()], [self.bore.mesh()]

    @property
    def attributes(self) -> Mapping[str, Any]:
        """Read-only mapping of the parameters that made this part."""
        return _deprecated.Attributes({**self.pipe.attributes, "kind": "hollow pipe",
                                       "wall": self.wall, "ends": "/".join(self.ends)},
                                      "HollowPipe.attributes")


@dataclass(frozen=True, eq=False, init=False)
class Junction(Hollow):
    """Hollow pipes joined into one part (a T, a Y, any branching).

    ``Junction(*hollow_pipes)``: the union of every outer solid minus the union of
    every bore, so each bore runs through the others' walls and the channels
    connect. Give an end that meets another pipe ``ends="open"`` so its bore reaches
    into that pipe's bore. (A single list, ``Junction([a, b])``, still works for this
    release, with a :class:`DeprecationWarning`.)
    """

    pipes: tuple[HollowPipe, ...]

    def __init__(self, *hollow_pipes: HollowPipe, pipes=None):
        members = _members(hollow_pipes, HollowPipe, "Junction", pipes)
        if not members or not all(isinstance(p, HollowPipe) for p in members):
            raise InputError("expected one or more cadpipe.HollowPipe", key="pipes")
        object.__setattr__(self, "pipes", members)

    def replace(self, **changes) -> "Junction":
        """This junction with some settings changed (``pipes=`` a sequence)."""
        return dataclasses.replace(self, **changes)

    def __repr__(self):
        return f"<cadpipe.Junction of {len(self.pipes)} hollow pipes>"

    def solids(self):
        """``(outer meshes, bore meshes)`` of every pipe."""
        outer, bores = zip(*(p.solids() for p in self.pipes))
        return [m for ms in outer for m in ms], [m for ms in bores for m in ms]

    @property
    def attributes(self) -> Mapping[str, Any]:
        """Read-only mapping of the parameters that made this part."""
        return _deprecated.Attributes({"kind": "junction", "pipes": len(self.pipes),
                                       "wall": max(p.wall for p in self.pipes)},
                                      "Junction.attributes")


@dataclass(frozen=True, eq=False, init=False)
class HollowChain(Hollow):
    """Pipes spliced into one chain (:func:`cadpipe.splice`) with a wall ``wall`` thick.

    ``HollowChain(*pipes, wall=..., ends=..., transition=..., closed=...)``, the
    pipes as :func:`~cadpipe.splice` takes them. The outer chain minus the chain of
    bores. The pipes first give up room for the transitions the way
    :func:`~cadpipe.splice` does, so both chains splice between the same end points
    and tangents and each bore transition runs inside its outer one, ``wall`` in
    from it. ``ends`` applies to the chain's two ends; a closed chain has none. (The
    0.1 form ``HollowChain([p, q], wall, ...)`` still works for this release, with a
    :class:`DeprecationWarning`.)
    """

    pipes: tuple[Pipe, ...]
    wall: float
    ends: tuple[str, str] | str = "open"
    transition: str = "lcm"
    closed: bool = False

    def __init__(self, *args, pipes=None, wall=None, ends="open", transition="lcm",
                 closed=False):
        if pipes is None and args and not isinstance(args[0], Pipe) \
                and hasattr(args[0], "__iter__"):
            old = dict(zip(("wall", "ends", "transition", "closed"), args[1:]))
            args = args[:1]
            wall, ends = old.get("wall", wall), old.get("ends", ends)
            transition, closed = old.get("transition", transition), old.get("closed", closed)
        members = _members(args, Pipe, "HollowChain", pipes)
        if not members or not all(isinstance(p, Pipe) for p in members):
            raise InputError("expected one or more cadpipe.Pipe", key="pipes")
        if wall is None:
            raise InputError("give the wall thickness: HollowChain(*pipes, wall=...)", key="wall")
        set_ = partial(object.__setattr__, self)
        set_("pipes", members)
        set_("wall", _wall(wall, members))
        set_("ends", _ends(ends))
        set_("transition", as_choice(transition, "transition", TRANSITIONS))
        set_("closed", bool(closed))

    def replace(self, **changes) -> "HollowChain":
        """This chain with some settings changed (``pipes=`` a sequence)."""
        return dataclasses.replace(self, **changes)

    def __repr__(self):
        return f"<cadpipe.HollowChain of {len(self.pipes)} pipes, wall {self.wall:g}>"

    def solids(self):
        """``([spliced outer pipes], [spliced bores])``."""
        from cadpipe.geometry.splice import make_room, splice

        outers = make_room(list(self.pipes), self.closed)
        last = len(outers) - 1
        open_ends = not self.closed
        bores = [bore(p, self.wall, self.ends[0] if i == 0 and open_ends else "flush",
                      self.ends[1] if i == last and open_ends else "flush")
                 for i, p in enumerate(outers)]
        options = {"transition": self.transition, "closed": self.closed}
        return [splice(*outers, **options)], [splice(*bores, **options)]

    @property
    def attributes(self) -> Mapping[str, Any]:
        """Read-only mapping of the parameters that made this part."""
        return _deprecated.Attributes({"kind": "hollow chain", "pipes": len(self.pipes),
                                       "wall": self.wall, "ends": "/".join(self.ends),
                                       "transition": self.transition, "closed": self.closed},
                                      "HollowChain.attributes")
