"""Previews: the PNG shows the scene and its highlights; the page works offline in Chromium."""

import json
import re
import shutil
import subprocess

import numpy as np
import pytest
import trimesh
from PIL import Image

from cadpipe import ExportError, InputError, Mesh, Path, Pipe
from cadpipe.cli import main
from cadpipe.io.preview import HIGHLIGHT, PALETTE, render_png, write_html
from cadpipe.solids.scene import Scene, ScenePart

SIZE = (320, 240)
TEAL = (0.15, 0.6, 0.5)


def box(extents, centre=(0, 0, 0)):
    b = trimesh.creation.box(extents)
    b.apply_translation(centre)
    return Mesh(b.vertices, b.faces)


def ball(radius, centre=(0, 0, 0)):
    s = trimesh.creation.icosphere(subdivisions=2, radius=radius)
    s.apply_translation(centre)
    return Mesh(s.vertices, s.faces)


@pytest.fixture(scope="module")
def pipe():
    points = [[0.0, 0, 0], [0.3, 0.1, 0.1], [0.5, 0.3, 0.2], [0.4, 0.5, 0.3]]
    return Pipe(Path.spline(points, step=0.02), radius=0.03, sides=12)


@pytest.fixture(scope="module")
def cell(pipe):
    """A pipe running through a workpiece: the colliding pair of a typical report."""
    return Scene("cell", (ScenePart("pipe", pipe.mesh()),
                          ScenePart("workpiece", box((0.3, 0.3, 0.15), (0.35, 0.2, 0.12)),
                                    color=TEAL)))


def picture(path):
    return np.asarray(Image.open(path).convert("RGB"), dtype=np.float64)


def near(pixels, rgb, tolerance=12.0):
    """Pixels within ``tolerance`` (0-255 units) of the colour ``rgb`` at some brightness."""
    target = np.asarray(rgb) / np.linalg.norm(rgb)
    brightness = pixels @ target
    return np.linalg.norm(pixels - brightness[..., None] * target, axis=-1) < tolerance


def colourful(pixels):
    """Pixels clearly coloured (the background is a near-grey gradient)."""
    return (pixels.max(axis=-1) - pixels.min(axis=-1)) > 40


def without_legend(mask):
    """``mask`` with the corners holding the legend (top left) and axes (bottom left) cleared."""
    mask = mask.copy()
    height, width = mask.shape
    mask[: height // 5, : width // 2] = False
    mask[-height // 3:, : width // 3] = False
    return mask


# -- the picture ----------------------------------------------------------------------
def test_png_shows_every_part_in_its_colour(tmp_path, cell):
    written = render_png(cell, tmp_path / "cell.png", size=SIZE)
    image = Image.open(written)
    assert image.size == SIZE and image.format == "PNG"
    pixels = picture(written)
    assert pixels.std() > 20                                       # not blank
    assert near(pixels, PALETTE[0]).mean() > 0.03                  # the pipe, default colour
    assert near(pixels, TEAL).mean() > 0.1                    # the workpiece, its colour
    assert not (near(pixels, HIGHLIGHT) & colourful(pixels)).any()  # nothing highlighted


def test_png_differs_when_the_scene_differs(tmp_path, cell, pipe):
    render_png(cell, tmp_path / "cell.png", size=SIZE)
    render_png(pipe, tmp_path / "pipe.png", size=SIZE)
    moved = Scene("cell", (cell.parts[0], ScenePart("workpiece", cell.parts[1].mesh,
                                                    color=TEAL, transform=_shift(0.1))))
    render_png(moved, tmp_path / "moved.png", size=SIZE)
    base = picture(tmp_path / "cell.png")
    for other in ("pipe.png", "moved.png"):
        assert np.abs(picture(tmp_path / other) - base).mean() > 3


def test_highlighted_parts_are_drawn_in_the_highlight_colour(tmp_path, cell):
    render_png(cell, tmp_path / "plain.png", size=SIZE)
    render_png(cell, tmp_path / "hit.png", size=SIZE, highlight=["pipe", "workpiece"])
    plain, hit = picture(tmp_path / "plain.png"), picture(tmp_path / "hit.png")
    assert (np.abs(hit - plain).max(axis=-1) > 30).mean() > 0.1
    assert (near(hit, HIGHLIGHT) & colourful(hit)).mean() > 0.1


def test_a_highlighted_part_hidden_inside_another_is_still_seen(tmp_path):
    hidden = Scene("s", (ScenePart("shell", box((1, 1, 1)), color=TEAL),
                         ScenePart("core", ball(0.2))))
    render_png(hidden, tmp_path / "plain.png", size=SIZE)
    render_png(hidden, tmp_path / "hit.png", size=SIZE, highlight=["core"])
    plain, hit = picture(tmp_path / "plain.png"), picture(tmp_path / "hit.png")
    redder = without_legend((hit[..., 0] - hit[..., 1]) - (plain[..., 0] - plain[..., 1]) > 40)
    rows, cols = np.nonzero(redder)
    assert redder.mean() > 0.02
    # traced where the core is: in the middle of the shell
    assert abs(rows.mean() - SIZE[1] / 2) < SIZE[1] * 0.1
    assert abs(cols.mean() - SIZE[0] / 2) < SIZE[0] * 0.1


def test_labels_of_a_unioned_mesh_keep_their_colours(tmp_path):
    a, b = box((1, 1, 1)), box((1, 1, 1), (1.5, 0, 0))
    merged = Mesh.concatenate([a.with_parts(("left",)), b.with_parts(("right",))])
    green = (0.1, 0.7, 0.2)
    scene = Scene("s", (ScenePart("assembly", merged),), colors={"left": green})
    render_png(scene, tmp_path / "plain.png", size=SIZE)
    render_png(scene, tmp_path / "hit.png", size=SIZE, highlight=["right"])
    plain, hit = picture(tmp_path / "plain.png"), picture(tmp_path / "hit.png")
    assert near(plain, green).mean() > 0.05
    assert (near(hit, HIGHLIGHT) & colourful(hit)).mean() > 0.05
    assert near(hit, green, 60).mean() > 0.02                      # left: faded, still green


@pytest.mark.parametrize("up_axis, tall", [("Z", (0.2, 0.2, 1.0)), ("Y", (0.2, 1.0, 0.2))])
def test_the_up_axis_points_up_the_picture(tmp_path, up_axis, tall):
    scene = Scene("post", (ScenePart("post", box(tall)),), up_axis=up_axis)
    for view in ("iso", "front", (30, 10)):
        render_png(scene, tmp_path / "post.png", size=SIZE, view=view)
        rows, cols = np.nonzero(without_legend(colourful(picture(tmp_path / "post.png"))))
        assert np.ptp(rows) > 2 * np.ptp(cols)


@pytest.mark.parametrize("kwargs, message", [
    ({"highlight": ["nope"]}, "no part named 'nope'"),
    ({"view": "sideways"}, "view"),
    ({"view": (1.0, float("nan"))}, "finite"),
    ({"size": (0, 100)}, "size[0]"),
    ({"size": 100}, "size"),
])
def test_bad_arguments_name_the_fix_and_write_nothing(tmp_path, cell, kwargs, message):
    with pytest.raises(InputError, match=re.escape(message)):
        render_png(cell, tmp_path / "x.png", **kwargs)
    assert not list(tmp_path.iterdir())


def test_bad_paths_and_inputs(tmp_path, cell):
    with pytest.raises(InputError, match=r"\.png"):
        render_png(cell, tmp_path / "x.jpg")
    with pytest.raises(InputError, match=r"\.html"):
        write_html(cell, tmp_path / "x.htm")
    with pytest.raises(InputError, match="mapping"):
        write_html(cell, tmp_path / "x.html", report=["not", "a", "dict"])
    with pytest.raises(InputError, match="no triangles"):
        render_png(Mesh(np.zeros((0, 3)), np.zeros((0, 3), int)), tmp_path / "x.png")
    with pytest.raises(ExportError, match="does not exist"):
        render_png(cell, tmp_path / "missing" / "x.png")
    assert not list(tmp_path.iterdir())


def _shift(dx):
    matrix = np.eye(4)
    matrix[0, 3] = dx
    return matrix


# -- the page, in headless Chromium ------------------------------------------------------
WINDOW = (1000, 700)
PANEL = 340                    # width of the page's side panel (px), see cadpipe.io.preview
# everything a browser could reach out to is closed: no DNS, a dead proxy, no QUIC
OFFLINE = ["--host-resolver-rules=MAP * ~NOTFOUND", "--proxy-server=http://127.0.0.1:9",
           "--disable-quic", "--disable-background-networking", "--disable-component-update",
           "--disable-sync", "--no-first-run"]


def chromium_screenshot(page, shot, profile):
    """Open ``page`` offline in headless Chromium; save a screenshot, return its console."""
    browser = shutil.which("chromium")
    assert browser, "Debian's chromium is needed for this test: run `make chromium` as root"
    command = [browser, "--headless", "--no-sandbox", "--disable-gpu",
               "--use-angle=swiftshader", "--enable-unsafe-swiftshader", *OFFLINE,
               f"--user-data-dir={profile}", "--enable-logging=stderr", "--v=0",
               f"--window-size={WINDOW[0]},{WINDOW[1]}", "--virtual-time-budget=10000",
               f"--screenshot={shot}", page.as_uri()]
    run = subprocess.run(command, capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr[-2000:]
    # console messages of the page and its viewer frame (not of Chromium's own pages)
    return [line for line in run.stderr.splitlines() if ":CONSOLE" in line
            and re.search(rf"source: ({re.escape(page.as_uri())}|about:srcdoc)", line)]


@pytest.fixture(scope="module")
def page(tmp_path_factory, cell):
    folder = tmp_path_factory.mktemp("page")
    report = {"colliding": True, "pairs": [{"a": "pipe", "b": "workpiece",
                                             "depth": np.float64(0.012)}]}
    path = write_html(cell, folder / "preview.html", report=report, highlight=["pipe"])
    console = chromium_screenshot(path, folder / "shot.png", folder / "profile")
    return path, picture(folder / "shot.png"), console


def test_page_loads_without_script_errors(page):
    _, _, console = page
    errors = [line for line in console if re.search(r"Uncaught|Error|Failed", line)]
    assert not errors, errors


def test_page_draws_the_scene_in_its_canvas(page):
    _, shot, _ = page
    viewer = shot[:, : WINDOW[0] - PANEL - 10]
    assert viewer.std() > 15                                        # not blank
    assert (near(viewer, HIGHLIGHT) & colourful(viewer)).mean() > 0.005   # the pipe
    assert near(viewer, TEAL).mean() > 0.02                    # the workpiece


def test_page_is_self_contained_and_shows_the_report(page):
    path, _, _ = page
    text = path.read_text()
    assert not re.search(r"""(src|href)\s*=\s*["']?(https?:)?//""", text)   # nothing fetched
    assert "pipe" in text and "workpiece" in text
    assert "colliding" in text
    shown = json.dumps([{"a": "pipe", "b": "workpiece", "depth": 0.012}], indent=2)
    assert shown.replace('"', "&quot;") in text


# -- the command ---------------------------------------------------------------------------
def test_cadpipe_view_writes_both_previews(tmp_path, pipe, capsys):
    mesh_file = pipe.mesh().export(tmp_path / "pipe.stl")
    assert main(["view", str(mesh_file), "-o", str(tmp_path / "out"),
                 "--view", "top"]) == 0
    png, page = tmp_path / "out" / "preview.png", tmp_path / "out" / "preview.html"
    assert picture(png).std() > 20
    assert "<iframe" in page.read_text()
    assert f"wrote {png}" in capsys.readouterr().out


@pytest.mark.parametrize("args, message", [
    (["missing.stl"], "no such file"),
    (["pipe.stl", "--highlight", "arm"], "no part named 'arm'"),
    (["pipe.stl", "-o", "pipe.stl/out"], "pipe.stl is a file"),
])
def test_cadpipe_view_errors_are_one_line(tmp_path, pipe, capsys, monkeypatch, args, message):
    monkeypatch.chdir(tmp_path)
    pipe.mesh().export(tmp_path / "pipe.stl")
    assert main(["view", *args]) == 1
    err = capsys.readouterr().err
    assert err.startswith("cadpipe view: error:") and message in err
    assert err.count("\n") == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pipe.stl"]
