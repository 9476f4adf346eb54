"""Printable pipes with a wall: outer solids minus bores.

Two hollow tubes must never be unioned as they are: each wall plugs the other's
bore and leaves sealed voids. A hollow part therefore hands an assembly two lists
(:meth:`HollowPipe.solids`): the outer solids it adds and the bores it cuts, and
the assembly computes ``union(outer solids) - union(bores)``. A
:class:`Junction` (T, Y, any branching) is several hollow pipes treated as one
part. Bores of open ends run a little past the pipe, so the cut leaves no skin.
"""

from functools import cached_property

import numpy as np

from ._validate import as_choice, as_positive
from .booleans import carve
from .errors import InputError
from .path import Path
from .pipe import Pipe

END_STYLES = ("open", "closed")


def _ends(ends):
    """``(start, end)`` styles from one style or a pair."""
    pair = (ends, ends) if isinstance(ends, str) else tuple(ends)
    if len(pair) != 2:
        raise InputError(f"ends: expected 'open', 'closed' or a pair of them, got {ends!r}")
    return tuple(as_choice(e, "ends", END_STYLES) for e in pair)


def _stretch(path, radii, start, stop):
    """Points and radii of ``path`` between arc lengths ``start`` and ``stop``.

    Values outside ``[0, length]`` extend the path straight along its end directions;
    values inside trim it. Radii are interpolated (and held constant past the ends).
    """
    s = path.arc_length
    inner = (s > start) & (s < stop)

    def point_at(t):
        if t <= 0:
            return path.points[0] + t * path.directions[0]
        if t >= path.length:
            return path.points[-1] + (t - path.length) * path.directions[-1]
        return np.array([np.interp(t, s, path.points[:, k]) for k in range(3)])

    points = np.vstack([point_at(start), path.points[inner], point_at(stop)])
    ends = np.interp([start, stop], s, radii)
    return points, np.concatenate([[ends[0]], radii[inner], [ends[1]]])


class Hollow:
    """A part that adds outer solids and cuts bores; subclasses give :meth:`solids`."""

    def mesh(self):
        """The part on its own: a closed solid (with voids where ends are closed)."""
        bodies, bores = self.solids()
        return carve(bodies, bores, self.attributes()["kind"], attributes=self.attributes())


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
        self.wall = float(as_positive(wall, "wall"))
        thinnest = float(pipe.radii.min())
        if self.wall >= thinnest:
            raise InputError(f"wall: {self.wall:g} must be less than the pipe's smallest radius "
                             f"{thinnest:g}")
        self.ends = _ends(ends)

    def __repr__(self):
        ends = "/".join(self.ends)
        return f"<cadpipe.HollowPipe wall {self.wall:g}, ends {ends}, {self.pipe!r}>"

    @cached_property
    def bore(self):
        """The :class:`Pipe` cut out of the outer one, rings aligned with its rings."""
        outer = self.pipe
        path, radii = outer.path, outer.radii - self.wall
        first = 0
        if not outer.closed:
            reach = outer.ring_radii.max() if outer.caps == "round" else 0.0

            def past(style):            # how far the bore runs past an end (< 0: short of it)
                if style == "open":
                    return self.wall + reach
                return -self.wall if outer.caps == "flat" else 0.0

            start, stop = -past(self.ends[0]), path.length + past(self.ends[1])
            if stop <= start:
                raise InputError(f"wall: closed ends {self.wall:g} thick leave no bore in a "
                                 f"pipe {path.length:g} long; use a thinner wall or open ends")
            points, radii = _stretch(path, radii, start, stop)
            path = Path(points)
            first = min(int(np.searchsorted(outer.path.arc_length, max(start, 0.0))),
                        len(outer.path) - 1)
        return Pipe(path, radii, outer.sides, caps=outer.caps, envelope=outer.envelope,
                    frame=outer.frame, normal=outer.normals[first],
                    miter_limit=outer.miter_limit, cap_segments=outer.cap_segments,
                    repair=outer.repair)

    def solids(self):
        """``([outer mesh], [bore mesh])``: what an assembly adds and what it cuts."""
        return [self.pipe.mesh()], [self.bore.mesh()]

    def attributes(self):
        return {**self.pipe.attributes(), "kind": "hollow pipe", "wall": self.wall,
                "ends": "/".join(self.ends)}


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

    def attributes(self):
        return {"kind": "junction", "pipes": len(self.pipes),
                "wall": max(p.wall for p in self.pipes)}
