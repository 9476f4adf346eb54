"""Spec files: the shipped examples build, bad specs give the documented errors."""

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path as FilePath

import numpy as np
import pytest

import cadpipe
from cadpipe.core.units import meters_per_unit
from cadpipe import HollowChain, HollowPipe, Junction, Pipe, primitives
from cadpipe.cli import main
from cadpipe.spec import read
from cadpipe.core.transform import placement

EXAMPLES = FilePath(__file__).parent.parent / "assets" / "examples"


SPECS = sorted(EXAMPLES.glob("*.toml")) + sorted(EXAMPLES.glob("*.json"))


def write(folder, text, name="cell.toml"):
    path = folder / name
    path.write_text(textwrap.dedent(text))
    return path


def test_there_are_several_examples():
    assert len(SPECS) >= 4


@pytest.mark.parametrize("spec", SPECS, ids=lambda p: p.name)
def test_every_example_spec_builds_one_watertight_solid(spec, tmp_path):
    """One solid per example; a robot cell's parts stand apart from each other."""
    read_spec = read(spec)
    solid = read_spec.assembly.union()
    assert solid.is_watertight and solid.is_outward
    assert solid.n_bodies == 1 or read_spec.cell.robot is not None
    assert set(solid.part_names) == {p.name for p in read_spec.assembly.parts}
    assert read_spec.outputs, "examples list their outputs"
    out = tmp_path / "example.stl"                        # and from the command line
    assert main(["build", str(spec), "-o", str(out), "--quiet"]) == 0
    mm_per_unit = 1000 * meters_per_unit(read_spec.assembly.units)   # STL is in millimetres
    assert cadpipe.Mesh.load(out).volume == pytest.approx(solid.volume * mm_per_unit ** 3,
                                                          rel=1e-6)


def test_a_robot_cell_builds_its_parts_and_the_posed_links(tmp_path, capsys):
    cell = read(EXAMPLES / "robot_cell.toml")
    robot = cell.cell.robot
    names = [p.name for p in cell.assembly.parts]
    assert names[:3] == ["workpiece", "cable_duct", "weld_seam"]
    assert names[3:] == list(robot.robot.link_meshes)              # then every link, posed
    for part in cell.assembly.parts[3:]:
        placed = np.eye(4) if part.transform is None else part.transform   # None: identity
        np.testing.assert_allclose(placed, robot.link_poses()[part.name])
        assert part.color == pytest.approx((0x64 / 255, 0x74 / 255, 0x8b / 255))
    out = tmp_path / "cell.usda"
    assert main(["build", str(EXAMPLES / "robot_cell.toml"), "-o", str(out), "--quiet"]) == 0
    from pxr import Usd

    stage = Usd.Stage.Open(str(out))
    prims = {p.GetParent().GetName() for p in stage.Traverse() if p.GetTypeName() == "Mesh"}
    assert {"workpiece", "panda_hand", "panda_leftfinger"} <= prims


def test_spec_builds_the_same_assembly_as_the_python_api(tmp_path):
    spec = write(tmp_path, """
        name = "cell"
        units = "mm"
        [[parts]]
        name = "duct"
        kind = "pipe"
        path = [[0, 0, 0], [100, 0, 0], [100, 80, 0]]
        radius = 10
        sides = 16
        wall = 2
        color = "#3b82f6"
        [[parts]]
        name = "post"
        kind = "cylinder"
        radius = 15
        height = 40
        transform = { translate = [100, 0, 0], rotate = [0, 0, 45] }
        [[parts]]
        name = "cap"
        kind = "box"
        size = [30, 30, 30]
        op = "intersect"
        transform = [[4, 0, 0, 100], [0, 4, 0, 0], [0, 0, 4, 0], [0, 0, 0, 1]]
        """)
    from_spec = cadpipe.load(spec)
    by_hand = (cadpipe.Assembly(units="mm", name="cell")
               .add("duct", HollowPipe(Pipe([[0, 0, 0], [100, 0, 0], [100, 80, 0]], 10, 16), 2),
                    color="#3b82f6")
               .add("post", primitives.cylinder(15, 40),
                    transform=placement(translate=(100, 0, 0), rotate=(0, 0, 45)))
               .intersect("cap", primitives.box(30),
                          transform=np.array([[4, 0, 0, 100], [0, 4, 0, 0], [0, 0, 4, 0],
                                              [0, 0, 0, 1.0]])))
    a, b = from_spec.union(), by_hand.union()
    assert (from_spec.name, from_spec.units) == ("cell", "mm")
    assert [(p.name, p.op, p.color) for p in from_spec.parts] == \
        [(p.name, p.op, p.color) for p in by_hand.parts]
    np.testing.assert_allclose(a.vertices, b.vertices)
    np.testing.assert_array_equal(a.faces, b.faces)


def test_toml_and_json_share_one_schema(tmp_path):
    table = {"units": "cm", "outputs": ["out/x.stl"],
             "parts": [{"kind": "sphere", "radius": 2, "name": "ball"},
                       {"kind": "box", "size": 3, "op": "subtract",
                        "transform": {"translate": [2, 0, 0]}}]}
    json_spec = write(tmp_path, json.dumps(table), "cell.json")
    toml_spec = write(tmp_path, """
        units = "cm"
        outputs = ["out/x.stl"]
        [[parts]]
        kind = "sphere"
        radius = 2
        name = "ball"
        [[parts]]
        kind = "box"
        size = 3
        op = "subtract"
        transform = { translate = [2, 0, 0] }
        """)
    a, b = read(json_spec), read(toml_spec)
    assert a.outputs == b.outputs == ((tmp_path / "out/x.stl", None, {}),)
    assert [p.name for p in a.assembly.parts] == ["ball", "box-1"]
    assert a.assembly.union().volume == pytest.approx(b.assembly.union().volume, rel=1e-12)


def test_paths_come_from_csv_files_and_splines(tmp_path):
    (tmp_path / "route.csv").write_text("x,y,z\n0,0,0\n# a comment\n1,0,0\n1,1,0.5\n")
    spec = write(tmp_path, """
        [[parts]]
        kind = "pipe"
        path = "route.csv"
        radius = 0.1
        [[parts]]
        kind = "pipe"
        path = { points = "route.csv", spline = true, step = 0.05 }
        radius = 0.1
        """)
    plain, fitted = (p.obj for p in read(spec).assembly.parts)
    np.testing.assert_array_equal(plain.path.points, [[0, 0, 0], [1, 0, 0], [1, 1, 0.5]])
    assert len(fitted.path) > 20 and fitted.path.segment_lengths.max() <= 0.05 + 1e-9


def test_junction_entries_inherit_the_junction_defaults(tmp_path):
    spec = write(tmp_path, """
        [[parts]]
        kind = "junction"
        wall = 0.02
        sides = 20
        [[parts.pipes]]
        path = [[-1, 0, 0], [1, 0, 0]]
        radius = 0.1
        [[parts.pipes]]
        path = [[0, 0, 0], [0, 1, 0]]
        radius = 0.08
        ends = ["open", "closed"]
        sides = 12
        """)
    junction = read(spec).assembly.parts[0].obj
    assert isinstance(junction, Junction)
    run, branch = junction.pipes
    assert (run.wall, run.ends, run.pipe.sides) == (0.02, ("open", "open"), 20)
    assert (branch.ends, branch.pipe.sides) == (("open", "closed"), 12)


def test_chain_kind_splices_its_pipes(tmp_path):
    spec = write(tmp_path, """
        [[parts]]
        kind = "chain"
        transition = "merge"
        sides = 12
        [[parts.pipes]]
        path = [[0, 0, 0], [1, 0, 0]]
        radius = 0.1
        [[parts.pipes]]
        path = [[1.3, 0, 0], [2, 0, 0]]
        radius = 0.06
        sides = 8
        """)
    spliced = read(spec).assembly.parts[0].obj
    direct = cadpipe.splice(Pipe([[0, 0, 0], [1, 0, 0]], 0.1, 12),
                            Pipe([[1.3, 0, 0], [2, 0, 0]], 0.06, 8), transition="merge")
    np.testing.assert_array_equal(spliced.vertices, direct.vertices)
    hollow = write(tmp_path, spec.read_text().replace('transition = "merge"',
                                                      'transition = "merge"\nwall = 0.02'))
    assert isinstance(read(hollow).assembly.parts[0].obj, HollowChain)


def test_group_kinds_take_every_pipe_key_as_a_default(tmp_path):
    """junction and chain derive their keys: any Pipe option at the group level is a
    default for its pipes (a table overrides it), and an unknown one is refused."""
    import inspect

    from cadpipe.spec import parts

    pipe_keys = set(inspect.signature(Pipe).parameters) - {"path"}
    for kind in (parts.junction, parts.chain):
        assert pipe_keys <= set(inspect.signature(kind).parameters)
    assert {"transition", "closed", "wall", "ends"} <= set(inspect.signature(parts.chain)
                                                          .parameters)
    spec = write(tmp_path, """
        [[parts]]
        kind = "chain"
        radius = 0.1
        envelope = true
        caps = "round"
        [[parts.pipes]]
        path = [[0, 0, 0], [1, 0, 0]]
        [[parts.pipes]]
        path = [[1.3, 0, 0], [2, 0, 0]]
        radius = 0.06
        """)
    spliced = read(spec).assembly.parts[0].obj
    direct = cadpipe.splice(Pipe([[0, 0, 0], [1, 0, 0]], 0.1, envelope=True, caps="round"),
                            Pipe([[1.3, 0, 0], [2, 0, 0]], 0.06, envelope=True, caps="round"))
    np.testing.assert_array_equal(spliced.vertices, direct.vertices)
    bad = write(tmp_path, spec.read_text().replace("envelope = true", "envelop = true"))
    with pytest.raises(cadpipe.SpecError, match="envelop"):
        read(bad)


BAD_SPECS = [
    # (spec body, message fragments): each names the file, the key path and what was expected
    ("""
     [[parts]]
     kind = "box"
     size = 1
     colour = "#fff"
     """, ["parts[0].colour: unknown key; expected one of:", "color", "size"]),
    ("""
     [[parts]]
     kind = "pipe"
     path = [[0, 0, 0], [1, 0, 0]]
     radius = "thick"
     """, ["parts[0].radius: expected a number or a list, got 'thick'"]),
    ("""
     [[parts]]
     kind = "mesh"
     file = "flange.stl"
     """, ["parts[0].file: no such file 'flange.stl'"]),
    ("""
     [[parts]]
     kind = "pipe"
     path = [[0, 0, 0], [1, 0, 0]]
     [[parts]]
     kind = "pipe"
     path = [[0, 0, 0], [1, 0, 0]]
     radius = -0.1
     """, ["parts[0].radius: missing; expected a number or a list"]),
    ("""
     [[parts]]
     kind = "pipe"
     path = [[0, 0, 0], [1, 0, 0]]
     radius = -0.1
     """, ["parts[0].radius: must be finite and > 0, got -0.1"]),
    ("""
     [[parts]]
     kind = "cylinder"
     radius = 1
     height = 2
     sides = 12.5
     """, ["parts[0].sides: expected a whole number, got 12.5"]),
    ("""
     [[parts]]
     kind = "teapot"
     """, ["parts[0].kind: unknown part kind 'teapot'; known:", "pipe", "box"]),
    ("""
     units = "furlong"
     [[parts]]
     kind = "box"
     size = 1
     """, ["units: expected one of"]),
    ("""
     [[parts]]
     kind = "box"
     size = 1
     transform = { translate = [1, 2] }
     """, ["parts[0].transform.translate: expected 3 finite numbers"]),
    ("""
     [[parts]]
     kind = "junction"
     wall = 0.01
     [[parts.pipes]]
     path = { points = [[0, 0, 0], [1, 0, 0]], smooth = true }
     radius = 0.1
     """, ["parts[0].pipes[0].path.smooth: unknown key"]),
    ("""
     [[parts]]
     kind = "pipe"
     path = { points = [[0, 0, 0], [1, 0, 0]], step = 0.1 }
     radius = 0.1
     """, ["parts[0].path.step: only a fitted path has one; add spline = true"]),
    ("""
     [[parts]]
     kind = "box"
     size = 1
     op = "xor"
     """, ["parts[0].op: expected one of 'add', 'subtract', 'intersect'"]),
    ("""
     parts = []
     """, ["parts: expected at least one part"]),
    ("""
     [[parts]]
     kind = "chain"
     [[parts.pipes]]
     path = [[0, 0, 0], [1, 0, 0]]
     radius = 0.1
     wall = 0.01
     """, ["parts[0].pipes[0].wall: give the wall on the chain, not on its pipes"]),
    ("""
     [[parts]]
     kind = "pipe"
     path = [[0, 0, 0], [1, 0, 0]]
     radius = 0.1
     ends = "closed"
     """, ["parts[0].ends: only a hollow pipe has open or closed ends; give wall too"]),
    ("""
     [[parts]]
     kind = "box"
     size = 1
     name = "a"
     [[parts]]
     kind = "box"
     size = 1
     name = "a"
     """, ["parts[1].name: a part named 'a' is already in the assembly"]),
    ("""
     parts = [1, 2]
     """, ["parts[0]: expected a table, got 1"]),
    ("""
     [[parts]
     kind = "box"
     """, ["not valid TOML"]),
]


@pytest.mark.parametrize("body, fragments", BAD_SPECS)
def test_bad_specs_name_file_key_and_expectation(tmp_path, body, fragments):
    spec = write(tmp_path, body)
    with pytest.raises(cadpipe.SpecError) as err:
        read(spec)
    message = str(err.value)
    assert message.startswith(f"{spec}: ")
    for fragment in fragments:
        assert fragment in message


def test_missing_spec_and_unknown_format(tmp_path):
    with pytest.raises(cadpipe.SpecError, match="no such spec file"):
        read(tmp_path / "none.toml")
    with pytest.raises(cadpipe.SpecError, match="use .toml or .json"):
        read(write(tmp_path, "a: 1", "cell.yaml"))


def test_loading_a_spec_runs_no_code(tmp_path):
    marker = tmp_path / "pwned"
    spec = write(tmp_path, f"""
        [[parts]]
        kind = "box"
        size = 1
        name = "__import__('os').system('touch {marker}')"
        """)
    asm = cadpipe.load(spec)
    asm.union()
    assert not marker.exists() and asm.parts[0].name.startswith("__import__")


PLUGIN = '''
from cadpipe.solids import primitives
from cadpipe.spec import Number


def tetra(ctx, *, edge: Number = 1.0):
    """The corner tetrahedron x, y, z >= 0, x + y + z <= edge."""
    import cadpipe
    v = [[0, 0, 0], [edge, 0, 0], [0, edge, 0], [0, 0, edge]]
    return cadpipe.Mesh(v, [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
'''


def test_a_plugin_part_kind_is_usable_from_a_spec(tmp_path):
    """A tiny installed package (module + .dist-info with an entry point) adds a kind."""
    site = tmp_path / "site"
    (site / "cadpipe_tetra").mkdir(parents=True)
    (site / "cadpipe_tetra" / "__init__.py").write_text(PLUGIN)
    info = site / "cadpipe_tetra-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: cadpipe-tetra\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text("[cadpipe.parts]\ntetra = cadpipe_tetra:tetra\n")
    spec = write(tmp_path, """
        units = "mm"
        [[parts]]
        kind = "tetra"
        edge = 30
        [[parts]]
        kind = "box"
        size = 10
        """)
    out = tmp_path / "out" / "tetra.stl"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(site), *sys.path])}
    done = subprocess.run([sys.executable, "-m", "cadpipe", "build", str(spec), "-o", str(out),
                           "--quiet"], env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    solid = cadpipe.Mesh.load(out)
    tetra, box, corner = 30 ** 3 / 6, 10 ** 3, 5 ** 3    # the box's corner in the first
    assert solid.is_watertight                           # octant lies inside the tetrahedron
    assert solid.volume == pytest.approx(tetra + box - corner, rel=1e-6)
