"""cadpipe's own part kinds for spec files, registered like a plugin's.

Each is a thin function from a spec table to an API object: its keyword
parameters are the table's keys and their annotations the accepted types (see
:mod:`cadpipe.io.spec`). They are found through the ``cadpipe.io.parts`` entry points
declared in ``pyproject.toml``.
"""

from cadpipe.solids import primitives
from cadpipe._validate import as_positive
from cadpipe.errors import InputError
from cadpipe.solids.hollow import HollowChain, HollowPipe, Junction
from cadpipe.geometry.pipe import Pipe
from cadpipe.io.spec import Number
from cadpipe.geometry.splice import splice


def pipe(ctx, *, path: list | str | dict, radius: Number | list, sides: int | None = None,
         tolerance: Number | None = None, caps: str = "flat", envelope: bool = False,
         corners: str = "miter", bend_radius: Number | None = None, frame: str = "rmf",
         wall: Number | None = None, ends: str | list = "open", miter_limit: Number = 4.0,
         strict: bool = False):
    """A tube along ``path``; hollow with walls ``wall`` thick when ``wall`` is given."""
    tube = Pipe(ctx.path(path), radius, sides, tolerance=tolerance, caps=caps,
                envelope=envelope, corners=corners, bend_radius=bend_radius, frame=frame,
                miter_limit=miter_limit, strict=strict)
    if wall is None:
        if ends != "open":
            raise InputError("ends: only a hollow pipe has open or closed ends; give wall too")
        return tube
    return HollowPipe(tube, wall, ends)


def _pipe_tables(ctx, tables, shared):
    """Each table of ``pipes`` as a ``pipe`` part, its missing keys taken from ``shared``."""
    if not tables:
        raise InputError("pipes: expected at least one pipe table")
    return [ctx.call(pipe, {**shared, **entry} if isinstance(entry, dict) else entry,
                     f"pipes[{i}]") for i, entry in enumerate(tables)]


def junction(ctx, *, pipes: list, wall: Number, ends: str | list = "open",
             sides: int | None = None, caps: str = "flat"):
    """Hollow pipes joined into one part; each entry of ``pipes`` is a ``pipe`` table
    whose ``wall``, ``ends``, ``sides`` and ``caps`` default to the junction's."""
    as_positive(wall, "wall")
    return Junction(*_pipe_tables(ctx, pipes, {"wall": wall, "ends": ends, "sides": sides,
                                               "caps": caps}))


def chain(ctx, *, pipes: list, transition: str = "lcm", closed: bool = False,
          wall: Number | None = None, ends: str | list = "open", sides: int | None = None,
          caps: str = "flat"):
    """Pipes spliced end to start into one solid (:func:`cadpipe.splice`); hollow with
    walls ``wall`` thick when given. Entries of ``pipes`` are ``pipe`` tables without
    ``wall`` whose ``sides`` and ``caps`` default to the chain's."""
    tubes = _pipe_tables(ctx, pipes, {"sides": sides, "caps": caps})
    for i, tube in enumerate(tubes):
        if not isinstance(tube, Pipe):
            raise InputError(f"pipes[{i}].wall: give the wall on the chain, not on its pipes")
    if wall is None:
        if ends != "open":
            raise InputError("ends: only a hollow chain has open or closed ends; give wall too")
        return splice(*tubes, transition=transition, closed=closed)
    return HollowChain(*tubes, wall=wall, ends=ends, transition=transition, closed=closed)


def box(ctx, *, size: Number | list, center: bool = True):
    return primitives.box(size, center)


def cylinder(ctx, *, radius: Number, height: Number, sides: int = 32, center: bool = True):
    return primitives.cylinder(radius, height, sides, center)


def sphere(ctx, *, radius: Number, segments: int = 32):
    return primitives.sphere(radius, segments)


def mesh(ctx, *, file: str, snap_tolerance: Number | None = None):
    """A closed solid read from a mesh file in the spec's folder."""
    return primitives.imported(ctx.file_path(file, "file"), snap_tolerance)
