"""Export: every format writes what a user asked for, whole or not at all.

USD files pass usd-core's own validators and re-open with the expected prims,
counts, extents and stage metadata; mesh formats round-trip through trimesh to
the same triangles (float32 precision) and stay watertight.
"""

import os
import subprocess
import sys
import zipfile

import numpy as np
import pytest
import trimesh
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from scipy.spatial import cKDTree

import cadpipe
from cadpipe.errors import ExportError, InputError
from cadpipe.core.formats import export
from cadpipe.io.normals import shading_normals, split_for_normals
from cadpipe.io.stl import write_stl
from cadpipe.io.text import ascii_rows, float32_decimal
from cadpipe.io.gltf import gltf_root
from cadpipe.solids.scene import Scene, ScenePart, as_scene
from oracle import crease_normals

BUILT_IN = ("stl", "usda", "usdc", "usdz", "3mf", "glb", "obj", "ply")
MESH_FORMATS = ("stl", "3mf", "glb", "obj", "ply")
RED, BLUE, GREEN = (1.0, 0.0, 0.0), (0.0, 0.0, 1.0), (0.0, 0.8, 0.2)


def bent_pipe(sides=12, radius=0.1, lift=0.0):
    path = cadpipe.Path.spline([[0, 0, lift], [1, 0, lift], [1, 1, lift + 0.5],
                                [0, 1, lift + 1]], step=0.05)
    return cadpipe.Pipe(path, radius, sides=sides)


@pytest.fixture(scope="module")
def scene():
    """Two parts: a plain pipe moved by a transform, and a two-colour 'unioned' mesh."""
    shift = np.eye(4)
    shift[:3, 3] = [3.0, 0.0, 0.0]
    plain = bent_pipe(sides=16).mesh()
    union = cadpipe.Mesh.concatenate([bent_pipe(sides=12, lift=2.0).mesh().with_parts(["red"]),
                                      bent_pipe(sides=6, lift=4.0).mesh().with_parts(["blue"])])
    parts = (ScenePart("plain pipe", plain, color=GREEN, transform=shift,
                       attributes=bent_pipe(sides=16).attributes),
             ScenePart("union", union))
    return Scene("work cell", parts, units="mm", colors={"red": RED, "blue": "#0000ff"})


def world_triangles(scene):
    return np.concatenate([p.world_mesh().triangles for p in scene.parts])


def assert_same_triangles(found, expected):
    """Same oriented triangles to float32 precision, in any order, from any first corner."""
    found = np.asarray(found, dtype=np.float64)
    assert found.shape == expected.shape
    rotations = np.concatenate([np.roll(expected, -k, axis=1) for k in range(3)])
    distance, index = cKDTree(rotations.reshape(-1, 9)).query(found.reshape(-1, 9))
    assert distance.max() <= 8 * np.finfo(np.float32).eps * np.abs(expected).max()
    assert len(np.unique(index % len(expected))) == len(expected)   # each matched once


# -- registry and suffixes ------------------------------------------------------
def test_every_built_in_format_is_registered_in_code_not_through_metadata():
    """The built-ins work from a source tree that was never installed: no entry points."""
    script = ("import importlib.metadata as m; real = m.entry_points\n"
              "m.entry_points = lambda **kw: [] if kw.get('group', '').startswith('cadpipe') "
              "else real(**kw)\n"
              "from cadpipe.core import formats\n"
              "print(' '.join(formats.writers.names())); print(' '.join(formats.readers.names()))")
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          check=True)
    writers, readers = (set(line.split()) for line in done.stdout.splitlines())
    assert set(BUILT_IN) <= writers
    assert set(BUILT_IN) <= readers


def test_unknown_suffix_names_the_supported_ones(tmp_path):
    with pytest.raises(InputError) as err:
        export(bent_pipe().mesh(), tmp_path / "pipe.xyz")
    message = str(err.value)
    assert ".xyz" in message and all(f".{name}" in message for name in BUILT_IN)
    assert not any(tmp_path.iterdir())


def test_suffix_is_case_insensitive(tmp_path):
    bent_pipe().mesh().export(tmp_path / "PIPE.STL")
    assert cadpipe.Mesh.load(tmp_path / "PIPE.STL").is_watertight


# -- USD -----------------------------------------------------------------------
@pytest.fixture(scope="module")
def usd_validation():
    from pxr import UsdValidation

    registry = UsdValidation.ValidationRegistry()
    return UsdValidation.ValidationContext(registry.GetOrLoadAllValidators())


@pytest.mark.parametrize("suffix", ["usda", "usdc", "usdz"])
def test_usd_passes_validation_and_reopens_as_written(tmp_path, scene, usd_validation, suffix):
    from pxr import Usd, UsdGeom, UsdShade

    target = export(scene, tmp_path / f"cell.{suffix}")
    stage = Usd.Stage.Open(str(target))
    issues = [f"{e.GetName()}: {e.GetMessage()}" for e in usd_validation.Validate(stage)]
    assert issues == []

    # a .usdz is for AR Quick Look, which wants Y up: the root prim turns the Z-up scene
    up = UsdGeom.Tokens.y if suffix == "usdz" else UsdGeom.Tokens.z
    assert UsdGeom.GetStageUpAxis(stage) == up
    turn = np.eye(4)
    if suffix == "usdz":
        turn[:3, :3] = [[1, 0, 0], [0, 0, 1], [0, -1, 0]]
    assert UsdGeom.GetStageMetersPerUnit(stage) == pytest.approx(0.001)
    assert stage.GetDefaultPrim().GetPath() == "/work_cell"
    assert Usd.ModelAPI(stage.GetDefaultPrim()).GetKind() == "assembly"
    for part, prim_name in zip(scene.parts, ["plain_pipe", "union"]):
        # the leaf mesh is named after its part: Blender names its object by it
        geom = UsdGeom.Mesh(stage.GetPrimAtPath(f"/work_cell/{prim_name}/{prim_name}"))
        assert geom, f"missing mesh of {prim_name}"
        points = np.asarray(geom.GetPointsAttr().Get())
        np.testing.assert_array_equal(points, part.mesh.vertices.astype(np.float32))
        assert np.asarray(geom.GetFaceVertexCountsAttr().Get()).tolist() == \
            [3] * len(part.mesh.faces)
        np.testing.assert_array_equal(np.asarray(geom.GetFaceVertexIndicesAttr().Get()),
                                      part.mesh.faces.ravel())
        np.testing.assert_allclose(np.asarray(geom.GetExtentAttr().Get()),
                                   part.mesh.bounds, rtol=1e-6)
        assert geom.GetSubdivisionSchemeAttr().Get() == UsdGeom.Tokens.none
        normals = UsdGeom.PrimvarsAPI(geom).GetPrimvar("normals")
        assert normals.GetInterpolation() == UsdGeom.Tokens.faceVarying   # hard cap rims
        np.testing.assert_array_equal(np.asarray(normals.ComputeFlattened()),
                                      corner_normals(part.mesh)[0])

    plain = stage.GetPrimAtPath("/work_cell/plain_pipe")
    world = UsdGeom.Xformable(plain).ComputeLocalToWorldTransform(Usd.TimeCode.Default())
    np.testing.assert_allclose(np.asarray(world).T, turn @ scene.parts[0].transform, atol=1e-12)
    assert plain.GetAttribute("cadpipe:sides").Get() == 16
    assert plain.GetAttribute("cadpipe:path_length").Get() == pytest.approx(
        scene.parts[0].attributes["path_length"])
    material, _ = UsdShade.MaterialBindingAPI(
        stage.GetPrimAtPath("/work_cell/plain_pipe/plain_pipe")).ComputeBoundMaterial()
    assert _diffuse(material) == pytest.approx(GREEN)


def _diffuse(material):
    from pxr import UsdShade

    shader = UsdShade.Shader(material.GetPrim().GetChild("PreviewSurface"))
    return tuple(shader.GetInput("diffuseColor").Get())


def test_usd_union_keeps_part_colours_through_geom_subsets(tmp_path, scene):
    from pxr import Usd, UsdGeom, UsdShade

    stage = Usd.Stage.Open(str(export(scene, tmp_path / "cell.usdc")))
    geom = UsdGeom.Mesh(stage.GetPrimAtPath("/work_cell/union/union"))
    subsets = UsdShade.MaterialBindingAPI(geom.GetPrim()).GetMaterialBindSubsets()
    union = scene.parts[1].mesh
    assert [s.GetPrim().GetName() for s in subsets] == ["red", "blue"]
    valid, why = UsdGeom.Subset.ValidateFamily(geom, UsdGeom.Tokens.face, "materialBind")
    assert valid, why
    for label, (subset, rgb) in enumerate(zip(subsets, [RED, BLUE])):
        np.testing.assert_array_equal(np.asarray(subset.GetIndicesAttr().Get()),
                                      np.flatnonzero(union.face_part == label))
        material, _ = UsdShade.MaterialBindingAPI(subset.GetPrim()).ComputeBoundMaterial()
        assert _diffuse(material) == pytest.approx(rgb)
    # indexed (a colour per part, a part per face), as renderers and Blender flatten it
    display = geom.GetDisplayColorPrimvar()
    assert display.IsIndexed() and display.GetInterpolation() == UsdGeom.Tokens.uniform
    np.testing.assert_allclose(np.asarray(display.ComputeFlattened()),
                               np.array([RED, BLUE])[union.face_part])


def test_usdz_is_a_package_around_a_binary_layer(tmp_path):
    target = bent_pipe().mesh().export(tmp_path / "pipe.usdz")
    with zipfile.ZipFile(target) as package:
        names = package.namelist()
    assert names == ["pipe.usdc"]


@pytest.mark.parametrize("suffix", ["usda", "usdz"])
def test_lone_pipe_exports_with_its_parameters(tmp_path, usd_validation, suffix):
    from pxr import Usd

    pipe = bent_pipe(sides=9)
    stage = Usd.Stage.Open(str(export(pipe, tmp_path / f"pipe.{suffix}")))
    assert list(usd_validation.Validate(stage)) == []
    part = stage.GetDefaultPrim().GetChild("pipe")
    assert part.GetAttribute("cadpipe:sides").Get() == 9
    assert part.GetAttribute("cadpipe:radius_max").Get() == pytest.approx(0.1)
    assert part.GetAttribute("cadpipe:caps").Get() == "flat"


@pytest.mark.parametrize("dtype", [np.float64, np.float32, np.int64, np.int32])
def test_arrays_reach_usd_core_as_its_own_conversion_gives_them(dtype):
    from pxr import Vt

    from cadpipe.io.usd import vt_ints, vt_vec3f

    rng = np.random.default_rng(7)
    for rows in (1, 2, 1000):
        numbers = (rng.normal(size=(rows, 3)) * 1e3).astype(dtype)
        expected = np.asarray(Vt.Vec3fArray.FromNumpy(numbers))
        made = vt_vec3f(numbers)
        numbers[0] = 0                       # usd-core's array is its own, not a view
        assert isinstance(made, Vt.Vec3fArray)
        np.testing.assert_array_equal(np.asarray(made), expected)
        whole = rng.integers(-2**31, 2**31, size=(rows, 3)).astype(np.int64).astype(dtype)
        made = vt_ints(whole)
        assert isinstance(made, Vt.IntArray)
        np.testing.assert_array_equal(np.asarray(made), whole.ravel().astype(np.int32))
    assert len(vt_vec3f(np.empty((0, 3)))) == 0 and len(vt_ints(np.empty(0, np.int64))) == 0


def test_usd_arrays_fall_back_to_usd_cores_conversion_where_storage_is_not_shown():
    from pxr import Vt

    from cadpipe.io.usd import _checked

    source = np.array([4, 5, 6])
    elsewhere = source.astype(np.int32)         # filled, but not usd-core's storage
    made = _checked(Vt.IntArray(3), elsewhere, elsewhere.ctypes.data, source, Vt.IntArray)
    assert list(made) == [4, 5, 6]


# -- shading normals --------------------------------------------------------------
def corner_normals(mesh, crease_angle=35.0):
    shading = shading_normals(mesh, crease_angle)
    return shading.normals[shading.corner_index], shading.per_vertex


def test_round_tube_shades_smooth_and_keeps_hard_caps():
    mesh = cadpipe.Pipe([[0, 0, 0], [0, 0, 2]], 0.5, sides=16).mesh()
    normals, per_vertex = corner_normals(mesh)
    assert not per_vertex
    corners = mesh.vertices[mesh.faces.ravel()]
    on_cap = np.isclose(np.abs(mesh.face_normals[:, 2]), 1.0).repeat(3)
    radial = corners[:, :2] / np.linalg.norm(corners[:, :2], axis=1, keepdims=True)
    # side corners point straight out of the axis; cap corners along it
    np.testing.assert_allclose(normals[~on_cap, :2], radial[~on_cap], atol=1e-6)
    np.testing.assert_allclose(np.abs(normals[on_cap, 2]), 1.0, atol=1e-6)
    # indexed: one normal per vertex, plus one row per rim vertex for its second normal
    # (side and cap), never a row equal to its vertex's own
    long_pipe = cadpipe.Pipe(np.c_[np.zeros((10, 2)), np.arange(10)], 0.5, sides=16).mesh()
    shading = shading_normals(long_pipe)
    extra = shading.normals[len(long_pipe.vertices):]
    assert len(extra) == 2 * 16
    assert len(np.unique(shading.vertex)) == len(extra)
    assert not (extra == shading.normals[shading.vertex]).all(axis=1).any()


def test_low_poly_duct_keeps_its_facets():
    mesh = cadpipe.Pipe([[0, 0, 0], [0, 0, 2]], 0.5, sides=6).mesh()
    normals, per_vertex = corner_normals(mesh)
    assert not per_vertex
    np.testing.assert_allclose(normals, mesh.face_normals.repeat(3, axis=0), atol=1e-6)


def test_closed_ring_has_plain_vertex_normals():
    angles = np.linspace(0, 2 * np.pi, 40, endpoint=False)
    ring = cadpipe.Path(np.c_[np.cos(angles), np.sin(angles), np.zeros(40)], closed=True)
    mesh = cadpipe.Pipe(ring, 0.2, sides=16).mesh()
    shading = shading_normals(mesh)
    assert shading.per_vertex and shading.normals.shape == mesh.vertices.shape


def test_glb_splits_only_crease_vertices():
    mesh = cadpipe.Pipe([[0, 0, 0], [0, 0, 2]], 0.5, sides=16).mesh()
    vertices, faces, normals = split_for_normals(mesh)
    # every vertex lies on a rim (flat caps are fans of the end rings): a side copy and
    # a cap copy each
    assert len(vertices) == 2 * len(mesh.vertices)
    np.testing.assert_array_equal(vertices[faces], mesh.triangles.astype(np.float32))
    np.testing.assert_allclose(normals[faces.ravel()], corner_normals(mesh)[0])


def test_crease_angle_outside_0_180_is_rejected():
    with pytest.raises(InputError, match="crease_angle"):
        shading_normals(bent_pipe().mesh(), crease_angle=200)


@settings(max_examples=20, deadline=None)
@given(sides=st.integers(3, 40), angle=st.floats(0, 180))
def test_shading_normals_are_unit_and_face_outward(sides, angle):
    mesh = cadpipe.Pipe([[0, 0, 0], [1, 0.2, 0], [2, 0, 0.3]], 0.1, sides=sides).mesh()
    normals, _ = corner_normals(mesh, angle)
    np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-6)
    facing = np.einsum("ij,ij->i", normals, mesh.face_normals.repeat(3, axis=0))
    assert (facing > 0).all()


def shading_test_mesh(kind, seed):
    """A mesh with smooth stretches, creases and (``"degenerate"``) zero-area faces."""
    rng = np.random.default_rng(seed)
    if kind == "pipe":             # its arrays alone: the general rule (rings: below)
        points = np.cumsum(rng.normal(size=(4, 3)), axis=0)
        mesh = cadpipe.Pipe(points, 0.1, sides=int(rng.integers(3, 30))).mesh()
        return cadpipe.Mesh.trusted(mesh.vertices, mesh.faces)
    shapes = {"box": lambda: trimesh.creation.box(),
              "sphere": lambda: trimesh.creation.icosphere(subdivisions=2),
              "cylinder": lambda: trimesh.creation.cylinder(0.5, 1.0,
                                                            sections=int(rng.integers(5, 40))),
              "degenerate": lambda: trimesh.creation.cylinder(0.5, 1.0, sections=12)}
    tm = shapes[kind]()
    vertices = tm.vertices + rng.normal(scale=0.01, size=tm.vertices.shape)
    faces = tm.faces
    if kind == "degenerate":       # a sliver of zero area and a face on one point
        faces = np.vstack([faces, [faces[0, 0], faces[0, 1], faces[0, 1]],
                           [faces[1, 0], faces[1, 0], faces[1, 0]]])
    return cadpipe.Mesh.trusted(vertices, faces)


@settings(max_examples=40, deadline=None)
@given(kind=st.sampled_from(["pipe", "box", "sphere", "cylinder", "degenerate"]),
       seed=st.integers(0, 2**31), angle=st.floats(0, 180))
def test_shading_normals_match_the_crease_rule(kind, seed, angle):
    mesh = shading_test_mesh(kind, seed)
    shading = shading_normals(mesh, angle)
    expected = crease_normals(mesh.vertices, mesh.faces, angle)
    np.testing.assert_allclose(shading.normals[shading.corner_index], expected, atol=2e-6)
    # each extra row is a vertex's further normal: never one its vertex already has
    extra = shading.normals[len(mesh.vertices):]
    assert not (extra == shading.normals[shading.vertex]).all(axis=1).any()
    pairs = np.column_stack([shading.vertex, extra.view(np.int32)])
    assert len(np.unique(pairs, axis=0)) == len(pairs)
    # the glTF split: the same triangles, each corner with its normal
    vertices, faces, normals = split_for_normals(mesh, angle)
    np.testing.assert_array_equal(vertices[faces], mesh.triangles.astype(np.float32))
    np.testing.assert_array_equal(normals[faces.ravel()], shading.normals[shading.corner_index])


def angles_between(a, b):
    """Degrees between the rows of ``a`` and ``b``."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    return np.degrees(np.arctan2(np.linalg.norm(np.cross(a, b), axis=1),
                                 np.einsum("ij,ij->i", a, b)))


def test_pipe_normals_from_its_rings_are_the_tube_surface_normals():
    # a helix: the tube's surface normal at a ring vertex points away from the ring's
    # centre on the path (rings stand square to the path); the caps' along the path
    turns = np.linspace(0, 4 * np.pi, 400)
    path = cadpipe.Path(np.c_[np.cos(turns), np.sin(turns), 0.1 * turns])
    pipe = cadpipe.Pipe(path, 0.05, sides=24)
    mesh = pipe.mesh()
    assert mesh.ring_runs is not None
    normals, per_vertex = corner_normals(mesh)
    assert not per_vertex
    shading = shading_normals(mesh)
    rings = np.arange(len(mesh.vertices)) // 24
    on_side = np.isin(np.arange(len(shading.corner_index)), shading.corners, invert=True)
    corner_vertex = mesh.faces.ravel()
    radial = mesh.vertices[corner_vertex] - path.points[rings[corner_vertex]]
    assert angles_between(normals[on_side], radial[on_side]).max() < 0.5
    # the general rule agrees within 0.1 degree, and splits the same corners
    general = cadpipe.Mesh.trusted(mesh.vertices, mesh.faces)
    assert angles_between(normals, corner_normals(general)[0]).max() < 0.1
    np.testing.assert_array_equal(np.sort(shading.corners),
                                  np.sort(shading_normals(general).corners))
    # moved, relabelled: the same layout, the normals turned with the mesh
    turn = cadpipe.core.transform.as_matrix(np.array([[0.0, -1, 0, 1], [1, 0, 0, 2],
                                                        [0, 0, 1, 3], [0, 0, 0, 1]]))
    moved = mesh.transformed(turn).with_parts(["helix"])
    assert moved.ring_runs is not None
    np.testing.assert_allclose(corner_normals(moved)[0], normals @ turn[:3, :3].T, atol=1e-6)


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**31), sides=st.integers(3, 40), angle=st.floats(0, 180))
def test_pipe_normals_from_its_rings_follow_the_crease_rule(seed, sides, angle):
    # a pipe's inner rings take their normals from their ring neighbours where the
    # faces around them all lie within 15 degrees: the crease rule's corners, normals
    # within a degree and a half of its angle-weighted ones
    rng = np.random.default_rng(seed)
    points = np.cumsum(rng.normal(scale=0.5, size=(5, 3)), axis=0)
    path = cadpipe.Path.spline(points, step=0.05)
    mesh = cadpipe.Pipe(path, 0.05, sides=sides, strict=False).mesh()
    shading = shading_normals(mesh, angle)
    normals = shading.normals[shading.corner_index]
    expected = crease_normals(mesh.vertices, mesh.faces, angle)
    assert angles_between(normals, expected).max() < 1.5
    np.testing.assert_allclose(np.linalg.norm(shading.normals, axis=1), 1.0, atol=1e-6)
    general = shading_normals(cadpipe.Mesh.trusted(mesh.vertices, mesh.faces), angle)
    np.testing.assert_array_equal(np.sort(shading.corners), np.sort(general.corners))
    vertices, faces, split = split_for_normals(mesh, angle)
    np.testing.assert_array_equal(vertices[faces], mesh.triangles.astype(np.float32))
    np.testing.assert_array_equal(split[faces.ravel()], normals)


def test_faceted_pipe_keeps_its_facets_along_its_rings():
    # 8 sides at 35 degrees: 45 degrees between sides, so no ring shades smooth
    mesh = cadpipe.Pipe(cadpipe.Path.spline([[0, 0, 0], [1, 0, 0], [1, 1, 0.5]], step=0.1),
                        0.1, sides=8).mesh()
    normals, _ = corner_normals(mesh)
    np.testing.assert_allclose(normals, crease_normals(mesh.vertices, mesh.faces, 35.0),
                               atol=2e-6)


# -- mesh formats ----------------------------------------------------------------
@pytest.mark.parametrize("suffix", MESH_FORMATS)
def test_mesh_formats_round_trip_through_trimesh(tmp_path, scene, suffix):
    target = export(scene, tmp_path / f"cell.{suffix}")
    loaded = trimesh.load(target, force="mesh", process=False)
    expected = world_triangles(scene)
    if suffix == "glb":   # glTF is Y-up in metres: the root node converts
        root = gltf_root(scene)
        expected = expected @ root[:3, :3].T
    if suffix in ("obj", "ply"):   # in metres, as Blender and MeshLab read them
        expected = expected * scene.scale_to("m")
    assert_same_triangles(loaded.triangles, expected)
    back = cadpipe.Mesh.load(target)
    assert back.is_watertight and back.volume > 0
    assert back.n_bodies == 3


def test_stl_ascii_round_trips(tmp_path, scene):
    target = export(scene, tmp_path / "cell.stl", ascii=True)
    assert target.read_bytes().startswith(b"solid work_cell")
    assert_same_triangles(trimesh.load(target, force="mesh").triangles, world_triangles(scene))


def test_3mf_has_units_one_object_per_part_and_colours(tmp_path, scene):
    target = export(scene, tmp_path / "cell.3mf")
    with zipfile.ZipFile(target) as package:
        assert {"[Content_Types].xml", "_rels/.rels", "3D/3dmodel.model"} <= \
            set(package.namelist())
        model = package.read("3D/3dmodel.model").decode()
    assert 'unit="millimeter"' in model
    assert model.count("<object ") == 2 and model.count("<item ") == 2
    assert 'name="red" displaycolor="#FF0000FF"' in model
    assert 'name="plain pipe" displaycolor="#00CC33FF"' in model
    loaded = trimesh.load(target)
    assert len(loaded.geometry) == 2


def glb_json(path):
    """The JSON chunk of a .glb, read by the container layout of the glTF 2.0 spec."""
    import json
    import struct

    data = path.read_bytes()
    length, kind = struct.unpack_from("<I4s", data, 12)
    assert data[:4] == b"glTF" and kind == b"JSON"
    return json.loads(data[20:20 + length])


def test_glb_keeps_a_node_and_a_mesh_per_part_with_a_primitive_per_colour(tmp_path, scene):
    doc = glb_json(export(scene, tmp_path / "cell.glb"))
    assert [n["name"] for n in doc["nodes"]] == ["work cell", "plain pipe", "union"]
    meshes = {m["name"]: m for m in doc["meshes"]}
    materials = [m["name"] for m in doc["materials"]]
    assert len(set(materials)) == len(materials)                       # unique names

    def colour(primitive):
        material = doc["materials"][primitive["material"]]
        return tuple(material["pbrMetallicRoughness"]["baseColorFactor"][:3])

    assert [colour(p) for p in meshes["union"]["primitives"]] == [RED, BLUE]
    assert [colour(p) for p in meshes["plain pipe"]["primitives"]] == [GREEN]
    # the primitives of a part share its vertices: Blender imports one object per part
    positions = {p["attributes"]["POSITION"] for p in meshes["union"]["primitives"]}
    assert len(positions) == 1
    # trimesh (an independent reader) finds the same triangles, coloured the same
    loaded = trimesh.load(tmp_path / "cell.glb")
    assert sum(len(g.faces) for g in loaded.geometry.values()) == \
        sum(len(p.mesh.faces) for p in scene.parts)


def test_ply_carries_vertex_and_face_colours(tmp_path, scene):
    target = export(scene, tmp_path / "cell.ply")
    loaded = trimesh.load(target, process=False)
    # vertex colours, which Blender and MeshLab show (trimesh reads them first)
    assert loaded.visual.kind == "vertex"
    colors = {tuple(c) for c in loaded.visual.vertex_colors[:, :3].tolist()}
    assert colors == {(0, 204, 51), (255, 0, 0), (0, 0, 255)}
    corner_colors = loaded.visual.vertex_colors[loaded.faces][:, :, :3]
    assert (corner_colors == corner_colors[:, :1]).all()        # one colour per face
    face = loaded.metadata["_ply_raw"]["face"]["data"]
    face_colors = np.column_stack([face["red"], face["green"], face["blue"]])
    np.testing.assert_array_equal(face_colors, corner_colors[:, 0])


@settings(max_examples=25, deadline=None)
@given(points=st.lists(st.tuples(*[st.floats(-50, 50)] * 3), min_size=2, max_size=6,
                       unique=True),
       radius=st.floats(0.01, 0.5), sides=st.integers(3, 24))
def test_binary_stl_holds_the_float32_triangles_and_their_normals(tmp_path_factory, points,
                                                                 radius, sides):
    path = np.asarray(points)
    assume(np.linalg.norm(np.diff(path, axis=0), axis=1).min() >= 1.0)
    try:
        mesh = cadpipe.Pipe(path, radius, sides=sides, strict=True).mesh()
    except (cadpipe.GeometryError, InputError):
        assume(False)                    # folds on itself: a union's slivers tilt in float32
    target = tmp_path_factory.mktemp("stl") / "pipe.stl"
    write_stl(mesh, target, units="m")
    data = np.fromfile(target, dtype=np.uint8)
    assert len(data) == 84 + 50 * len(mesh.faces)
    loaded = trimesh.load(target, process=False)
    np.testing.assert_array_equal(np.asarray(loaded.triangles, np.float32),
                                  mesh.triangles.astype(np.float32))
    stored = np.asarray(loaded.face_normals)            # the normals of the float32 triangles
    held = mesh.triangles.astype(np.float32).astype(np.float64)     # (a sliver's tilt there)
    normals = np.cross(held[:, 1] - held[:, 0], held[:, 2] - held[:, 0])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    np.testing.assert_allclose(np.einsum("ij,ij->i", stored, normals), 1.0, atol=1e-5)
    assert cadpipe.Mesh.load(target).is_watertight


@pytest.mark.parametrize("suffix", ["3mf", "usda", "glb"])
def test_unknown_units_are_a_clear_error(tmp_path, suffix):
    scene = Scene("cell", (ScenePart("pipe", bent_pipe().mesh()),), units="furlong")
    with pytest.raises(InputError, match="units"):
        export(scene, tmp_path / f"cell.{suffix}")
    assert not any(tmp_path.iterdir())


def test_empty_part_is_a_clear_error(tmp_path):
    empty = cadpipe.Mesh(np.zeros((0, 3)), np.zeros((0, 3), int))
    with pytest.raises(InputError, match="no triangles"):
        export(empty, tmp_path / "empty.stl")


# -- numbers to text (3MF) ----------------------------------------------------------
@settings(max_examples=50, deadline=None)
@given(table=st.lists(st.tuples(st.integers(-2**40, 2**40), st.integers(0, 9)), min_size=1,
                      max_size=20))
def test_ascii_rows_match_python_formatting(table):
    text = ascii_rows((b"<t a=\"", 0, b"\" b=\"", 1, b"\"/>\n"), np.array(table))
    assert text.decode() == "".join(f'<t a="{a}" b="{b}"/>\n' for a, b in table)


@settings(max_examples=50, deadline=None)
@given(values=st.lists(st.floats(width=32, allow_nan=False, allow_infinity=False), min_size=1,
                       max_size=50))
def test_float32_decimal_reads_back_to_the_same_float32(values):
    values = np.array(values, dtype=np.float32)
    mantissa, exponent = float32_decimal(values)
    back = np.array([float(f"{m}e{e}") for m, e in zip(mantissa.tolist(), exponent.tolist())])
    np.testing.assert_array_equal(back.astype(np.float32), values)
    assert (np.abs(mantissa) < 10**9).all()


# -- whole or nothing ------------------------------------------------------------
@pytest.mark.parametrize("suffix", BUILT_IN)
def test_target_in_a_missing_folder_leaves_nothing(tmp_path, suffix):
    blocker = tmp_path / "not-a-folder"
    blocker.write_text("a file where a folder should be")
    with pytest.raises(ExportError, match="not-a-folder is a file, not a folder"):
        export(bent_pipe().mesh(), blocker / f"pipe.{suffix}")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["not-a-folder"]


def assert_failed_export_keeps_old_file(target, error, match):
    """Exporting over an existing ``target`` fails with ``error``; the old file stays as it was."""
    target.write_bytes(b"previous version")
    with pytest.raises(error, match=match):
        export(bent_pipe().mesh(), target)
    assert target.read_bytes() == b"previous version"
    assert [p.name for p in target.parent.iterdir()] == [target.name]   # no temp file left


@pytest.mark.parametrize("suffix", BUILT_IN)
def test_failed_rename_keeps_the_old_file_and_leaves_no_temp(tmp_path, monkeypatch, suffix):
    def refuse(src, dst):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(os, "replace", refuse)
    assert_failed_export_keeps_old_file(tmp_path / f"pipe.{suffix}", ExportError,
                                        "nothing was written")


def test_3mf_writer_failing_midway_keeps_the_old_file(tmp_path, monkeypatch):
    from cadpipe.io import threemf

    real_rows = threemf._rows

    def fail_after_first_chunk(template, *tables, **options):
        yield next(real_rows(template, *tables, **options))
        raise RuntimeError("disk full (simulated)")

    monkeypatch.setattr(threemf, "_rows", fail_after_first_chunk)
    assert_failed_export_keeps_old_file(tmp_path / "pipe.3mf", RuntimeError, "simulated")


def test_usdz_packaging_failure_keeps_the_old_file(tmp_path, monkeypatch):
    from pxr import UsdUtils

    monkeypatch.setattr(UsdUtils, "CreateNewARKitUsdzPackage", lambda *args: False)
    assert_failed_export_keeps_old_file(tmp_path / "pipe.usdz", ExportError, "package")


def test_export_accepts_anything_with_to_scene(tmp_path, scene):
    class Cell:
        def to_scene(self):
            return scene

    assert as_scene(Cell()) is scene
    target = export(Cell(), tmp_path / "cell.stl")
    assert len(trimesh.load(target).faces) == len(world_triangles(scene))

