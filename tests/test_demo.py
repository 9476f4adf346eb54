"""`make demo` end to end: every file a new user is promised, valid and showing the cell."""

import json

import numpy as np
import pytest
from PIL import Image

import cadpipe
from cadpipe.cli import welding_cell as demo
from cadpipe.cli import main
from cadpipe.io.preview import render_png


@pytest.fixture(scope="module")
def demo_folder(tmp_path_factory):
    folder = tmp_path_factory.mktemp("demo")
    lines = []
    demo.run_demo(folder, echo=lines.append)
    return folder, lines


def test_every_promised_file_is_written(demo_folder):
    folder, lines = demo_folder
    for name in demo.FILES:
        assert (folder / name).is_file() and (folder / name).stat().st_size > 0, name
    assert any(str(folder) in line for line in lines)


def test_parts_stl_is_a_watertight_printable_solid(demo_folder):
    mesh = cadpipe.Mesh.load(demo_folder[0] / "parts.stl")
    assert mesh.is_watertight and mesh.volume > 0
    assert mesh.n_bodies == 2               # the spliced safety pipe and the hollow tee


@pytest.mark.parametrize("name", ["scene.usda", "scene.usdz"])
def test_usd_passes_usd_core_validation(demo_folder, name):
    from pxr import Usd, UsdGeom, UsdValidation

    stage = Usd.Stage.Open(str(demo_folder[0] / name))
    context = UsdValidation.ValidationContext(
        UsdValidation.ValidationRegistry().GetOrLoadAllValidators())
    assert [e.GetMessage() for e in context.Validate(stage)] == []
    meshes = [p for p in stage.Traverse() if p.IsA(UsdGeom.Mesh)]
    assert len(meshes) >= 10
    assert UsdGeom.GetStageMetersPerUnit(stage) == 1.0


def test_report_names_the_colliding_pair_and_a_verified_certificate(demo_folder):
    report = json.loads((demo_folder[0] / "report.json").read_text())
    pairs = [{c["a"], c["b"]} for c in report["collision"]["collisions"]]
    assert pairs == [{"tool", "workpiece"}]
    assert report["certificate"]["verified"] is True
    assert {report["certificate"]["a"], report["certificate"]["b"]} == {"upper_arm",
                                                                        "coolant_tee"}
    assert report["safety_pipe"]["watertight"] and report["safety_pipe"]["torch_path_inside"]
    assert report["printable"]["watertight"]


def _pixels(path):
    return np.asarray(Image.open(path).convert("RGB"), dtype=np.float64)


def test_preview_is_not_blank_and_follows_the_scene(demo_folder, tmp_path):
    shown = _pixels(demo_folder[0] / "preview.png")
    assert shown.std() > 20
    # the colliding parts are highlighted in red
    assert ((shown[..., 0] > 200) & (shown[..., 1] < 90) & (shown[..., 2] < 90)).sum() > 200
    cell = demo.build_cell()
    cell.assembly.add("extra", cadpipe.primitives.box([0.2, 0.2, 0.2]))
    render_png(cell.assembly, tmp_path / "other.png")
    other = _pixels(tmp_path / "other.png")
    assert np.abs(other - shown).mean() > 1.0


def test_demo_command_prints_a_summary(tmp_path, capsys):
    assert main(["demo", "-o", str(tmp_path / "d")]) == 0
    out = capsys.readouterr().out
    assert "COLLISION  tool <-> workpiece" in out
    assert "wrote 9 files" in out


@pytest.mark.slow
def test_the_whole_cell_as_one_solid_survives_every_file(tmp_path):
    # it had one non-manifold edge after reading back: a pinch point of two arm links; and
    # 3MF's and OBJ's decimals moved the links' tangent contact by 1e-9 m, which counted
    # as 58 pairs of crossing faces
    from cadpipe.solids.validity import check_mesh

    cell = demo.build_cell()
    for suffix in ("stl", "3mf", "glb", "obj", "ply", "usdc"):
        reread = cadpipe.Mesh.load(cell.assembly.export(tmp_path / f"cell.{suffix}", "solid"))
        report = check_mesh(reread)
        assert report["valid"], (suffix, report["problems"])
        assert report["nonmanifold_edges"] == 0 and report["bodies"] == 2, suffix
