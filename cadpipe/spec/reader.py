"""Spec files: an assembly written as TOML or JSON, read into the same Python API calls.

One schema for both formats (see ``docs/spec.md``): ``name``, ``units``, ``parts``
(each with a ``kind`` looked up in :data:`part_kinds`), and
``outputs``; a robot cell adds ``robot`` (a posed URDF arm, whose links join the
assembly as parts), ``allow`` and ``check``, which :func:`cadpipe.spec.world_from_spec`
turns into a collision world. Reading a spec only parses data and calls registered
functions; nothing in it is executed.

A part kind is a function ``kind(ctx, *, key=default, ...)``: its keyword
parameters are the keys a spec may give, and their annotations the accepted
types, so unknown keys, missing keys and wrong types are reported before the
function runs. Errors carry their key as a field (``InputError(..., key="radius")``);
each table the loader descends into prefixes its own key with
:meth:`~cadpipe.errors.CadpipeError.at` as the error passes outward, so every error
reads ``<file>: parts[3].radius: ...``, whichever layer raised it. ``ctx``
(:class:`SpecContext`) resolves files and paths relative to the spec's folder.

What a spec may touch: it reads the files it names (CSV paths, meshes, URDF/SRDF),
relative to its folder or absolute, and only regular files; it writes only its
``outputs``, which must lie inside the output folder (the spec's folder unless the
caller names another): absolute names, ``..`` and links that lead out are refused.
"""

import inspect
import json
import os
import re
import tomllib
import typing
from dataclasses import dataclass, field
from pathlib import Path as FilePath, PurePath

import numpy as np

from cadpipe import limits
from cadpipe._validate import as_choice, as_input_file
from cadpipe.errors import CadpipeError, InputError, LimitError, SpecError, shown
from cadpipe.core.registry import Registry
from cadpipe.core.transform import as_matrix, placement

if typing.TYPE_CHECKING:
    from cadpipe.solids.assembly import Assembly

#: annotation for a number in a part kind's signature (TOML and JSON keep ints apart)
Number = int | float

#: the part kinds a spec's ``kind`` names: cadpipe's own (:mod:`cadpipe.spec.parts`) and
#: plugins' (entry-point group ``cadpipe.parts``)
part_kinds = Registry("cadpipe.parts", "part kind")

_TYPE_NAMES = {bool: "true or false", int: "a whole number", float: "a number", str: "a string",
               list: "a list", dict: "a table"}
_COMMON_KEYS = ("name", "kind", "op", "color", "transform")
_CONTROL = re.compile(r"[\x00-\x1f\x7f]")


def _describe(annotation):
    kinds = [a for a in typing.get_args(annotation) or (annotation,) if a is not type(None)]
    if float in kinds and int in kinds:
        kinds.remove(int)
    return " or ".join(_TYPE_NAMES.get(a, getattr(a, "__name__", str(a))) for a in kinds)


def _accepts(value, annotation):
    if annotation is inspect.Parameter.empty:
        return True
    allowed = typing.get_args(annotation) or (annotation,)
    if isinstance(value, bool) and bool not in allowed:
        return False            # a bool is an int to Python, never a number in a spec
    return isinstance(value, allowed)


def _located(exc, key):
    """``exc`` as a spec error about ``key`` (relative to the enclosing table).

    A :class:`LimitError` stays one (the caller may raise the limit); any other
    cadpipe error becomes a :class:`SpecError` with the same fields.
    """
    if not isinstance(exc, (SpecError, LimitError)):
        moved = SpecError(exc.message, key=exc.key, part=exc.part, file=exc.file,
                          index=exc.index, fix=exc.fix)
        moved.in_spec, moved._part_located = exc.in_spec, exc._part_located
        moved.__cause__, moved.__suppress_context__ = exc.__cause__, True
        exc = moved
    return exc.at(key or None, spec=True)


class SpecContext:
    """What a part kind gets besides its keys: the spec's file and folder, and helpers
    that resolve files and paths there and validate nested tables the same way."""

    def __init__(self, file, output_folder=None, budgets=None):
        self.file = FilePath(file)
        self.budgets = dict(budgets or {})      # the caller's, over the spec's own
        self.folder = self.file.parent
        self.output_folder = self.folder if output_folder is None else FilePath(output_folder)

    def error(self, key, message):
        """A :class:`SpecError` about ``key`` of the table being read ("" for itself)."""
        return SpecError(message, key=key or None)

    def call(self, func, table, key="", ignore=()):
        """``func(ctx, **table)`` after checking ``table`` against ``func``'s signature.

        ``key`` names the table; any cadpipe error raised inside gets it prefixed to
        its key path. Keys in ``ignore`` are allowed but not passed on.
        """
        try:
            return self._call(func, table, ignore)
        except CadpipeError as exc:
            raise _located(exc, key) from exc.__cause__

    def _call(self, func, table, ignore):
        if not isinstance(table, dict):
            raise self.error("", f"expected a table, got {shown(table)}")
        params = list(inspect.signature(func, eval_str=True).parameters.values())[1:]
        named = {p.name: p for p in params if p.kind is p.KEYWORD_ONLY}
        open_ended = any(p.kind is p.VAR_KEYWORD for p in params)
        for name, value in table.items():
            if name in ignore:
                continue
            if name not in named:
                if open_ended:
                    continue
                known = ", ".join(sorted(set(named) | set(ignore)))
                raise self.error(name, f"unknown key; expected one of: {known}")
            if not _accepts(value, named[name].annotation):
                raise self.error(name, f"expected {_describe(named[name].annotation)}, "
                                       f"got {shown(value)}")
        for name, p in named.items():
            if p.default is p.empty and name not in table:
                raise self.error(name, f"missing; expected {_describe(p.annotation)}")
        return func(self, **{k: v for k, v in table.items() if k not in ignore})

    def file_path(self, value, key):
        """An existing regular file named by ``value``, relative to the spec's folder."""
        if not isinstance(value, str) or not value or "\x00" in value:
            raise InputError(f"expected a file name, got {shown(value)}", key=key)
        return as_input_file(self.folder / value, key=key, shown_as=value)

    def output_path(self, value, key):
        """Where output ``value`` goes: inside :attr:`output_folder`, never outside it.

        Absolute names, ``..`` and names with control characters are refused, and so
        is a name whose existing folders or file are links leading out of the folder.
        """
        if not value or _CONTROL.search(value):
            raise InputError(f"expected a file name without control characters, got "
                             f"{shown(value)}", key=key)
        name = PurePath(value)
        if name.is_absolute() or ".." in name.parts:
            raise InputError(f"{shown(value)} leaves the output folder; a spec writes only "
                             f"inside {self.output_folder} (give a name relative to it)",
                             key=key)
        target = self.output_folder / name
        root = self.output_folder.resolve()
        if not target.resolve().is_relative_to(root):
            raise InputError(f"{shown(value)} is a link leading out of the output folder "
                             f"{self.output_folder}; a spec writes only inside it", key=key)
        return target

    def path(self, value, key="path"):
        """A :class:`cadpipe.Path` from a list of points, a CSV file name, or a table."""
        from cadpipe.geometry.path import Path

        if isinstance(value, dict):
            return self.call(_path_table, value, key)
        points = _csv_points(self.file_path(value, key), key) if isinstance(value, str) \
            else _points(value, key)
        try:
            return Path(points)
        except CadpipeError as exc:
            raise exc.at(key) from exc.__cause__


def _points(value, key):
    from cadpipe._validate import as_points

    return as_points(value, key, min_count=2)


def _is_number(text):
    try:
        float(text)
    except ValueError:
        return False
    return True


def _csv_points(file, key):
    """Rows ``x,y,z`` of a CSV file (UTF-8, a byte-order mark allowed).

    ``#`` comments and blank lines are skipped; the first row is a header when a
    field of it is not a number. Any other row must hold three finite numbers: a row
    with NaN or inf is an error naming its line, never taken for a header.
    """
    try:
        text = file.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError:
        raise InputError(f"{file.name}: not a text file; expected rows of x,y,z numbers",
                         key=key) from None
    lines = [(n, line) for n, line in enumerate(text.splitlines(), 1)
             if line.strip() and not line.lstrip().startswith("#")]
    if lines and not all(_is_number(f) for f in lines[0][1].split(",")):
        lines = lines[1:]                          # a header: some field is not a number
    try:
        points = np.loadtxt([line for _, line in lines], delimiter=",", ndmin=2)
    except ValueError as exc:
        raise InputError(f"{file.name}: expected rows of x,y,z numbers ({exc})",
                         key=key) from None
    if points.ndim == 2 and points.shape[1] == 3 and len(points):
        bad = ~np.isfinite(points).all(axis=1)
        if bad.any():
            row = int(np.argmax(bad))
            raise InputError(f"{file.name}: line {lines[row][0]} is not three finite numbers "
                             f"({shown(lines[row][1])})", key=key, index=row)
    try:
        return _points(points, None)
    except CadpipeError as exc:
        raise InputError(f"{file.name}: {exc.message}", key=key, index=exc.index) from None


def _path_table(ctx, *, points: list | str, closed: bool = False, spline: bool = False,
                step: Number | None = None, tolerance: Number | None = None):
    """``path = {points = ..., spline = true, step = 0.01}``: a fitted or plain path."""
    from cadpipe.geometry.path import Path

    pts = _csv_points(ctx.file_path(points, "points"), "points") if isinstance(points, str) \
        else _points(points, "points")
    if spline:
        return Path.spline(pts, step, tolerance=tolerance, closed=closed)
    if step is not None or tolerance is not None:
        raise InputError("only a fitted path has one; add spline = true",
                         key="step" if step is not None else "tolerance")
    return Path(pts, closed=closed)


def _transform_table(ctx, *, translate: list | Number = (0, 0, 0),
                     rotate: list | Number = (0, 0, 0), scale: list | Number = 1.0):
    """``transform = {translate = ..., rotate = ..., scale = ...}``: see :func:`placement`."""
    return placement(translate, rotate, scale)


def _matrix(ctx, transform):
    """A ``transform`` key's 4x4 matrix (None when absent): a matrix or a table."""
    if isinstance(transform, dict):
        return ctx.call(_transform_table, transform, "transform")
    return None if transform is None else as_matrix(transform)


def _placement(ctx, *, kind: str, name: str | None = None, op: str = "add",
               color: str | list | None = None, transform: list | dict | None = None):
    """The keys every part has: how it is named, placed, coloured and combined."""
    from cadpipe.solids.assembly import OPERATIONS

    return {"name": name, "op": as_choice(op, "op", OPERATIONS), "color": color,
            "transform": _matrix(ctx, transform)}


def _output(ctx, *, file: str, mode: str | None = None, **options):
    """An ``outputs`` entry: its file, mode and any option of :meth:`Assembly.export`
    (``layout``, ``units``, the format's own; see :func:`export_options`)."""
    from cadpipe.solids.assembly import EXPORT_MODES, export_options

    if mode is not None:
        as_choice(mode, "mode", EXPORT_MODES)
    path = ctx.output_path(file, "file")
    return path, mode, export_options(path, options)


@dataclass(frozen=True)
class PosedRobot:
    """The ``robot`` table: a loaded :class:`~cadpipe.collision.Robot`, its joint values
    by name, its base pose (4x4, rigid; None: the origin), the group its links share
    and their colour."""

    robot: object
    joints: dict
    transform: np.ndarray
    group: str
    color: object = None

    def link_poses(self):
        """World pose of every link with geometry."""
        return self.robot.link_poses(self.joints, self.transform)


@dataclass(frozen=True)
class Cell:
    """What a collision check needs besides the geometry (``cadpipe collide``).

    ``objects`` names the spec's added parts (each one collision object), ``robot``
    is a :class:`PosedRobot` or None, ``allow`` holds ``(a, b, reason)`` triples and
    ``check`` the keyword arguments of :meth:`~cadpipe.CollisionWorld.check`.
    """

    objects: tuple
    robot: PosedRobot = None
    allow: tuple = ()
    check: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Spec:
    """A read spec: its file, the assembly it describes (the parts, then the robot's
    posed links), its outputs as ``(path, mode, options)`` (mode None: chosen by the
    suffix; options for :meth:`~cadpipe.Assembly.export`), its :class:`Cell`, the key
    path of each part by name, and the budgets it sets (``max_triangles``, ... as
    :func:`cadpipe.limits.using` takes them)."""

    file: FilePath
    assembly: object
    outputs: tuple
    cell: Cell
    part_keys: dict = field(default_factory=dict)
    budgets: dict = field(default_factory=dict)

    def locate(self, exc: CadpipeError) -> CadpipeError:
        """``exc``, raised later about one of this spec's parts, at that part's key."""
        return exc.at(self.part_keys.get(exc.part), part=exc.part, file=self.file,
                      spec=exc.part in self.part_keys)


def parse(file):
    """The spec file's table, refusing what would exhaust the parser: a file larger
    than a spec can be, numbers too long to convert, nesting too deep to walk."""
    if not file.exists() and not file.is_symlink():
        raise SpecError("no such spec file", file=file)
    try:
        file = as_input_file(file, "spec file")
    except CadpipeError as exc:
        raise SpecError(exc.message, file=exc.file) from None
    size = file.stat().st_size
    limits.check("max_spec_bytes", size, "reading this spec", file=file)
    suffix = file.suffix.lower()
    if suffix not in (".toml", ".json"):
        raise SpecError(f"unknown spec format {shown(file.suffix)}; use .toml or .json",
                        file=file)
    raw = file.read_bytes()
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise SpecError(f"not valid {suffix[1:].upper()}: not UTF-8 text ({exc.reason} at "
                        f"byte {exc.start})", file=file) from None
    longest = max((len(m) for m in re.findall(r"[0-9][0-9_]*", text)), default=0)
    limits.check("max_number_chars", longest, "a number in this spec", file=file)
    depth = limits.current().max_depth
    # dotted keys nest without brackets, and tomllib takes quadratic time over them
    if re.search(r"(?:[\w\"'-]+\s*\.\s*)" + f"{{{depth}}}", text):
        limits.check("max_depth", depth + 1, "a dotted key in this spec", at_least=True,
                     file=file)
    try:
        data = tomllib.loads(text) if suffix == ".toml" else json.loads(text)
    except (tomllib.TOMLDecodeError, json.JSONDecodeError) as exc:
        raise SpecError(f"not valid {suffix[1:].upper()}: {exc}", file=file) from None
    except RecursionError:
        data = None
    depth = _depth(data) if data is not None else limits.current().max_depth + 1
    limits.check("max_depth", depth, "this spec's nesting of tables and lists", at_least=True,
                 file=file)
    return data


def _depth(data):
    """How deeply lists and tables nest in ``data`` (without recursion)."""
    deepest, stack = 0, [(data, 0)]
    while stack:
        value, level = stack.pop()
        if isinstance(value, (dict, list)):
            deepest = max(deepest, level + 1)
            if deepest > limits.current().max_depth:
                return deepest
            stack.extend((v, level + 1) for v in (value.values() if isinstance(value, dict)
                                                   else value))
    return deepest


def _robot(ctx, *, urdf: str, srdf: str | None = None, joints: list | dict | None = None,
           transform: list | dict | None = None, group: str | None = None,
           color: str | list | None = None):
    """``[robot]``: a URDF arm posed by ``joints`` on a rigid base ``transform``."""
    from cadpipe.collision.robot import Robot
    from cadpipe.core.transform import is_rigid

    files = {"urdf": ctx.file_path(urdf, "urdf"),
             "srdf": None if srdf is None else ctx.file_path(srdf, "srdf")}
    try:
        robot = Robot.from_urdf(files["urdf"], files["srdf"])
    except SpecError as exc:          # about the URDF or SRDF file: name it in the message
        key = "srdf" if exc.file and files["srdf"] and exc.file == str(files["srdf"]) \
            else "urdf"
        raise InputError(f"{exc.file}: {exc.message}" if exc.file else exc.message,
                         key=key) from None
    base = _matrix(ctx, transform)
    if base is not None and not is_rigid(base):
        raise InputError("a robot's base only rotates and translates; remove scale",
                         key="transform")
    values = dict(zip((j.name for j in robot.joints), robot.joint_array(joints)[0].tolist()))
    return PosedRobot(robot, {k: values[k] for k in robot.actuated}, base,
                      robot.name if group is None else group, color)


def _allow(ctx, *, a: str, b: str, reason: str = "allowed in the spec"):
    return a, b, reason


def _check(ctx, *, stop_after_self: bool = False, certify: bool = False,
           first_hit: bool = False, only: str = ""):
    """``[check]``: options of :meth:`cadpipe.CollisionWorld.check` (``only = ""``: every
    pair)."""
    return {"stop_after_self": stop_after_self, "certify": certify, "first_hit": first_hit,
            "only": only or None}


def _add_parts(ctx, assembly, parts):
    """Each table of ``parts`` built by its kind and added to ``assembly``; returns the
    key path of each part by name."""
    limits.check("max_parts", len(parts), f"a spec of {len(parts):,} parts", key="parts")
    keys, triangles = {}, 0
    for i, entry in enumerate(parts):
        key = f"parts[{i}]"
        if not isinstance(entry, dict):
            raise ctx.error(key, f"expected a table, got {shown(entry)}")
        kind = entry.get("kind")
        common = {k: v for k, v in entry.items() if k in _COMMON_KEYS}
        place = ctx.call(_placement, common, key)
        try:
            build = part_kinds.get(kind)
        except CadpipeError as exc:
            raise _located(exc, f"{key}.kind") from None
        obj = ctx.call(build, entry, key, ignore=_COMMON_KEYS)
        name = place["name"] or f"{kind}-{i}"
        triangles += limits.estimated_triangles(obj)
        try:
            limits.check("max_triangles", triangles, f"the parts so far ({i + 1} of {len(parts)})")
            getattr(assembly, place["op"])(name, obj, place["transform"], place["color"])
        except CadpipeError as exc:
            raise _located(exc, key) from None
        keys[name] = key
    return keys


def _add_robot(ctx, assembly, table):
    """The ``robot`` table read, and its posed links added to ``assembly`` as parts."""
    if assembly.units != "m":
        raise ctx.error("units", 'a spec with a robot is in metres, as URDF is; '
                                 'set units = "m"')
    posed = ctx.call(_robot, table, "robot")
    taken = {p.name for p in assembly.parts}
    for link, pose in posed.link_poses().items():
        if link in taken:
            raise ctx.error("robot", f"the robot's link {link!r} has the name of a part; "
                                     "rename the part")
        assembly.add(link, posed.robot.link_meshes[link], pose, posed.color)
    return posed


def _allowed_pairs(ctx, tables, names):
    """``(a, b, reason)`` of each ``allow`` table, both ends among ``names``."""
    pairs = []
    for i, entry in enumerate(tables):
        key = f"allow[{i}]"
        pair = ctx.call(_allow, entry, key)
        for end, which in zip(pair[:2], "ab"):
            if end not in names:
                raise ctx.error(f"{key}.{which}",
                                f"unknown object {shown(end)}; objects (added parts and robot "
                                f"links): {', '.join(sorted(names))}")
        if pair[0] == pair[1]:
            raise ctx.error(f"{key}.b", "an object cannot collide with itself")
        pairs.append(pair)
    return tuple(pairs)


def _spec(ctx, *, parts: list = (), name: str | None = None, units: str = "m",
          outputs: list = (), robot: dict | None = None, allow: list = (),
          check: dict | None = None, **budgets):
    """The top-level table: an :class:`~cadpipe.Assembly`, its outputs and its cell.

    ``budgets``: a key per :data:`cadpipe.limits.SPEC_KEYS` (see :func:`_with_budget_keys`).
    """
    from cadpipe.solids.assembly import Assembly

    budgets = {k: v for k, v in {**limits.checked(budgets), **ctx.budgets}.items()
               if v is not None}
    if not parts and robot is None:
        raise InputError("expected at least one part", key="parts")
    with limits.using(**budgets):
        assembly = Assembly(units=units, name=name or ctx.file.stem)
        part_keys = _add_parts(ctx, assembly, parts)
        objects = tuple(p.name for p in assembly.parts if p.op == "add")
        posed = None if robot is None else _add_robot(ctx, assembly, robot)
    names = set(objects) | set(posed.robot.link_meshes if posed else ())
    cell = Cell(objects, posed, _allowed_pairs(ctx, allow, names),
                ctx.call(_check, {} if check is None else check, "check"))
    made = []
    for i, out in enumerate(outputs):
        made.append(ctx.call(_output, {"file": out} if isinstance(out, str) else out,
                             f"outputs[{i}]"))
    return Spec(ctx.file, assembly, tuple(made), cell, part_keys, budgets)


def _with_budget_keys(func):
    """``func`` with its ``**budgets`` replaced by one optional key per budget a spec
    may set (:data:`cadpipe.limits.SPEC_KEYS`), typed as the budget's default: the
    keys follow :class:`cadpipe.limits.Limits`, so a new budget is a spec key without
    an edit here."""
    signature = inspect.signature(func, eval_str=True)
    keys = [inspect.Parameter(name, inspect.Parameter.KEYWORD_ONLY, default=None,
                              annotation=(Number if isinstance(getattr(limits.Limits(), name),
                                                               float) else int) | None)
            for name in limits.SPEC_KEYS]
    func.__signature__ = signature.replace(parameters=[
        *(p for p in signature.parameters.values() if p.kind is not p.VAR_KEYWORD), *keys])
    return func


_with_budget_keys(_spec)


def read(spec_path, *, data=None, output_folder=None, **budgets):
    """Read a TOML or JSON spec into a :class:`Spec` (assembly, outputs and cell).

    Parameters
    ----------
    spec_path : str or path
        The ``.toml`` or ``.json`` file.
    data : dict, optional
        The spec's table already parsed (a template with its parameters filled in, from
        :mod:`cadpipe.batch`); files it names still resolve relative to ``spec_path``'s
        folder.
    output_folder : str or path, optional
        Where the spec's ``outputs`` are written (default: the spec's folder); a
        spec cannot name a file outside it.
    **budgets : int or float, optional
        Any budget of :class:`cadpipe.limits.Limits` (``max_triangles=``,
        ``max_depth=``, ...) for reading and building this spec, over the spec's own
        keys of those names.

    Raises :class:`SpecError` naming the file, the key path and what was expected,
    and :class:`~cadpipe.errors.LimitError` for a spec asking for too much work.
    """
    file = FilePath(spec_path)
    budgets = {k: v for k, v in limits.checked(budgets).items() if v is not None}
    try:
        with limits.using(**budgets):
            return SpecContext(file, output_folder, budgets).call(
                _spec, parse(file) if data is None else data)
    except CadpipeError as exc:
        raise exc.at(file=file) from exc.__cause__


def load(spec_path: str | os.PathLike, **options: typing.Any) -> "Assembly":
    """The :class:`~cadpipe.Assembly` a spec file describes.

    Parameters
    ----------
    spec_path : str or path-like
        The ``.toml`` or ``.json`` file (docs/spec.md).
    **options
        As for :func:`read`: ``output_folder`` and any budget of
        :class:`cadpipe.limits.Limits` (``max_triangles=``, ...).

    Returns
    -------
    assembly : Assembly
    """
    return read(spec_path, **options).assembly
