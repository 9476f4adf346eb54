"""``cadpipe collide`` and robot-cell files: the shipped example, JSON, SVG, and errors."""

import json
import re
import shutil
from pathlib import Path as FilePath

import pytest
import trimesh

from cadpipe import SpecError
from cadpipe.cli import main
from cadpipe.collision.cell import load_cell

ROOT = FilePath(__file__).parent.parent
EXAMPLE = ROOT / "assets" / "examples" / "robot_cell.toml"


def test_the_example_cell_reports_the_finger_in_the_workpiece(capsys):
    assert main(["collide", str(EXAMPLE)]) == 0
    out = capsys.readouterr().out
    assert "COLLISION  panda_leftfinger <-> workpiece  (world, decided by fcl)" in out
    assert out.count("COLLISION") == 1
    world, options = load_cell(EXAMPLE)
    assert options == {"stop_after_self": False}
    assert ("workpiece", "weld_seam", "the seam lies on the workpiece") in world.allowed()
    assert world.group("panda_hand") == "panda" and world.group("cable_duct") is None


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
    path.write_text(text)
    return path


def test_json_cells_and_mesh_files(tmp_path, capsys):
    trimesh.creation.box(extents=(1, 1, 1)).export(tmp_path / "block.stl")
    cell = {"objects": [
        {"name": "block", "kind": "mesh", "file": "block.stl"},
        {"name": "ball", "kind": "sphere", "radius": 0.2,
         "transform": [[1, 0, 0, 0.1], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]},
        {"name": "rod", "kind": "capsule", "radius": 0.1, "length": 1.0,
         "transform": {"xyz": [3, 0, 0], "rpy": [1.5707963, 0, 0]}}],
        "check": {"stop_after_self": True}}
    path = tmp_path / "cell.json"
    path.write_text(json.dumps(cell))
    assert main(["collide", str(path)]) == 0
    out = capsys.readouterr().out
    assert "COLLISION  block <-> ball  (world, decided by containment)" in out


@pytest.mark.parametrize("text, message", [
    ('[[objects]]\nname = "a"\nkind = "box"\nsize = [1, 1, 1]\n'
     '[[allow]]\na = "a"\nb = "ghost"\n', "unknown object 'ghost'"),
    ('[[objects]]\nname = "a"\nkind = "box"\nsize = [1, 1, 1]\n'
     'transform = {xyz = [nan, 0, 0]}\n', "NaN or infinite"),
    ('[[objects]]\nname = "a"\nkind = "cone"\n', "objects[0].kind: expected one of"),
    ('[[objects]]\nname = "a"\nkind = "box"\nradius = 1\n', "objects[0].radius: not a key"),
    ('[[objects]]\nkind = "box"\n', "objects[0].name: required"),
    ('[robots]\n', "unknown section 'robots'"),
    ('[robot]\nurdf = "missing.urdf"\n', "no such URDF file"),
    ('[check]\nfast = true\n', "check.fast: unknown option"),
    ('objects = [[\n', "not valid TOML"),
])
def test_bad_cells_are_one_line_errors(tmp_path, capsys, text, message):
    path = write_cell(tmp_path, text)
    with pytest.raises(SpecError if "unknown object" not in message
                       and "NaN" not in message else Exception, match=re.escape(message)):
        load_cell(path)
    assert main(["collide", str(path)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message.split("'")[0].split("[")[0] in err[0]
    assert str(path) in err[0]


def test_open_mesh_files_are_refused(tmp_path, capsys):
    box = trimesh.creation.box()
    trimesh.Trimesh(box.vertices, box.faces[:-2], process=False).export(tmp_path / "open.stl")
    path = write_cell(tmp_path, '[[objects]]\nname = "lid"\nkind = "mesh"\nfile = "open.stl"\n')
    assert main(["collide", str(path)]) == 1
    assert "not a closed solid" in capsys.readouterr().err


def test_robot_cells_resolve_paths_and_import_srdf_pairs(tmp_path):
    shutil.copytree(ROOT / "assets" / "robots" / "panda", tmp_path / "panda")
    robot = '[robot]\nurdf = "panda/panda.urdf"\njoints = {panda_joint4 = -1.5}\n'
    world, _ = load_cell(write_cell(tmp_path, robot))
    # at zero the fingers close on each other and the wrist folds onto link5 ...
    assert [(a, b) for a, b, _ in world.check().collisions] == [
        ("panda_link5", "panda_link7"), ("panda_link5", "panda_hand"),
        ("panda_leftfinger", "panda_rightfinger")]
    # ... which MoveIt's SRDF disables ("Default": they touch in the default pose)
    world, _ = load_cell(write_cell(tmp_path, robot + 'srdf = "panda/panda.srdf"\n'))
    assert not world.check().collisions
    assert ("panda_link5", "panda_link7", "srdf: Default") in world.allowed()
