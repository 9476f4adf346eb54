"""``cadpipe build``: exit codes, outputs written whole or not at all."""

import textwrap
from pathlib import Path as FilePath

import numpy as np
import pytest

import cadpipe
from cadpipe.cli import main

EXAMPLES = FilePath(__file__).parent.parent / "assets" / "examples"

GOOD = """
    name = "cell"
    outputs = ["out/cell.stl"]
    [[parts]]
    kind = "pipe"
    path = [[0, 0, 0], [1, 0, 0]]
    radius = 0.1
    wall = 0.02
    [[parts]]
    kind = "sphere"
    radius = 0.15
    op = "subtract"
    """


def spec(folder, body=GOOD):
    path = folder / "cell.toml"
    path.write_text(textwrap.dedent(body))
    return path


def files(folder):
    return sorted(p.relative_to(folder) for p in folder.rglob("*") if p.is_file())


def test_build_writes_each_output_and_exits_0(tmp_path, capsys):
    out = tmp_path / "new" / "folder"
    manifold = str(EXAMPLES / "manifold.toml")
    assert main(["build", manifold, "-o", str(out / "parts.stl"), "--mode", "parts"]) == 0
    assert main(["build", manifold, "-o", str(out / "m.stl"), "-o", str(out / "m2.stl")]) == 0
    solid, parts = cadpipe.Mesh.load(out / "m.stl"), cadpipe.Mesh.load(out / "parts.stl")
    assert solid.is_watertight and solid.n_bodies == 1
    assert parts.n_bodies > 1 and parts.volume > solid.volume   # parts overlap, unmerged
    assert (out / "m2.stl").read_bytes() == (out / "m.stl").read_bytes()
    printed = capsys.readouterr().out
    assert "manifold: 8 parts" in printed and f"wrote {out / 'm.stl'}" in printed


def test_build_defaults_to_the_spec_outputs_beside_the_spec(tmp_path, capsys):
    code = main(["build", str(spec(tmp_path)), "--quiet"])
    assert code == 0
    assert capsys.readouterr() == ("", "")
    assert cadpipe.Mesh.load(tmp_path / "out" / "cell.stl").is_watertight


@pytest.mark.parametrize("body, output, fragment", [
    (GOOD.replace("radius = 0.1", "radius = -0.1"), "x.stl", "parts[0].radius: must be"),
    (GOOD.replace("wall = 0.02", "wall = 0.02\n    colour = 1"), "x.stl", "parts[0].colour"),
    (GOOD, "x.unknown", "unknown output format"),
    (GOOD.replace("op = \"subtract\"", "op = \"intersect\"").replace("0.15", "0.01")
     .replace("[[parts]]\n    kind = \"sphere\"", "[[parts]]\n    transform = "
              "{ translate = [5, 0, 0] }\n    kind = \"sphere\""), "x.stl", "nothing is left"),
])
def test_user_errors_exit_1_with_one_line_and_write_nothing(tmp_path, capsys, body, output,
                                                            fragment):
    path = spec(tmp_path, body)
    before = files(tmp_path)
    code = main(["build", str(path), "-o", str(tmp_path / "out" / output)])
    assert code == 1
    err = capsys.readouterr().err
    assert err.startswith("cadpipe build: error: ") and fragment in err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert files(tmp_path) == before


def test_a_spec_without_outputs_needs_o(tmp_path, capsys):
    path = spec(tmp_path, GOOD.replace('outputs = ["out/cell.stl"]', ""))
    assert main(["build", str(path)]) == 1
    assert "pass -o FILE" in capsys.readouterr().err


@pytest.mark.parametrize("argv", [["build"], ["build", "x.toml", "--mode", "both"],
                                  ["build", "x.toml", "--bogus"]])
def test_bad_usage_exits_2(argv):
    with pytest.raises(SystemExit) as exit_:
        main(argv)
    assert exit_.value.code == 2


TWO_CROSSING = """
    name = "cross"
    [[parts]]
    kind = "pipe"
    path = [[0, 0, 0], [1, 0, 0]]
    radius = 0.1
    [[parts]]
    kind = "pipe"
    path = [[0.5, -0.5, 0], [0.5, 0.5, 0]]
    radius = 0.1
    [[parts]]
    kind = "box"
    size = 0.2
    transform = { translate = [5, 0, 0] }
    """


def test_plain_progress_is_one_line_per_stage_with_counts(tmp_path, capsys):
    path = spec(tmp_path, TWO_CROSSING)
    assert main(["build", str(path), "-o", str(tmp_path / "a.stl"),
                 "-o", str(tmp_path / "b.glb")]) == 0
    lines = [line for line in capsys.readouterr().out.splitlines()
             if line.startswith("cadpipe build: ")]
    assert lines == ["cadpipe build: reading cell.toml", "cadpipe build: meshing 3 parts",
                     "cadpipe build: union of 2 solids in 1 group",   # the box overlaps nothing
                     "cadpipe build: writing a.stl (1/2)",
                     "cadpipe build: writing b.glb (2/2)",
                     "cadpipe build: summing up "
                     f"{len(cadpipe.load(path).union().faces):,} triangles"]


def test_plain_progress_names_the_join_of_a_large_union(tmp_path, capsys):
    rng = np.random.default_rng(3)
    rods = "".join(f"[[parts]]\nkind = \"pipe\"\nradius = 0.03\nsides = 6\n"
                   f"path = {np.round(rng.uniform(0, 1, (2, 3)), 4).tolist()}\n"
                   for _ in range(70))
    path = spec(tmp_path, 'name = "rods"\n' + rods)
    assert main(["build", str(path), "-o", str(tmp_path / "rods.stl")]) == 0
    lines = [line for line in capsys.readouterr().out.splitlines()
             if line.startswith("cadpipe build: union")]
    # one group of 70 crossing rods, united in 8 batches, then the batches joined
    assert lines == ["cadpipe build: union of 70 solids in 1 group",
                     "cadpipe build: union of 70 solids in 1 group: joining 8 batches"]


@pytest.mark.slow
def test_check_accepts_what_build_writes_of_a_union_of_many_crossing_pipes(tmp_path, capsys):
    # float32 rounding shortened a few edges manifold3d's simplify had left to nothing:
    # the files welded their ends, and check found edges of three or four faces
    rng = np.random.default_rng(0)
    rods = []
    for _ in range(400):
        steps = rng.normal(size=(3, 3))
        steps *= 0.15 / np.linalg.norm(steps, axis=1, keepdims=True)
        start = rng.uniform(0.1, 0.9, 3)
        path = np.clip(np.vstack([start, start + np.cumsum(steps, axis=0)]), 0, 1)
        rods.append(f"[[parts]]\nkind = \"pipe\"\nradius = 0.01\nsides = 12\n"
                    f"path = {np.round(path, 6).tolist()}\n")
    path = spec(tmp_path, 'name = "rods"\n' + "".join(rods))
    outputs = [tmp_path / f"rods.{suffix}" for suffix in ("stl", "3mf", "glb")]
    assert main(["build", str(path), "-q", *[a for o in outputs for a in ("-o", str(o))]]) == 0
    for output in outputs:
        assert main(["check", str(output)]) == 0, capsys.readouterr().out


def test_spec_outputs_reach_every_export_option(tmp_path, capsys):
    path = spec(tmp_path, TWO_CROSSING + """
    [[outputs]]
    file = "plate.stl"
    layout = "print"
    units = "m"
    [[outputs]]
    file = "text.stl"
    ascii = true
    [[outputs]]
    file = "scene.stl"
    """)
    assert main(["build", str(path), "--quiet"]) == 0
    asm = cadpipe.load(path)
    reference = asm.export(tmp_path / "reference.stl", layout="print", units="m")
    assert (tmp_path / "plate.stl").read_bytes() == reference.read_bytes()
    plate = cadpipe.Mesh.load(tmp_path / "plate.stl")
    assert plate.bounds[0][2] == pytest.approx(0.0, abs=1e-9)    # on the bed (read as mm)
    assert (tmp_path / "text.stl").read_bytes().startswith(b"solid")
    scene = cadpipe.Mesh.load(tmp_path / "scene.stl")
    assert scene.bounds[0][2] == pytest.approx(-100.0, rel=1e-6)  # where it sits, in mm
    # the command line's options win over the spec's
    assert main(["build", str(path), "--quiet", "--layout", "scene", "--units", "mm"]) == 0
    assert cadpipe.Mesh.load(tmp_path / "plate.stl").bounds[0][2] == pytest.approx(-100.0,
                                                                                  rel=1e-6)


@pytest.mark.parametrize("table, key", [
    ('file = "x.stl"\n    crease_angle = 30', "outputs[0].crease_angle"),
    ('file = "x.stl"\n    ascii = "yes"', "outputs[0].ascii"),
    ('file = "x.stl"\n    layout = "plate"', "outputs[0].layout"),
    ('file = "x.glb"\n    units = "furlong"', "outputs[0].units"),
])
def test_bad_output_options_name_their_key_and_write_nothing(tmp_path, capsys, table, key):
    path = spec(tmp_path, TWO_CROSSING + "\n    [[outputs]]\n    " + table + "\n")
    before = files(tmp_path)
    assert main(["build", str(path)]) == 1
    err = capsys.readouterr().err
    assert f"cell.toml: {key}: " in err and err.count("\n") == 1
    assert files(tmp_path) == before


def test_overlapping_shells_of_an_imported_stl_are_unioned(tmp_path, capsys):
    from cadpipe import primitives
    from cadpipe.solids.validity import check_mesh

    cube = primitives.box(1.0)
    two = cadpipe.Mesh.concatenate([cube, cadpipe.Mesh(cube.vertices + 0.5, cube.faces)])
    two.export(tmp_path / "two.stl", units="m")
    assert not check_mesh(cadpipe.Mesh.load(tmp_path / "two.stl"))["valid"]   # as given
    path = spec(tmp_path, 'name = "imp"\n[[parts]]\nkind = "mesh"\nfile = "two.stl"\n')
    assert main(["build", str(path), "-o", str(tmp_path / "out.stl"), "--units", "mm"]) == 0
    assert "watertight=True" in capsys.readouterr().out
    out = cadpipe.Mesh.load(tmp_path / "out.stl")
    report = check_mesh(out)
    assert report["valid"], report["problems"]
    # two unit cubes (1000 mm) overlapping in a 0.5-cube: 2 - 0.125 litres... of mm^3
    assert out.volume == pytest.approx((2 - 0.125) * 1000.0 ** 3, rel=1e-6)
    assert out.n_bodies == 1
