"""Spec files: an assembly written as TOML or JSON, read into the same Python API calls.

One schema for both formats (see ``docs/spec.md``): ``name``, ``units``, ``parts``
(each with a ``kind`` looked up in :data:`cadpipe.io.registry.part_kinds`), and
``outputs``; a robot cell adds ``robot`` (a posed URDF arm, whose links join the
assembly as parts), ``allow`` and ``check``, which :func:`cadpipe.collision.world_from_spec`
turns into a collision world. Reading a spec only parses data and calls registered
functions; nothing in it is executed.

A part kind is a function ``kind(ctx, *, key=default, ...)``: its keyword
parameters are the keys a spec may give, and their annotations the accepted
types, so unknown keys, missing keys and wrong types are reported before the
function runs, as ``SpecError("<file>: parts[3].radius: ...")``. Errors the
function raises about an argument (messages starting ``"radius: "``) get the
same key path. ``ctx`` (:class:`SpecContext`) resolves files and paths relative
to the spec's folder.
"""

import inspect
import json
import re
import tomllib
import typing
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path as FilePath

import numpy as np

from cadpipe._validate import as_choice
from cadpipe.errors import CadpipeError, InputError, SpecError
from cadpipe.solids.transform import as_matrix, placement

#: annotation for a number in a part kind's signature (TOML and JSON keep ints apart)
Number = int | float

_TYPE_NAMES = {bool: "true or false", int: "a whole number", float: "a number", str: "a string",
               list: "a list", dict: "a table"}
_COMMON_KEYS = ("name", "kind", "op", "color", "transform")


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


class SpecContext:
    """What a part kind gets besides its keys: the spec's file and folder, and helpers
    that resolve files and paths there and validate nested tables the same way."""

    def __init__(self, file, where=""):
        self.file = FilePath(file)
        self.folder = self.file.parent
        self.where = where

    def _key(self, key):
        if not key or not self.where:
            return key or self.where
        return f"{self.where}.{key}"

    def error(self, key, message):
        """A :class:`SpecError` about ``key`` (relative to this context; "" for itself)."""
        where = self._key(key)
        return SpecError(f"{self.file}: {where}: {message}" if where else
                         f"{self.file}: {message}")

    @contextmanager
    def keyed(self, key, table=()):
        """Report a :class:`CadpipeError` raised inside as being about ``key``.

        A message that starts with one of ``table``'s keys (``"radius: ..."``, or
        ``"pipes[1].wall: ..."``) is reported at that key, ``key.radius``.
        """
        try:
            yield
        except SpecError:
            raise
        except CadpipeError as exc:
            text = str(exc)
            head, sep, rest = text.partition(": ")
            if sep and re.split(r"[.\[]", head, maxsplit=1)[0] in table:
                raise self.error(f"{key}.{head}" if key else head, rest) from None
            raise self.error(key, text) from None

    def call(self, func, table, key="", ignore=()):
        """``func(ctx, **table)`` after checking ``table`` against ``func``'s signature.

        ``key`` names the table in error messages; keys in ``ignore`` are allowed but
        not passed on.
        """
        child = SpecContext(self.file, self._key(key))
        if not isinstance(table, dict):
            raise child.error("", f"expected a table, got {table!r}")
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
                raise child.error(name, f"unknown key; expected one of: {known}")
            if not _accepts(value, named[name].annotation):
                raise child.error(name, f"expected {_describe(named[name].annotation)}, "
                                        f"got {value!r}")
        for name, p in named.items():
            if p.default is p.empty and name not in table:
                raise child.error(name, f"missing; expected {_describe(p.annotation)}")
        with child.keyed("", table):
            return func(child, **{k: v for k, v in table.items() if k not in ignore})

    def file_path(self, value, key):
        """An existing file named by ``value``, relative to the spec's folder."""
        path = self.folder / value
        if not path.is_file():
            raise InputError(f"{key}: no such file {value!r} in {self.folder}")
        return path

    def path(self, value, key="path"):
        """A :class:`cadpipe.Path` from a list of points, a CSV file name, or a table."""
        from cadpipe.geometry.path import Path

        if isinstance(value, dict):
            return self.call(_path_table, value, key)
        if isinstance(value, str):
            return Path(_csv_points(self.file_path(value, key), key))
        return Path(_points(value, key))


def _points(value, key):
    from cadpipe._validate import as_points

    return as_points(value, key, min_count=2)


def _csv_points(file, key):
    """Rows ``x,y,z`` of a CSV file; a header row and ``#`` comments are skipped."""
    try:
        text = file.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise InputError(f"{key}: {file.name}: not a text file; expected rows of x,y,z "
                         "numbers") from None
    rows = [line for line in text.splitlines()
            if line.strip() and not line.lstrip().startswith("#")]
    if rows and any(c.isalpha() for c in rows[0].replace("e", "").replace("E", "")):
        rows = rows[1:]
    try:
        points = np.loadtxt(rows, delimiter=",", ndmin=2)
    except ValueError as exc:
        raise InputError(f"{key}: {file.name}: expected rows of x,y,z numbers ({exc})") from None
    return _points(points, f"{key}: {file.name}")


def _path_table(ctx, *, points: list | str, closed: bool = False, spline: bool = False,
                step: Number | None = None, tolerance: Number | None = None):
    """``path = {points = ..., spline = true, step = 0.01}``: a fitted or plain path."""
    from cadpipe.geometry.path import Path

    pts = _csv_points(ctx.file_path(points, "points"), "points") if isinstance(points, str) \
        else _points(points, "points")
    if spline:
        return Path.spline(pts, step, tolerance=tolerance, closed=closed)
    if step is not None or tolerance is not None:
        raise InputError(f"{'step' if step is not None else 'tolerance'}: only a fitted path "
                         "has one; add spline = true")
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


def _output(ctx, *, file: str, mode: str | None = None):
    from cadpipe.solids.assembly import EXPORT_MODES

    if mode is not None:
        as_choice(mode, "mode", EXPORT_MODES)
    return ctx.folder / file, mode


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
    posed links), its outputs as ``(path, mode)`` pairs (mode None: chosen by the
    suffix), and its :class:`Cell`."""

    file: FilePath
    assembly: object
    outputs: tuple
    cell: Cell


def _parse(file):
    if not file.is_file():
        raise SpecError(f"{file}: is a folder, not a spec file" if file.is_dir() else
                        f"{file}: no such spec file")
    suffix = file.suffix.lower()
    try:
        if suffix == ".toml":
            with open(file, "rb") as fh:
                return tomllib.load(fh)
        if suffix == ".json":
            with open(file, encoding="utf-8") as fh:
                return json.load(fh)
    except (tomllib.TOMLDecodeError, json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise SpecError(f"{file}: not valid {suffix[1:].upper()}: {exc}") from None
    raise SpecError(f"{file}: unknown spec format {file.suffix!r}; use .toml or .json")


def _robot(ctx, *, urdf: str, srdf: str | None = None, joints: list | dict | None = None,
           transform: list | dict | None = None, group: str | None = None,
           color: str | list | None = None):
    """``[robot]``: a URDF arm posed by ``joints`` on a rigid base ``transform``."""
    from cadpipe.collision.robot import Robot
    from cadpipe.solids.transform import is_rigid

    try:
        robot = Robot.from_urdf(ctx.file_path(urdf, "urdf"),
                                None if srdf is None else ctx.file_path(srdf, "srdf"))
    except SpecError as exc:          # about the URDF or SRDF file: keep its own wording
        raise InputError(str(exc)) from None
    base = _matrix(ctx, transform)
    if base is not None and not is_rigid(base):
        raise InputError("transform: a robot's base only rotates and translates; "
                         "remove scale")
    values = dict(zip((j.name for j in robot.joints), robot.joint_array(joints)[0].tolist()))
    return PosedRobot(robot, {k: values[k] for k in robot.actuated}, base,
                      robot.name if group is None else group, color)


def _allow(ctx, *, a: str, b: str, reason: str = "allowed in the spec"):
    return a, b, reason


def _check(ctx, *, stop_after_self: bool = False, certify: bool = False):
    """``[check]``: options of :meth:`cadpipe.CollisionWorld.check`."""
    return {"stop_after_self": stop_after_self, "certify": certify}


def _add_parts(ctx, assembly, parts):
    """Each table of ``parts`` built by its kind and added to ``assembly``."""
    from cadpipe.io.registry import part_kinds

    for i, entry in enumerate(parts):
        key = f"parts[{i}]"
        if not isinstance(entry, dict):
            raise ctx.error(key, f"expected a table, got {entry!r}")
        kind = entry.get("kind")
        common = {k: v for k, v in entry.items() if k in _COMMON_KEYS}
        place = ctx.call(_placement, common, key)
        with ctx.keyed(f"{key}.kind"):
            build = part_kinds.get(kind)
        obj = ctx.call(build, entry, key, ignore=_COMMON_KEYS)
        with ctx.keyed(key, common):
            getattr(assembly, place["op"])(place["name"] or f"{kind}-{i}", obj,
                                           place["transform"], place["color"])


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
                                f"unknown object {end!r}; objects (added parts and robot "
                                f"links): {', '.join(sorted(names))}")
        if pair[0] == pair[1]:
            raise ctx.error(f"{key}.b", "an object cannot collide with itself")
        pairs.append(pair)
    return tuple(pairs)


def _spec(ctx, *, parts: list = (), name: str | None = None, units: str = "m",
          outputs: list = (), robot: dict | None = None, allow: list = (),
          check: dict | None = None):
    """The top-level table: an :class:`~cadpipe.Assembly`, its outputs and its cell."""
    from cadpipe.solids.assembly import Assembly

    if not parts and robot is None:
        raise InputError("parts: expected at least one part")
    assembly = Assembly(units=units, name=name or ctx.file.stem)
    _add_parts(ctx, assembly, parts)
    objects = tuple(p.name for p in assembly.parts if p.op == "add")
    posed = None if robot is None else _add_robot(ctx, assembly, robot)
    names = set(objects) | set(posed.robot.link_meshes if posed else ())
    cell = Cell(objects, posed, _allowed_pairs(ctx, allow, names),
                ctx.call(_check, {} if check is None else check, "check"))
    made = []
    for i, out in enumerate(outputs):
        made.append(ctx.call(_output, {"file": out} if isinstance(out, str) else out,
                             f"outputs[{i}]"))
    return Spec(ctx.file, assembly, tuple(made), cell)


def read(spec_path, data=None):
    """Read a TOML or JSON spec into a :class:`Spec` (assembly, outputs and cell).

    ``data``, when given, is the spec's table already parsed (a template with its
    parameters filled in, from :mod:`cadpipe.batch`); files it names still resolve
    relative to ``spec_path``'s folder. Raises :class:`SpecError` naming the file, the
    key path and what was expected.
    """
    file = FilePath(spec_path)
    return SpecContext(file).call(_spec, _parse(file) if data is None else data)


def load(spec_path):
    """The :class:`~cadpipe.Assembly` a spec file describes."""
    return read(spec_path).assembly
