"""The files cadpipe writes open in the programs people use them with.

PrusaSlicer slices the STL and 3MF (layers, no "empty" or "not manifold"
warning), lib3mf (the 3MF Consortium's reader) reads the 3MF with a colour per
part and no warnings, the Khronos glTF validator finds no errors in the GLB,
the USDZ follows AR Quick Look's rules (all of it on the demo's files and on
each example spec's), and Blender shows the parts of a GLB and a USD named,
coloured, at size and shaded as cadpipe shades them. The programs are installed
by ``make consumers``.
"""

import json
import subprocess
from pathlib import Path as FilePath

import numpy as np
import pytest
from scipy.spatial import cKDTree

import cadpipe
from cadpipe.cli import main
from cadpipe.cli.welding_cell import build_cell, run_demo
from cadpipe.core.formats import export, load_scene
from cadpipe.io.flatten import labelled
from cadpipe.io.normals import shading_normals
from cadpipe.solids.scene import as_scene

ROOT = FilePath(__file__).resolve().parent.parent
EXAMPLES = sorted(p for p in (ROOT / "assets" / "examples").iterdir()
                  if p.suffix in (".toml", ".json"))
#: each example's spec file suffix, by stem
SPEC_SUFFIX = {p.stem: p.suffix for p in EXAMPLES}
VALIDATOR = ROOT / ".tools" / "node_modules" / "gltf-validator"
#: a bed big enough for the demo's half-metre parts (the slicer's default is 200 mm), and a
#: coarse print (1 mm nozzle, 0.7 mm layers, one perimeter, no infill) that slices fast
SLICER = ["--bed-shape", "0x0,2000x0,2000x2000,0x2000", "--max-print-height", "1000",
          "--nozzle-diameter", "1", "--layer-height", "0.7", "--first-layer-height", "0.7",
          "--fill-density", "0", "--perimeters", "1", "--skirts", "0",
          "--top-solid-layers", "0", "--bottom-solid-layers", "1"]
#: a line PrusaSlicer's Arachne perimeter generator logs at random, whatever the mesh
ARACHNE_NOTE = "reversing even wall line causes it to be printed ccw instead of cw"
#: every format an example is built into: the printing ones laid out for the bed
PRINTING, SCENES = ("stl", "3mf"), ("glb", "usdz", "usda", "obj", "ply")

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    folder = tmp_path_factory.mktemp("demo")
    run_demo(folder, echo=lambda *_: None)
    return folder




@pytest.fixture(scope="module", params=[p.name for p in EXAMPLES])
def example(request, tmp_path_factory):
    """An example spec built into every format (printing ones laid out), by two builds."""
    folder = tmp_path_factory.mktemp(FilePath(request.param).stem)
    spec = ROOT / "assets" / "examples" / request.param
    stem = spec.stem
    for formats, layout in ((PRINTING, ["--layout", "print"]), (SCENES, [])):
        outputs = [arg for suffix in formats for arg in ("-o", str(folder / f"{stem}.{suffix}"))]
        assert main(["build", str(spec), "-q", *outputs, *layout]) == 0
    return folder, stem


# -- PrusaSlicer -------------------------------------------------------------------
def slice_file(path, tmp_path):
    out = tmp_path / (path.stem + ".gcode")
    run = subprocess.run(["prusa-slicer", "--export-gcode", str(path), *SLICER, "-o", str(out)],
                         capture_output=True, text=True, timeout=300)
    log = (run.stdout + run.stderr).replace(str(out), "OUT").replace(str(path), "IN").lower()
    assert run.returncode == 0 and out.is_file(), log[-2000:]
    # Arachne's wall ordering logs this at error level now and then on the same file (1 run
    # in 8 of spliced_duct): the slicer's own choice of direction, not a problem of the mesh
    log = "\n".join(line for line in log.splitlines() if ARACHNE_NOTE not in line)
    for warning in ("empty", "manifold", "repaired", "no extrusions", "error"):
        assert warning not in log, log[-2000:]
    return out.read_text().count(";LAYER_CHANGE")


@pytest.mark.parametrize("name", ["parts.stl", "parts.3mf"])
def test_prusaslicer_slices_the_demo_parts(demo, tmp_path, name):
    layers = slice_file(demo / name, tmp_path)
    # the tallest part stands about 0.23 m on the bed: some 330 layers of 0.7 mm
    assert 250 < layers < 450


def test_prusaslicer_slices_each_example(example, tmp_path):
    folder, stem = example
    # the STL: the 3MF writer's output is sliced on the demo, and read by lib3mf here too
    assert slice_file(folder / f"{stem}.stl", tmp_path) > 0


def test_demo_parts_stand_on_the_bed_in_millimetres(demo):
    mesh = cadpipe.Mesh.load(demo / "parts.stl")
    low, high = mesh.bounds
    assert low[2] == pytest.approx(0.0, abs=1e-6)
    assert 100 < (high - low).max() < 2000          # hundreds of mm, not a fraction of one


# -- cadpipe check: build never writes a solid that check rejects -------------------------
def test_check_accepts_every_file_the_demo_writes(demo, capsys):
    for name in ("parts.stl", "parts.3mf", "scene.glb", "scene.usda", "scene.usdz"):
        assert main(["check", str(demo / name)]) == 0, (name, capsys.readouterr().out)


def test_check_accepts_every_file_each_example_builds(example, capsys):
    folder, stem = example
    for suffix in PRINTING + SCENES:
        assert main(["check", str(folder / f"{stem}.{suffix}")]) == 0, \
            (suffix, capsys.readouterr().out)


# -- lib3mf --------------------------------------------------------------------------
def lib3mf_colours(path):
    """{object name: {(r, g, b) of its triangles}} and the reader's warning count."""
    import lib3mf

    wrapper = lib3mf.get_wrapper()
    model = wrapper.CreateModel()
    reader = model.QueryReader("3mf")
    reader.SetStrictModeActive(True)
    reader.ReadFromFile(str(path))
    colours = {}
    objects = model.GetMeshObjects()
    while objects.MoveNext():
        mesh = objects.GetCurrentMeshObject()
        found = set()
        for prop in mesh.GetAllTriangleProperties():
            group = model.GetBaseMaterialGroupByID(prop.ResourceID)
            rgb = group.GetDisplayColor(prop.PropertyIDs[0])
            found.add((rgb.Red, rgb.Green, rgb.Blue))
        colours[mesh.GetName()] = found
    return colours, reader.GetWarningCount()


def test_lib3mf_reads_the_demo_parts_with_their_colours(demo):
    colours, warnings = lib3mf_colours(demo / "parts.3mf")
    assert warnings == 0
    assert colours == {"safety_pipe": {(0x3B, 0x82, 0xF6)}, "coolant_tee": {(0xF5, 0x9E, 0x0B)}}


def test_lib3mf_reads_each_example_with_a_colour_per_part(example):
    folder, stem = example
    colours, warnings = lib3mf_colours(folder / f"{stem}.3mf")
    assert warnings == 0 and colours
    assert len(set(colours)) == len(colours)
    assert all(found for found in colours.values())      # every triangle has a colour


def test_3mf_parts_mode_gives_each_part_its_own_colour(tmp_path):
    plate = cadpipe.Pipe([[0, 0, 0], [0.1, 0, 0]], 0.02, sides=12)
    asm = cadpipe.Assembly(units="mm", name="cell")
    asm.add("duct", plate, color="#ff0000")
    asm.add("plate", cadpipe.Pipe([[0, 0.1, 0], [0.1, 0.1, 0]], 0.02, sides=8),
            color="#0000ff")
    colours, warnings = lib3mf_colours(asm.export(tmp_path / "cell.3mf", mode="parts"))
    assert warnings == 0
    assert colours == {"duct": {(255, 0, 0)}, "plate": {(0, 0, 255)}}


# -- Khronos glTF validator ------------------------------------------------------------
def gltf_report(path):
    script = ("const v = require(process.argv[1]); const fs = require('fs');"
              "v.validateBytes(new Uint8Array(fs.readFileSync(process.argv[2])))"
              ".then(r => console.log(JSON.stringify(r.issues)))"
              ".catch(e => { console.error(e); process.exit(2); });")
    run = subprocess.run(["node", "-e", script, str(VALIDATOR), str(path)],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    return json.loads(run.stdout)


def test_gltf_validator_finds_no_problem_in_the_demo_scene(demo):
    issues = gltf_report(demo / "scene.glb")
    assert issues["numErrors"] == 0 and issues["numWarnings"] == 0, issues["messages"][:5]


def test_gltf_validator_finds_no_error_in_each_example(example):
    folder, stem = example
    issues = gltf_report(folder / f"{stem}.glb")
    assert issues["numErrors"] == 0 and issues["numWarnings"] == 0, issues["messages"][:5]


# -- AR Quick Look (usdz) ---------------------------------------------------------------
#: prim types AR Quick Look draws (the ARKit rules of usd-core's former compliance checker)
ARKIT_PRIM_TYPES = {"", "Scope", "Xform", "Camera", "Shader", "Material", "Mesh", "Sphere",
                    "Cube", "Cylinder", "Cone", "Capsule", "GeomSubset", "Points",
                    "SkelRoot", "Skeleton", "SkelAnimation", "BlendShape", "SpatialAudio"}
ARKIT_SHADERS = {"UsdPreviewSurface", "UsdUVTexture", "UsdTransform2d"}


def arkit_problems(path):
    """What keeps a .usdz from AR Quick Look: usd-core's usdz validators, Y up, a binary
    root layer alone in the package, and only the prim and shader types ARKit knows."""
    import zipfile

    from pxr import Usd, UsdGeom, UsdShade, UsdValidation

    wanted = {"UsdzValidators", "UsdGeomValidators", "UsdShadeValidators", "UsdCoreValidators"}
    validators = [v for v in UsdValidation.ValidationRegistry().GetOrLoadAllValidators()
                  if wanted & set(v.GetMetadata().GetKeywords())]
    stage = Usd.Stage.Open(str(path))
    problems = [f"{e.GetName()}: {e.GetMessage()}"
                for e in UsdValidation.ValidationContext(validators).Validate(stage)]
    if UsdGeom.GetStageUpAxis(stage) != UsdGeom.Tokens.y:
        problems.append("upAxis is not Y")
    with zipfile.ZipFile(path) as package:
        names = package.namelist()
    if len(names) != 1 or not names[0].endswith(".usdc"):
        problems.append(f"package holds {names}, not one binary layer")
    for prim in stage.Traverse():
        if prim.GetTypeName() not in ARKIT_PRIM_TYPES:
            problems.append(f"{prim.GetPath()}: prim type {prim.GetTypeName()}")
        if prim.IsA(UsdShade.Shader) and UsdShade.Shader(prim).GetIdAttr().Get() not in \
                ARKIT_SHADERS:
            problems.append(f"{prim.GetPath()}: shader {UsdShade.Shader(prim).GetIdAttr().Get()}")
    return problems


def test_the_demo_usdz_follows_the_arkit_rules(demo):
    assert arkit_problems(demo / "scene.usdz") == []


def test_each_example_usdz_follows_the_arkit_rules(example):
    folder, stem = example
    assert arkit_problems(folder / f"{stem}.usdz") == []


# -- MeshLab (pymeshlab) and Blender's PLY colours ---------------------------------------
#: the colours of the three crossing pipes of :func:`crossing`, by part name
PALETTE = {"a": (255, 0, 0), "b": (0, 0, 255), "c": (0, 255, 0)}


@pytest.fixture(scope="module")
def crossing():
    """Three crossing pipes of three colours: their union has faces of each colour, and
    vertices where the colours meet."""
    asm = cadpipe.Assembly(name="cross")
    asm.add("a", cadpipe.Pipe([[0, 0, 0], [1, 0, 0]], 0.2, sides=12), color="#ff0000")
    asm.add("b", cadpipe.Pipe([[0.5, -0.5, 0], [0.5, 0.5, 0]], 0.2, sides=12), color="#0000ff")
    asm.add("c", cadpipe.Pipe([[0.5, 0, -0.5], [0.5, 0, 0.5]], 0.15, sides=8), color="#00ff00")
    union = asm.union()
    return asm, union, np.array([PALETTE[n] for n in union.part_names])[union.face_part]


@pytest.mark.parametrize("ascii", [False, True])
def test_meshlab_reads_the_colours_of_a_union_per_face_and_per_vertex(tmp_path, crossing,
                                                                        ascii):
    """Blender's PLY importer reads vertex colours only, MeshLab both: each face's corners
    must carry its part's colour, so vertices where parts meet are written once per colour
    (and only those)."""
    import pymeshlab

    asm, union, expected = crossing
    ms = pymeshlab.MeshSet()
    ms.load_new_mesh(str(asm.export(tmp_path / "cross.ply", ascii=ascii)))
    read = ms.current_mesh()
    faces, points = read.face_matrix(), read.vertex_matrix()
    face_rgb = np.round(read.face_color_matrix()[:, :3] * 255)
    corner_rgb = np.round(read.vertex_color_matrix()[:, :3] * 255)[faces]
    np.testing.assert_array_equal(face_rgb, expected)
    np.testing.assert_array_equal(corner_rgb, np.repeat(expected[:, None], 3, axis=1))
    np.testing.assert_array_equal(points[faces], union.triangles.astype(np.float32))
    # one vertex per (vertex, colour) pair of the union's corners: split only where colours meet
    pairs = np.unique(np.c_[union.faces.ravel(), np.repeat(union.face_part, 3)], axis=0)
    assert read.vertex_number() == len(pairs) > len(union.vertices)


@pytest.mark.parametrize("suffix", ["3mf", "ply", "glb", "usdc"])
def test_a_unions_face_colours_read_back(tmp_path, crossing, suffix):
    # cadpipe's 3MF reader went through trimesh, which reads no 3MF colours: all grey
    asm, union, expected = crossing
    back = load_scene(asm.export(tmp_path / f"cross.{suffix}", mode="solid"))
    (part,) = back.parts
    painted = labelled(back, part)
    found = np.round(painted.colors[painted.labels] * 255)
    # each face read matched to the union's face with the same centre (float32 apart)
    centres = part.world_mesh(back.scale_to(asm.units)).triangles.mean(axis=1)
    distance, face = cKDTree(union.triangles.mean(axis=1)).query(centres)
    assert distance.max() < 1e-6 and len(np.unique(face)) == len(union.faces)
    np.testing.assert_array_equal(found, expected[face])


# -- Blender -----------------------------------------------------------------------------
#: Blender as a Python module (bpy), in a venv of its own (``make consumers``)
BLENDER = ROOT / ".tools" / "blender" / "bin" / "python"


def blender_reads(path, out):
    """What Blender's importer makes of ``path`` (see ``tests/blender_probe.py``)."""
    run = subprocess.run([str(BLENDER), str(ROOT / "tests" / "blender_probe.py"), str(out),
                          str(path)], capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, (run.stdout + run.stderr)[-2000:]
    return (json.loads((out / f"{path.name}.json").read_text()),
            np.load(out / f"{path.name}.npz"))


def blender_name(name, path):
    """The name a part or the scene has in ``path`` as Blender imports it: a USD prim's
    name is an identifier (``docs/export.md``: "y-junction" becomes ``y_junction``)."""
    if path.suffix == ".glb":
        return name
    from pxr import Tf

    return Tf.MakeValidIdentifier(name)


def assert_blender_shows(scene, path, out):
    """Blender shows each part of ``scene`` as an object of its name under the scene's,
    with its colours, at its size in metres, shaded with cadpipe's normals; from USD each
    part is one closed surface (every edge between two faces).

    Blender's objects share one namespace: where a part is named as its scene is, one of
    the two becomes ``<name>.001``."""
    objects, arrays = blender_reads(path, out)
    root = blender_name(scene.name, path)
    assert len(objects) == len(scene.parts)
    for part in scene.parts:
        name = blender_name(part.name, path)
        clash = name == root and name not in objects
        found = objects[name + ".001" if clash else name]
        assert found["parent"] in ((root, root + ".001") if name == root else (root,))
        # a material per colour of the part's faces, named after its source part
        painted = labelled(scene, part)
        used = np.unique(painted.labels)
        expected = {blender_name(painted.names[k], path): painted.colors[k] for k in used}
        for material, rgb in found["materials"]:
            np.testing.assert_allclose(rgb, expected[material], atol=1e-6)
        assert {tuple(np.round(c, 6)) for c in expected.values()} == \
            {tuple(np.round(rgb, 6)) for _, rgb in found["materials"]}
        # each polygon is the part's triangle with the same corners, in metres
        key = name + ".001" if clash else name
        world = part.world_mesh(scene.scale_to("m"))
        corners = arrays[f"{key}/corners"].reshape(-1, 3, 3)
        distance, face = cKDTree(world.triangles.mean(axis=1)).query(corners.mean(axis=1))
        assert len(corners) == len(world.faces) == len(np.unique(face))
        which = np.linalg.norm(corners[:, :, None] - world.triangles[face][:, None],
                               axis=3).argmin(axis=2)
        assert np.linalg.norm(corners - np.take_along_axis(world.triangles[face],
                                                           which[..., None], axis=1),
                              axis=2).max() < 1e-6 * max(1.0, np.abs(world.bounds).max())
        # the normals Blender draws are the crease-angle normals cadpipe computed (within
        # half a degree: Blender keeps custom normals in its own compact form, 0.2 degrees
        # off at worst seen; without normals it draws facets, 11 degrees off)
        shading = shading_normals(part.mesh)
        turn = np.eye(3) if part.transform is None else np.asarray(part.transform)[:3, :3]
        expected_normals = shading.normals[shading.corner_index].reshape(-1, 3, 3) @ \
            np.linalg.inv(turn)
        expected_normals /= np.linalg.norm(expected_normals, axis=2, keepdims=True)
        expected_normals = np.take_along_axis(expected_normals[face], which[..., None], axis=1)
        drawn = arrays[f"{key}/normals"].reshape(-1, 3, 3)
        assert np.einsum("fki,fki->fk", drawn, expected_normals).min() > \
            np.cos(np.radians(0.5))
        if path.suffix != ".glb":              # glTF splits vertices at creases by design
            assert (arrays[f"{key}/edge_faces"] == 2).all()


@pytest.mark.parametrize("name", ["scene.glb", "scene.usda", "scene.usdz"])
def test_blender_shows_the_demo_parts_named_coloured_at_size_and_shaded(demo, tmp_path, name):
    assert_blender_shows(as_scene(build_cell().assembly), demo / name, tmp_path)


def test_blender_shows_each_example_named_coloured_at_size_and_shaded(example, tmp_path):
    from cadpipe.spec import read

    folder, stem = example
    scene = read(ROOT / "assets" / "examples" / f"{stem}{SPEC_SUFFIX[stem]}").assembly \
        .to_scene("parts")
    for suffix in ("glb", "usda"):
        assert_blender_shows(scene, folder / f"{stem}.{suffix}", tmp_path)


@pytest.mark.parametrize("suffix", ["glb", "usdc", "usdz"])
def test_blender_shows_a_millimetre_scene_in_metres(tmp_path, two_part_scene, suffix):
    target = export(two_part_scene, tmp_path / f"cell.{suffix}")
    assert_blender_shows(two_part_scene, target, tmp_path)


# -- round trips through cadpipe's own readers ------------------------------------------
ROUND_TRIP = ("usda", "usdc", "usdz", "glb", "3mf", "obj", "ply", "stl")
#: formats that store part names (STL and PLY store none)
NAMED = {"usda", "usdc", "usdz", "glb", "3mf", "obj"}
#: formats that store colours (per face or per part)
COLOURED = {"usda", "usdc", "usdz", "glb", "ply", "3mf"}


@pytest.mark.parametrize("suffix", ROUND_TRIP)
def test_every_format_reads_back_with_its_parts_names_colours_and_extent(
        tmp_path, two_part_scene, suffix):
    scene = two_part_scene
    back = load_scene(export(scene, tmp_path / f"cell.{suffix}"))
    scale = back.scale_to("mm")          # compare in the scene's own unit
    expected = np.array([p.world_mesh().bounds for p in scene.parts])
    found = np.array([p.world_mesh(scale).bounds for p in back.parts])
    if suffix in NAMED:
        assert [p.name for p in back.parts] == ["duct", "rod"]
        np.testing.assert_allclose(found, expected, rtol=1e-6, atol=1e-5)
    else:                                 # one mesh: every part in one
        np.testing.assert_allclose(found[0], [expected[:, 0].min(0), expected[:, 1].max(0)],
                                   rtol=1e-6, atol=1e-5)
    if suffix in COLOURED:
        colours = set()
        for part in back.parts:
            painted = labelled(back, part)
            colours |= {tuple(np.round(c, 2)) for c in painted.colors}
        assert colours == {(1.0, 0.0, 0.0), (0.0, 0.0, 1.0)}
    for part in back.parts:
        assert part.world_mesh().is_watertight


@pytest.mark.parametrize("suffix", ["glb", "usdz", "3mf", "obj"])
def test_check_and_view_work_per_part_on_cadpipe_files(tmp_path, two_part_scene, suffix,
                                                       capsys):
    target = export(two_part_scene, tmp_path / f"cell.{suffix}")
    assert main(["check", str(target), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert [p["name"] for p in report["parts"]] == ["duct", "rod"]
    # glTF is metres by definition, OBJ metres by default (as Blender reads it)
    assert report["units"] == ("m" if suffix in ("glb", "obj") else "mm")
    assert main(["view", str(target), "-o", str(tmp_path / "view"),
                 "--highlight", "rod"]) == 0


def test_a_z_up_scene_reads_back_z_up_from_y_up_files(tmp_path, two_part_scene):
    for suffix in ("glb", "usdz"):
        back = load_scene(export(two_part_scene, tmp_path / f"cell.{suffix}"))
        rod = back.parts[1].world_mesh(back.scale_to("mm"))
        assert np.ptp(rod.vertices[:, 2]) == pytest.approx(50, rel=1e-6)   # still upright


def test_as_scene_of_a_loaded_file_is_its_scene(tmp_path, two_part_scene):
    scene = load_scene(export(two_part_scene, tmp_path / "cell.glb"))
    assert as_scene(scene) is scene
