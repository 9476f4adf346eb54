"""cadpipe's own part kinds for spec files, registered like a plugin's.

Each is a thin function from a spec table to an API object: its keyword
parameters are the table's keys and their annotations the accepted types (see
:mod:`cadpipe.spec.reader`). The keys of ``pipe``, ``box``, ``cylinder``, ``sphere`` and
``mesh`` are derived from the signature of the API call they make
(:class:`~cadpipe.Pipe`, :mod:`cadpipe.solids.primitives`), so every option of the
API is a spec key under the same name, and a new option appears in specs without
an edit here. :data:`SPEC_TYPES` says which values a spec may give for the known
keys; a key it does not list takes any value and is checked by the API itself.
They are registered in :data:`cadpipe.spec.reader.part_kinds` when this module is
imported (``import cadpipe.spec`` does), so they exist without installing the package.
"""

import inspect

from cadpipe._validate import as_positive
from cadpipe.errors import CadpipeError, InputError
from cadpipe.geometry.pipe import Pipe
from cadpipe.geometry.splice import splice
from cadpipe.spec.reader import Number, part_kinds
from cadpipe.solids import primitives
from cadpipe.solids.hollow import HollowChain, HollowPipe, Junction

#: the values a spec may give for an API argument of this name
SPEC_TYPES = {
    "path": list | str | dict, "radius": Number | list, "sides": int | None,
    "tolerance": Number | None, "caps": str, "envelope": bool, "corners": str,
    "frame": str, "normal": list | None,
    "end_normal": list | None, "miter_limit": Number, "cap_segments": int | None,
    "strict": bool, "size": Number | list, "center": bool,
    "height": Number, "segments": int, "file": str, "snap_tolerance": Number | None,
    "wall": Number | None, "ends": str | list,
}


def _keys(api, extra=()):
    """Keyword-only spec parameters mirroring ``api``'s public arguments, plus ``extra``."""
    found = [inspect.Parameter(p.name, inspect.Parameter.KEYWORD_ONLY, default=p.default,
                               annotation=SPEC_TYPES.get(p.name, inspect.Parameter.empty))
             for p in inspect.signature(api).parameters.values()
             if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)
             and not p.name.startswith("_")]
    return found + list(extra)


def _kind(api, build, extra=()):
    """A part kind for ``build(ctx, **keys)`` whose keys are ``api``'s arguments."""
    def kind(ctx, **keys):
        return build(ctx, **keys)

    context = inspect.Parameter("ctx", inspect.Parameter.POSITIONAL_OR_KEYWORD)
    kind.__signature__ = inspect.Signature([context, *_keys(api, extra)])
    kind.__name__ = kind.__qualname__ = getattr(api, "__name__", "kind").lower()
    kind.__doc__ = build.__doc__
    return kind


def _hollow_keys():
    return (inspect.Parameter("wall", inspect.Parameter.KEYWORD_ONLY, default=None,
                              annotation=SPEC_TYPES["wall"]),
            inspect.Parameter("ends", inspect.Parameter.KEYWORD_ONLY, default="open",
                              annotation=SPEC_TYPES["ends"]))


def _pipe(ctx, *, path, wall=None, ends="open", **options):
    """A tube along ``path`` (any :class:`~cadpipe.Pipe` argument is a key); hollow with
    walls ``wall`` thick when ``wall`` is given."""
    tube = Pipe(ctx.path(path), **options)
    if wall is None:
        if ends != "open":
            raise InputError("only a hollow pipe has open or closed ends; give wall too",
                             key="ends")
        return tube
    return HollowPipe(tube, wall, ends)


pipe = _kind(Pipe, _pipe, _hollow_keys())


def _pipe_tables(ctx, tables, shared):
    """Each table of ``pipes`` as a ``pipe`` part, its missing keys taken from ``shared``."""
    if not tables:
        raise InputError("expected at least one pipe table", key="pipes")
    shared = {k: v for k, v in shared.items() if v is not None}
    return [ctx.call(pipe, {**shared, **entry} if isinstance(entry, dict) else entry,
                     f"pipes[{i}]") for i, entry in enumerate(tables)]


def _group(api, build):
    """A part kind of several pipes: ``pipes`` (a list of ``pipe`` tables), ``api``'s own
    keyword arguments, and every other ``pipe`` key as a default for the tables (a table
    may override it), so a new option of the API is a key here too. ``build(ctx, tubes,
    **own)`` gets the tables and the defaults they take."""
    # the build's defaults win: a chain without a wall is a solid chain (splice)
    defaults = {n: p.default for n, p in inspect.signature(build).parameters.items()
                if p.kind is p.KEYWORD_ONLY and p.default is not p.empty}
    own = [p.replace(default=defaults.get(p.name, p.default)) for p in _keys(api)
           if p.name not in ("pipes", "pipe")]
    names = {p.name for p in own}
    shared = [p.replace(default=None) for p in pipe.__signature__.parameters.values()
              if p.kind is p.KEYWORD_ONLY and p.name not in names | {"path"}]

    def kind(ctx, *, pipes, **keys):
        return build(ctx, pipes, {k: v for k, v in keys.items() if k not in names},
                     **{k: v for k, v in keys.items() if k in names})

    context = inspect.Parameter("ctx", inspect.Parameter.POSITIONAL_OR_KEYWORD)
    tables = inspect.Parameter("pipes", inspect.Parameter.KEYWORD_ONLY, annotation=list)
    kind.__signature__ = inspect.Signature([context, tables, *own, *shared])
    kind.__name__ = kind.__qualname__ = build.__name__.strip("_")
    kind.__doc__ = build.__doc__
    return kind


def _junction(ctx, pipes, defaults, *, wall, ends="open"):
    """Hollow pipes joined into one part (:class:`~cadpipe.Junction`); each entry of
    ``pipes`` is a ``pipe`` table whose keys default to the junction's."""
    as_positive(wall, "wall")
    return Junction(*_pipe_tables(ctx, pipes, {**defaults, "wall": wall, "ends": ends}))


def _chain(ctx, pipes, defaults, *, wall=None, ends="open", transition="lcm", closed=False):
    """Pipes spliced end to start into one solid (:func:`cadpipe.splice`); hollow with
    walls ``wall`` thick when given (:class:`~cadpipe.HollowChain`). Entries of
    ``pipes`` are ``pipe`` tables without ``wall`` whose keys default to the chain's."""
    tubes = _pipe_tables(ctx, pipes, defaults)
    for i, tube in enumerate(tubes):
        if not isinstance(tube, Pipe):
            raise InputError("give the wall on the chain, not on its pipes",
                             key=f"pipes[{i}].wall")
    if wall is None:
        if ends != "open":
            raise InputError("only a hollow chain has open or closed ends; give wall too",
                             key="ends")
        return splice(*tubes, transition=transition, closed=closed)
    return HollowChain(*tubes, wall=wall, ends=ends, transition=transition, closed=closed)


junction = _group(HollowPipe, _junction)
chain = _group(HollowChain, _chain)


def _mesh(ctx, *, file, **options):
    """A closed solid read from a mesh file in the spec's folder."""
    try:
        return primitives.imported(ctx.file_path(file, "file"), **options)
    except CadpipeError as exc:      # about the mesh file: name it at the spec's key
        if exc.key or not exc.file:
            raise
        raise type(exc)(f"{file}: {exc.message}", key="file") from None


box = _kind(primitives.box, lambda ctx, **keys: primitives.box(**keys))
cylinder = _kind(primitives.cylinder, lambda ctx, **keys: primitives.cylinder(**keys))
sphere = _kind(primitives.sphere, lambda ctx, **keys: primitives.sphere(**keys))
mesh = _kind(primitives.imported, _mesh)
mesh.__signature__ = mesh.__signature__.replace(parameters=[
    p.replace(name="file", annotation=str) if p.name == "path" else p
    for p in mesh.__signature__.parameters.values()])

#: every built-in kind by its spec name
KINDS = {"pipe": pipe, "junction": junction, "chain": chain, "box": box,
         "cylinder": cylinder, "sphere": sphere, "mesh": mesh}
for _name, _kind_of in KINDS.items():
    part_kinds.register(_name, _kind_of)
