"""``cadpipe collide`` on spec files with a robot cell: the shipped example, JSON, SVG, errors."""

import json
import re
import shutil
import textwrap
from pathlib import Path as FilePath

import numpy as np
import pytest
import trimesh

from cadpipe import Pipe, SpecError
from cadpipe.cli import main
from cadpipe.spec import world_from_spec
from cadpipe.spec import read

ROOT = FilePath(__file__).parent.parent
EXAMPLE = ROOT / "assets" / "examples" / "robot_cell.toml"


def test_the_example_cell_reports_the_finger_in_the_workpiece(capsys):
    assert main(["collide", str(EXAMPLE)]) == 0
    out = capsys.readouterr().out
    assert "COLLISION  panda_leftfinger <-> workpiece  (world, decided by fcl)" in out
    assert out.count("COLLISION") == 1
    spec = read(EXAMPLE)
    world = world_from_spec(spec)
    assert spec.cell.check == {"stop_after_self": False, "certify": False, "first_hit": False,
                               "only": None}
    assert ("workpiece", "weld_seam", "the seam lies on the workpiece") in world.allowed
    assert world.group("panda_hand") == "panda" and world.group("cable_duct") is None
    assert spec.cell.objects == ("workpiece", "cable_duct", "weld_seam")


def test_pipe_parts_stay_pipes_and_are_placed_by_their_transform():
    spec = read(EXAMPLE)
    world = world_from_spec(EXAMPLE)
    duct = next(p for p in spec.assembly.parts if p.name == "cable_duct")
    assert isinstance(duct.obj, Pipe)                     # the part kind returns the Pipe ...
    np.testing.assert_allclose(world.pose("cable_duct"), duct.transform)
    low, high = world.bounds("cable_duct")                # ... checked as the round tube
    starts, ends, r0, r1 = duct.obj.collision_units()     # that holds its mesh
    shift = duct.transform[:3, 3]
    lo = np.minimum(starts - r0[:, None], ends - r1[:, None]).min(axis=0) + shift
    hi = np.maximum(starts + r0[:, None], ends + r1[:, None]).max(axis=0) + shift
    np.testing.assert_allclose(low, lo, atol=1e-9)
    np.testing.assert_allclose(high, hi, atol=1e-9)
    mesh = duct.obj.mesh().vertices + shift
    assert (low <= mesh.min(axis=0) + 1e-12).all() and (high >= mesh.max(axis=0) - 1e-12).all()


def test_json_and_svg_output(tmp_path, capsys):
    assert main(["collide", str(EXAMPLE), "--json", "--svg", str(tmp_path / "certs")]) == 0
    report = json.loads(capsys.readouterr().out)
    assert [(c["a"], c["b"]) for c in report["collisions"]] == [
        ("panda_leftfinger", "workpiece")]
    assert report["counts"]["certificate"] >= 1
    assert report["svg"] and all(FilePath(p).read_text().startswith("<svg")
                                 for p in report["svg"])
    assert "panda_link5__cable_duct.svg" in {FilePath(p).name for p in report["svg"]}


def write_cell(folder, text, name="cell.toml"):
    path = folder / name
    path.write_text(textwrap.dedent(text))
    return path


def test_json_cells_and_mesh_files(tmp_path, capsys):
    trimesh.creation.box(extents=(1, 1, 1)).export(tmp_path / "block.stl")
    cell = {"parts": [
        {"name": "block", "kind": "mesh", "file": "block.stl"},
        {"name": "ball", "kind": "sphere", "radius": 0.2,
         "transform": [[1, 0, 0, 0.1], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]},
        {"name": "rod", "kind": "pipe", "path": [[0, 0, -0.5], [0, 0, 0.5]], "radius": 0.1,
         "caps": "round", "transform": {"translate": [3, 0, 0], "rotate": [90, 0, 0]}}],
        "check": {"stop_after_self": True}}
    path = tmp_path / "cell.json"
    path.write_text(json.dumps(cell))
    assert main(["collide", str(path)]) == 0
    out = capsys.readouterr().out
    assert "COLLISION  block <-> ball  (world, decided by containment)" in out
    assert "1 colliding pair(s) among 3" in out


def test_scaled_and_hollow_parts_are_checked_as_their_solids(tmp_path):
    """A scaled part is baked into its mesh (poses are rigid); a hollow pipe is its wall."""
    spec = write_cell(tmp_path, json.dumps({"parts": [
        {"name": "plate", "kind": "box", "size": 1,
         "transform": {"scale": [0.2, 0.2, 0.02]}},
        {"name": "duct", "kind": "pipe", "path": [[0, 0, -0.5], [0, 0, 0.5]], "radius": 0.3,
         "wall": 0.05, "sides": 32},
        {"name": "hole", "kind": "cylinder", "radius": 0.05, "height": 1, "op": "subtract"}]}),
        "cell.json")
    world = world_from_spec(spec)
    assert world.names == ("plate", "duct")               # subtracted parts are no objects
    np.testing.assert_array_equal(world.pose("plate"), np.eye(4))
    np.testing.assert_allclose(world.bounds("plate"), [[-0.1, -0.1, -0.01], [0.1, 0.1, 0.01]])
    assert not world.check().collisions                   # the plate sits in the duct's bore


@pytest.mark.parametrize("text, message", [
    ('[[parts]]\nname = "a"\nkind = "box"\nsize = [1, 1, 1]\n'
     '[[allow]]\na = "a"\nb = "ghost"\n', "allow[0].b: unknown object 'ghost'"),
    ('[[parts]]\nname = "a"\nkind = "box"\nsize = 1\n[[parts]]\nname = "b"\n'
     'kind = "box"\nsize = 1\nop = "subtract"\n[[allow]]\na = "a"\nb = "b"\n',
     "allow[0].b: unknown object 'b'"),
    ('[[parts]]\nname = "a"\nkind = "box"\nsize = [1, 1, 1]\n'
     'transform = { translate = [nan, 0, 0] }\n', "parts[0].transform.translate: expected 3"),
    ('[[parts]]\nname = "a"\nkind = "capsule"\n', "parts[0].kind: unknown part kind"),
    ('[[parts]]\nname = "a"\nkind = "box"\nradius = 1\n', "parts[0].radius: unknown key"),
    ('[robots]\n', "robots: unknown key"),
    ('[robot]\nurdf = "missing.urdf"\n', "robot.urdf: no such file 'missing.urdf'"),
    ('[robot]\nurdf = "robot.urdf"\njoints = [1, "x"]\n', "robot.joints: expected numbers"),
    ('[robot]\nurdf = "robot.urdf"\njoints = {elbow = 9}\n', "robot.joints: unknown joint"),
    ('[robot]\nurdf = "robot.urdf"\njoints = [9]\n', "robot.joints: hinge=9.0 is outside"),
    ('[robot]\nurdf = "robot.urdf"\ntransform = { scale = 2 }\n',
     "robot.transform: a robot's base only rotates and translates"),
    ('units = "mm"\n[robot]\nurdf = "robot.urdf"\n', "units: a spec with a robot is in metres"),
    ('[robot]\nurdf = "robot.urdf"\n[[parts]]\nname = "arm"\nkind = "box"\nsize = 1\n',
     "robot: the robot's link 'arm' has the name of a part"),
    ('[robot]\nurdf = "bad.urdf"\n', "robot.urdf: "),
    ('[check]\nfast = true\n[[parts]]\nkind = "box"\nsize = 1\n', "check.fast: unknown key"),
    ('[check]\ncertify = "yes"\n[[parts]]\nkind = "box"\nsize = 1\n',
     "check.certify: expected true or false"),
    ('parts = [[\n', "not valid TOML"),
])
def test_bad_cells_are_one_line_errors(tmp_path, capsys, text, message):
    (tmp_path / "robot.urdf").write_text(ROBOT)
    (tmp_path / "bad.urdf").write_text("<robot name='x'><link")
    path = write_cell(tmp_path, text)
    with pytest.raises(SpecError, match=re.escape(message)):
        world_from_spec(path)
    assert main(["collide", str(path)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0] and f"{path}: " in err[0]


ROBOT = """<robot name="hinge">
  <link name="base"><collision><geometry><box size="0.2 0.2 0.2"/></geometry></collision></link>
  <link name="arm"><collision><origin xyz="0.3 0 0"/><geometry><box size="0.4 0.05 0.05"/>
  </geometry></collision></link>
  <joint name="hinge" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="0 0 1"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
</robot>"""


def test_open_mesh_files_are_refused(tmp_path, capsys):
    box = trimesh.creation.box()
    trimesh.Trimesh(box.vertices, box.faces[:-2], process=False).export(tmp_path / "open.stl")
    path = write_cell(tmp_path, '[[parts]]\nname = "lid"\nkind = "mesh"\nfile = "open.stl"\n')
    assert main(["collide", str(path)]) == 1
    assert "parts[0]" in capsys.readouterr().err


def test_robot_cells_resolve_paths_and_import_srdf_pairs(tmp_path):
    shutil.copytree(ROOT / "assets" / "robots" / "panda", tmp_path / "panda")
    robot = '[robot]\nurdf = "panda/panda.urdf"\njoints = {panda_joint4 = -1.5}\n'
    world = world_from_spec(write_cell(tmp_path, robot))
    # at zero the fingers close on each other and the wrist folds onto link5 ...
    assert [(a, b) for a, b, _ in world.check().collisions] == [
        ("panda_link5", "panda_link7"), ("panda_link5", "panda_hand"),
        ("panda_leftfinger", "panda_rightfinger")]
    # ... which MoveIt's SRDF disables ("Default": they touch in the default pose)
    world = world_from_spec(write_cell(tmp_path, robot + 'srdf = "panda/panda.srdf"\n'))
    assert not world.check().collisions
    assert ("panda_link5", "panda_link7", "srdf: Default") in world.allowed


def test_a_robot_base_transform_moves_every_link(tmp_path):
    (tmp_path / "robot.urdf").write_text(ROBOT)
    at = read(write_cell(tmp_path, '[robot]\nurdf = "robot.urdf"\njoints = [0.5]\n'))
    moved = world_from_spec(write_cell(
        tmp_path, '[robot]\nurdf = "robot.urdf"\njoints = {hinge = 0.5}\n'
                  'transform = { translate = [1, 2, 3], rotate = [0, 0, 90] }\n', "moved.toml"))
    base = np.array([[0, -1, 0, 1], [1, 0, 0, 2], [0, 0, 1, 3], [0, 0, 0, 1.0]])
    for link, pose in at.cell.robot.link_poses().items():
        np.testing.assert_allclose(moved.pose(link), base @ pose, atol=1e-12)
    assert moved.group("arm") == "hinge" and ("base", "arm", "adjacent links") in moved.allowed


def test_check_options_first_hit_and_only_come_from_the_spec(tmp_path):
    shutil.copytree(ROOT / "assets" / "robots" / "panda", tmp_path / "panda")
    text = ('[robot]\nurdf = "panda/panda.urdf"\njoints = {panda_joint4 = -1.5}\n'
            '[check]\nfirst_hit = true\nonly = "panda"\n'
            '[[parts]]\nname = "a"\nkind = "box"\nsize = 0.1\ntransform = {translate = [2, 2, 2]}\n'
            '[[parts]]\nname = "b"\nkind = "box"\nsize = 0.1\n'
            'transform = {translate = [2, 2, 2.05]}\n')
    spec = read(write_cell(tmp_path, text))
    assert spec.cell.check == {"stop_after_self": False, "certify": False, "first_hit": True,
                               "only": "panda"}
    report = world_from_spec(spec).check(**spec.cell.check)
    # the robot collides with itself (no SRDF): found, and the rest left unchecked
    assert report.collisions and report.counts()["not checked"] >= 1
    decided = {(p.a, p.b): p.decided_by for p in report.pairs}
    assert decided[("a", "b")] == "not checked"          # obstacle pair: not the robot's
