"""What every writer shares: units, print layout, safe names, options, temporary files,
and what ``cadpipe check`` says about shells and units."""

import os
import time
import zipfile

import numpy as np
import pytest
import trimesh

import cadpipe
from cadpipe.cli import main
from cadpipe.errors import InputError
from cadpipe.core.formats import export, load_scene
from cadpipe.solids.scene import Scene, ScenePart, laid_out_for_print
from cadpipe.solids.primitives import box
from cadpipe.solids.validity import check_mesh

FORMATS = ("stl", "3mf", "glb", "obj", "ply", "usda", "usdc", "usdz")


def moved(mesh, offset):
    matrix = np.eye(4)
    matrix[:3, 3] = offset
    return mesh.transformed(matrix)


@pytest.mark.parametrize("suffix, units, scale", [
    ("stl", None, 1000.0), ("stl", "m", 1.0), ("obj", None, 1.0), ("obj", "mm", 1000.0),
    ("ply", None, 1.0), ("ply", "cm", 100.0)])
def test_unitless_formats_write_their_default_unit_or_the_one_asked(tmp_path, suffix, units,
                                                                    scale):
    mesh = box([0.2, 0.1, 0.05])                        # metres
    options = {} if units is None else {"units": units}
    target = export(mesh, tmp_path / f"box.{suffix}", **options)
    loaded = trimesh.load(target, force="mesh", process=False)   # an independent reader
    np.testing.assert_allclose(np.ptp(loaded.vertices, axis=0), [0.2 * scale, 0.1 * scale,
                                                                 0.05 * scale], rtol=1e-6)


@pytest.mark.parametrize("suffix", ["3mf", "usda"])
def test_formats_with_a_unit_store_the_one_asked(tmp_path, suffix):
    back = load_scene(export(box([0.2, 0.1, 0.05]), tmp_path / f"box.{suffix}", units="mm"))
    assert back.units == "mm"
    np.testing.assert_allclose(np.ptp(back.parts[0].mesh.vertices, axis=0), [200, 100, 50],
                               rtol=1e-6)


def test_glb_is_metres_by_definition(tmp_path):
    with pytest.raises(InputError, match="metres by definition"):
        export(box([1, 1, 1]), tmp_path / "box.glb", units="mm")
    assert not any(tmp_path.iterdir())


def test_an_option_a_format_does_not_take_is_a_clear_error(tmp_path):
    with pytest.raises(InputError, match="take no option unit") as err:
        export(box([1, 1, 1]), tmp_path / "box.stl", unit="mm")
    assert err.value.key == "unit"


def test_print_layout_stands_every_body_on_the_bed_apart(tmp_path):
    asm = cadpipe.Assembly(name="plate")
    asm.add("high", moved(box([0.02, 0.02, 0.02]), [0, 0, 0.3]), color="#ff0000")
    asm.add("low", moved(box([0.03, 0.01, 0.01]), [0.001, 0.001, -0.1]), color="#0000ff")
    scene = laid_out_for_print(asm.to_scene("solid"))
    assert sorted(p.name for p in scene.parts) == ["high", "low"]
    bounds = np.array(sorted(p.mesh.bounds.tolist() for p in scene.parts))
    np.testing.assert_allclose(bounds[:, 0, 2], 0.0, atol=1e-12)        # on the bed
    assert bounds[1, 0, 0] >= bounds[0, 1, 0] + 0.005 - 1e-12            # 5 mm apart
    target = asm.export(tmp_path / "plate.3mf", layout="print")
    with zipfile.ZipFile(target) as package:
        assert package.read("3D/3dmodel.model").count(b"<object ") == 2   # one per body


def test_print_layout_keeps_a_shell_inside_another_with_it():
    outer = box([1, 1, 1])
    cavity = cadpipe.Mesh(box([0.5, 0.5, 0.5]).vertices, box([0.5, 0.5, 0.5]).faces[:, ::-1])
    hollow = cadpipe.Mesh.concatenate([outer, cavity])
    scene = laid_out_for_print(Scene("s", (ScenePart("hollow", hollow),)))
    assert len(scene.parts) == 1 and check_mesh(scene.parts[0].mesh)["valid"]


@pytest.mark.parametrize("suffix", FORMATS)
def test_names_with_control_characters_write_and_read_back(tmp_path, suffix):
    name = "duct\x00\x07\nleft" + "x" * 300
    scene = Scene("cell\x1b", (ScenePart(name, box([1, 1, 1]), color="#ff0000"),))
    back = load_scene(export(scene, tmp_path / f"cell.{suffix}"))
    for part in back.parts:
        assert all(ord(c) >= 32 for c in part.name) and len(part.name) <= 128


def test_a_killed_write_leaves_a_temporary_file_the_next_write_removes(tmp_path):
    target = tmp_path / "pipe.stl"
    stale = tmp_path / ".pipe.stl.abc123xy.tmp.stl"   # what atomic_path names its files
    stale.write_bytes(b"half a file")
    old = time.time() - 3600
    os.utime(stale, (old, old))
    other = tmp_path / ".other.stl.abc123xy.tmp.stl"  # another target's: not ours to remove
    other.write_bytes(b"x")
    os.utime(other, (old, old))
    export(box([1, 1, 1]), target)
    assert sorted(p.name for p in tmp_path.iterdir()) == [other.name, target.name]


def test_glb_and_usd_can_leave_normals_out(tmp_path):
    from pxr import Usd, UsdGeom

    mesh = cadpipe.Pipe([[0, 0, 0], [0, 0, 1]], 0.1, sides=16).mesh()
    stage = Usd.Stage.Open(str(export(mesh, tmp_path / "p.usda", normals=False)))
    geom = UsdGeom.Mesh(stage.GetDefaultPrim().GetChild("pipe").GetChild("pipe"))
    assert not geom.GetNormalsAttr().HasValue()
    assert not UsdGeom.PrimvarsAPI(geom).HasPrimvar("normals")
    export(mesh, tmp_path / "p.glb", normals=False)
    loaded = trimesh.load(tmp_path / "p.glb", force="mesh", process=False)
    assert len(loaded.faces) == len(mesh.faces)


# -- check -------------------------------------------------------------------------
def test_check_finds_overlapping_and_nested_shells_but_accepts_cavities():
    a = box([1, 1, 1])
    overlapping = cadpipe.Mesh.concatenate([a, moved(a, [0.5, 0.5, 0.5])])
    inside = cadpipe.Mesh.concatenate([a, box([0.2, 0.2, 0.2])])
    small = box([0.2, 0.2, 0.2])
    cavity = cadpipe.Mesh.concatenate([a, cadpipe.Mesh(small.vertices, small.faces[:, ::-1])])
    apart = cadpipe.Mesh.concatenate([a, moved(a, [3, 0, 0])])
    assert not check_mesh(overlapping)["valid"] and check_mesh(overlapping)["nested_shells"]
    assert not check_mesh(inside)["valid"]
    assert check_mesh(cavity)["valid"] and check_mesh(apart)["valid"]
    # manifold3d's union of the overlapping pair is one valid solid: the reference
    union = cadpipe.Assembly().add("a", a).add("b", moved(a, [0.5, 0.5, 0.5])).union()
    assert check_mesh(union)["valid"]


def test_check_warns_when_an_stl_looks_like_metres(tmp_path, capsys):
    target = export(box([0.4, 0.6, 0.3]), tmp_path / "m.stl", units="m")
    assert main(["check", str(target)]) == 0
    assert "suggests it was written in metres" in capsys.readouterr().out
    target = export(box([0.4, 0.6, 0.3]), tmp_path / "mm.stl")
    assert main(["check", str(target)]) == 0
    assert "warning" not in capsys.readouterr().out


def test_build_names_each_stage_on_a_plain_output(tmp_path, capsys):
    spec = tmp_path / "s.toml"
    spec.write_text('name = "s"\n[[parts]]\nkind = "box"\nsize = 0.1\n')
    assert main(["build", str(spec), "-o", str(tmp_path / "s.stl"), "-o",
                 str(tmp_path / "s.glb"), "--units", "m"]) == 0
    out = capsys.readouterr().out
    for line in ("cadpipe build: meshing 1 part",
                 "cadpipe build: writing s.stl (1/2)", "cadpipe build: writing s.glb (2/2)"):
        assert line in out
    assert "union" not in out                     # one part: no boolean to run
    assert np.ptp(trimesh.load(tmp_path / "s.stl").vertices, axis=0) == pytest.approx([0.1] * 3)


@pytest.mark.parametrize("mode", ["solid", "parts"])
def test_a_streamed_usda_holds_what_usd_cores_own_text_holds(tmp_path, mode):
    """Issue 16: cadpipe writes a .usda's large arrays itself, a block at a time; opened by
    usd-core, every attribute equals that of the same stage written by usd-core."""
    from pxr import Usd

    from cadpipe.io.usd import _STREAM_ROWS, build_stage, save_stage

    t = np.linspace(0, 3, _STREAM_ROWS // 8)                  # arrays of several blocks
    assembly = cadpipe.Assembly(name="two").add(
        "wavy", cadpipe.Pipe(np.c_[t, np.sin(t), 0 * t], 0.05, sides=12), color="#ff0000")
    assembly.add("straight", cadpipe.Pipe([[0, 0.02, 0], [3, 0.02, 0]], 0.04, sides=8),
                 color="#00ff00")
    # numbers whose shortest text usd-core writes positionally (0.00001), numpy not (1e-05)
    assembly.add("tiny", cadpipe.Pipe([[0, -1e-4, 0], [1e-4, -1e-4, 0]], 2e-5, sides=8))
    ours = assembly.export(tmp_path / "ours.usda", mode=mode)
    theirs = tmp_path / "theirs.usda"
    save_stage(build_stage(assembly.to_scene(mode)), theirs)
    # the same text, number for number (usd-core formats each block: float32's shortest)
    assert ours.read_text() == theirs.read_text()
    a, b = Usd.Stage.Open(str(ours)), Usd.Stage.Open(str(theirs))
    prims = [p.GetPath() for p in b.Traverse()]
    assert [p.GetPath() for p in a.Traverse()] == prims
    compared = 0
    for path in prims:
        for attribute in b.GetPrimAtPath(path).GetAttributes():
            value = a.GetPrimAtPath(path).GetAttribute(attribute.GetName()).Get()
            expected = attribute.Get()
            if hasattr(expected, "__len__") and not isinstance(expected, str):
                assert np.array_equal(np.asarray(value), np.asarray(expected)), attribute
                compared += len(expected)
            else:
                assert value == expected, attribute
    assert compared > 3 * _STREAM_ROWS
