"""Robot-cell files for ``cadpipe collide``: a TOML or JSON description -> CollisionWorld.

The format (documented in ``docs/collision.md``)::

    [robot]                      # optional
    urdf = "robots/panda/panda.urdf"
    srdf = "robots/panda/panda.srdf"        # optional: MoveIt's disabled pairs
    joints = [0.0, -0.4, 0.0, -2.0, 0.0, 1.6, 0.8, 0.02]   # or {name = value, ...}
    transform = {xyz = [0, 0, 0], rpy = [0, 0, 0]}         # optional base pose

    [check]                      # optional
    stop_after_self = false
    certify = false

    [[objects]]
    name = "workpiece"
    kind = "box"                 # box | sphere | capsule | mesh | pipe
    size = [0.3, 0.2, 0.1]
    transform = {xyz = [0.5, 0.0, 0.05]}

    [[allow]]
    a = "panda_hand"
    b = "workpiece"
    reason = "gripping it"

Paths are relative to the file. A transform is ``{xyz, rpy}`` (metres and
radians, URDF's roll-pitch-yaw) or a 4x4 matrix. This loader is small on
purpose: it only turns the file into :class:`CollisionWorld` calls.
"""

import json
import tomllib
from pathlib import Path as FilePath

import numpy as np

from ..errors import CadpipeError, SpecError
from ..mesh import Mesh
from ..path import Path
from ..pipe import Pipe
from .bodies import Box, Capsule, Sphere
from .robot import Robot
from .world import CollisionWorld

KINDS = ("box", "sphere", "capsule", "mesh", "pipe")
SECTIONS = ("robot", "check", "objects", "allow")


def read_cell(path):
    """Parse a cell file into a dict (TOML by default, JSON for ``.json``)."""
    path = FilePath(path)
    if not path.is_file():
        raise SpecError(f"{path}: no such cell file")
    try:
        if path.suffix.lower() == ".json":
            data = json.loads(path.read_text(encoding="utf-8"))
        else:
            data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise SpecError(f"{path}: not valid {'JSON' if path.suffix == '.json' else 'TOML'} "
                        f"({exc})") from None
    if not isinstance(data, dict):
        raise SpecError(f"{path}: expected a table at the top level")
    unknown = set(data) - set(SECTIONS)
    if unknown:
        raise SpecError(f"{path}: unknown section {sorted(unknown)[0]!r}; expected "
                        f"{', '.join(SECTIONS)}")
    return data


def load_cell(path):
    """Build the :class:`CollisionWorld` a cell file describes.

    Returns ``(world, check_options)``, the options being keyword arguments
    for :meth:`CollisionWorld.check`.
    """
    path = FilePath(path)
    data = read_cell(path)
    world = CollisionWorld()
    folder = path.parent
    try:
        robot = data.get("robot")
        if robot is not None:
            _add_robot(world, _table(robot, "robot"), folder)
        for k, obj in enumerate(_list(data.get("objects", []), "objects")):
            _add_object(world, _table(obj, f"objects[{k}]"), k, folder)
        for k, pair in enumerate(_list(data.get("allow", []), "allow")):
            pair = _table(pair, f"allow[{k}]")
            world.allow(_required(pair, "a", f"allow[{k}]"), _required(pair, "b", f"allow[{k}]"),
                        str(pair.get("reason", "allowed in the cell file")))
        check = _table(data.get("check", {}), "check")
        unknown = set(check) - {"stop_after_self", "certify"}
        if unknown:
            raise SpecError(f"check.{sorted(unknown)[0]}: unknown option; expected "
                            "stop_after_self or certify")
        options = {k: bool(v) for k, v in check.items()}
    except SpecError as exc:
        raise SpecError(f"{path}: {exc}") from None
    except CadpipeError as exc:
        raise type(exc)(f"{path}: {exc}") from None
    return world, options


def _table(value, where):
    if not isinstance(value, dict):
        raise SpecError(f"{where}: expected a table, got {type(value).__name__}")
    return value


def _list(value, where):
    if not isinstance(value, list):
        raise SpecError(f"{where}: expected a list of tables, got {type(value).__name__}")
    return value


def _required(table, key, where):
    if key not in table:
        raise SpecError(f"{where}.{key}: required")
    return table[key]


def transform_matrix(value, where):
    """A 4x4 matrix from ``{xyz, rpy}`` or a nested 4x4 list (validated later)."""
    if value is None:
        return None
    if isinstance(value, dict):
        unknown = set(value) - {"xyz", "rpy"}
        if unknown:
            raise SpecError(f"{where}.transform.{sorted(unknown)[0]}: unknown key; use xyz "
                            "and rpy")
        from scipy.spatial.transform import Rotation

        try:
            xyz = np.array(value.get("xyz", [0, 0, 0]), dtype=np.float64).reshape(3)
            rpy = np.array(value.get("rpy", [0, 0, 0]), dtype=np.float64).reshape(3)
        except (TypeError, ValueError):
            raise SpecError(f"{where}.transform: xyz and rpy must be 3 numbers each") from None
        m = np.eye(4)
        m[:3, :3] = Rotation.from_euler("xyz", rpy).as_matrix()   # URDF: Rz(y) Ry(p) Rx(r)
        m[:3, 3] = xyz
        return m
    return value


def _add_robot(world, robot, folder):
    unknown = set(robot) - {"urdf", "srdf", "joints", "transform", "group"}
    if unknown:
        raise SpecError(f"robot.{sorted(unknown)[0]}: unknown key")
    urdf = folder / str(_required(robot, "urdf", "robot"))
    srdf = robot.get("srdf")
    model = Robot.from_urdf(urdf, srdf=None if srdf is None else folder / str(srdf))
    world.add_robot(model, joints=robot.get("joints"),
                    transform=transform_matrix(robot.get("transform"), "robot"),
                    group=robot.get("group"))


def _add_object(world, obj, k, folder):
    where = f"objects[{k}]"
    name = str(_required(obj, "name", where))
    kind = _required(obj, "kind", where)
    if kind not in KINDS:
        raise SpecError(f"{where}.kind: expected one of {', '.join(KINDS)}, got {kind!r}")
    allowed = {"name", "kind", "transform", "group"} | {
        "box": {"size"}, "sphere": {"radius"}, "capsule": {"radius", "length"},
        "mesh": {"file"}, "pipe": {"points", "radius", "closed", "spline_step", "sides",
                                   "caps"}}[kind]
    unknown = set(obj) - allowed
    if unknown:
        raise SpecError(f"{where}.{sorted(unknown)[0]}: not a key of a {kind} object; "
                        f"expected {', '.join(sorted(allowed))}")
    if kind == "box":
        shape = Box(_required(obj, "size", where))
    elif kind == "sphere":
        shape = Sphere(_required(obj, "radius", where))
    elif kind == "capsule":
        shape = Capsule(_required(obj, "radius", where), _required(obj, "length", where))
    elif kind == "mesh":
        shape = Mesh.load(folder / str(_required(obj, "file", where)))
    else:
        points = _required(obj, "points", where)
        closed = bool(obj.get("closed", False))
        step = obj.get("spline_step")
        path_ = Path(points, closed=closed) if step is None else \
            Path.spline(points, step=step, closed=closed)
        shape = Pipe(path_, _required(obj, "radius", where), sides=obj.get("sides", 16),
                     caps=obj.get("caps", "round"))
    world.add(name, shape, transform=transform_matrix(obj.get("transform"), where),
              group=obj.get("group"))
