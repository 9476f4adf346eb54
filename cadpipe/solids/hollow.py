"""Printable pipes with a wall: outer solids minus bores.

Two hollow tubes must never be unioned as they are: each wall plugs the other's
bore and leaves sealed voids. A hollow part therefore hands an assembly two lists
(:meth:`HollowPipe.solids`): the outer solids it adds and the bores it cuts, and
the assembly computes ``union(outer solids) - union(bores)``. A
:class:`Junction` (T, Y, any branching) is several hollow pipes treated as one
part; a :class:`HollowChain` is spliced pipes with a spliced bore. Bores of open
ends run a little past the pipe, so the cut leaves no skin.
"""

from functools import cached_property

import numpy as np

from cadpipe import _deprecated
from cadpipe._validate import as_choice, as_positive
from cadpipe.solids.booleans import carve
from cadpipe.errors import InputError
from cadpipe.geometry.path import Path
from cadpipe.geometry.pipe import Pipe

END_STYLES = ("open", "closed")


def _ends(ends):
    """``(start, end)`` styles from one style or a pair."""
    pair = (ends, ends) if isinstance(ends, str) else tuple(ends)
    if len(pair) != 2:
        raise InputError(f"ends: expected 'open', 'closed' or a pair of them, got {ends!r}")
    return tuple(as_choice(e, "ends", END_STYLES) for e in pair)


def _wall(wall, pipes):
    """``wall`` as a float, thinner than every pipe's smallest radius."""
    wall = float(as_positive(wall, "wall"))
    thinnest = min(float(p.radii.min()) for p in pipes)
    if wall >= thinnest:
        raise InputError(f"wall: {wall:g} must be less than the smallest pipe radius "
                         f"{thinnest:g}")
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
    inner = Pipe(path, radii, pipe.sides, caps=pipe.caps, envelope=pipe.envelope,
                 frame=pipe.frame, normal=pipe.normals[0], end_normal=pipe.end_normal,
                 miter_limit=pipe.miter_limit, cap_segments=pipe.cap_segments,
                 strict=pipe.strict)
    if path.closed or not (trim[start] or trim[end]):
        return inner
    if trim[start] + trim[end] >= path.length:
        raise InputError(f"wall: closed ends {wall:g} thick leave no bore in a pipe "
                         f"{path.length:g} long; use a thinner wall or open ends")
    return inner.trimmed(trim[start], trim[end])


class Hollow:
    """A part that adds outer solids and cuts bores; subclasses give :meth:`solids`."""

    def mesh(self):
        """The part on its own: a closed solid (with voids where ends are closed)."""
        bodies, bores = self.solids()
        return carve(bodies, bores, self.attributes["kind"], attributes=self.attributes)


class HollowPipe(Hollow):
    """A pipe with a wall of thickness ``wall``: its outer solid minus its bore.

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

    def __init__(self, pipe, wall, ends="open"):
        if not isinstance(pipe, Pipe):
            raise InputError(f"pipe: expected a cadpipe.Pipe, got {type(pipe).__name__}")
        self.pipe = pipe
        self.wall = _wall(wall, [pipe])
        self.ends = _ends(ends)

    def __repr__(self):
        ends = "/".join(self.ends)
        return f"<cadpipe.HollowPipe wall {self.wall:g}, ends {ends}, {self.pipe!r}>"

    @cached_property
    def bore(self):
        """The :class:`Pipe` cut out of the outer one (see :func:`bore`)."""
        return bore(self.pipe, self.wall, *self.ends)

    def solids(self):
        """``([outer mesh], [bore mesh])``: what an assembly adds and what it cuts."""
        return [self.pipe.mesh()], [self.bore.mesh()]

    @property
    def attributes(self):
        """Read-only mapping of the parameters that made this part."""
        return _deprecated.Attributes({**self.pipe.attributes, "kind": "hollow pipe",
                                       "wall": self.wall, "ends": "/".join(self.ends)},
                                      "HollowPipe.attributes")


class Junction(Hollow):
    """Hollow pipes joined into one part (a T, a Y, any branching).

    The union of every outer solid minus the union of every bore, so each bore
    runs through the others' walls and the channels connect. Give an end that
    meets another pipe ``ends="open"`` so its bore reaches into that pipe's bore.
    """

    def __init__(self, pipes):
        pipes = tuple(pipes)
        if not pipes or not all(isinstance(p, HollowPipe) for p in pipes):
            raise InputError("pipes: expected one or more cadpipe.HollowPipe")
        self.pipes = pipes

    def __repr__(self):
        return f"<cadpipe.Junction of {len(self.pipes)} hollow pipes>"

    def solids(self):
        """``(outer meshes, bore meshes)`` of every pipe."""
        outer, bores = zip(*(p.solids() for p in self.pipes))
        return [m for ms in outer for m in ms], [m for ms in bores for m in ms]

    @property
    def attributes(self):
        """Read-only mapping of the parameters that made this part."""
        return _deprecated.Attributes({"kind": "junction", "pipes": len(self.pipes),
                                       "wall": max(p.wall for p in self.pipes)},
                                      "Junction.attributes")


class HollowChain(Hollow):
    """Pipes spliced into one chain (:func:`cadpipe.splice`) with a wall ``wall`` thick.

    The outer chain minus the chain of bores. The pipes first give up room for the
    transitions the way :func:`~cadpipe.splice` does, so both chains splice between
    the same end points and tangents and each bore transition runs inside its outer
    one, ``wall`` in from it. ``ends`` applies to the chain's two ends; a closed chain
    has none.
    """

    def __init__(self, pipes, wall, ends="open", transition="lcm", closed=False):
        pipes = tuple(pipes)
        if not pipes or not all(isinstance(p, Pipe) for p in pipes):
            raise InputError("pipes: expected one or more cadpipe.Pipe")
        self.pipes = pipes
        self.wall = _wall(wall, pipes)
        self.ends = _ends(ends)
        self.transition = transition
        self.closed = bool(closed)

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
    def attributes(self):
        """Read-only mapping of the parameters that made this part."""
        return _deprecated.Attributes({"kind": "hollow chain", "pipes": len(self.pipes),
                                       "wall": self.wall, "ends": "/".join(self.ends),
                                       "transition": self.transition, "closed": self.closed},
                                      "HollowChain.attributes")
