"""``cadpipe build``: exit codes, outputs written whole or not at all."""

import textwrap
from pathlib import Path as FilePath

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
