"""cadpipe's own mesh readers against independent ones: the 3MF reader's compiled scan
against ElementTree's reading of the same model (a comment in the file sends it there)
and against trimesh's and lib3mf's readers, its number parsing against Python's
``float``; welding against ``np.unique``; and hostile 3MF packages refused, as
cadpipe errors naming the file, before their work is done."""

import io
import zipfile

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

import cadpipe
from cadpipe.core.weld import unique_points
from cadpipe.errors import CadpipeError, LimitError, MeshError
from cadpipe.core.formats import export, load_scene
from cadpipe.solids.scene import Scene, ScenePart
from cadpipe.io.threemf import read_3mf

CORE = "http://schemas.microsoft.com/3dmanufacturing/core/2015/02"
MATERIAL = "http://schemas.microsoft.com/3dmanufacturing/material/2015/02"
PRODUCTION = "http://schemas.microsoft.com/3dmanufacturing/production/2015/06"
TETRA = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
TETRA_FACES = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]


def package(folder, model, name="t.3mf", parts=None):
    """A 3MF package of the root model text ``model`` (and other model ``parts``)."""
    target = folder / name
    with zipfile.ZipFile(target, "w", zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("[Content_Types].xml", "<Types/>")
        archive.writestr("_rels/.rels", (
            '<Relationships xmlns="http://schemas.openxmlformats.org/package/2006/'
            'relationships"><Relationship Target="/3D/3dmodel.model" Id="r0" Type="http://'
            'schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"/></Relationships>'))
        archive.writestr("3D/3dmodel.model", model)
        for part, text in (parts or {}).items():
            archive.writestr(part, text)
    return target


def mesh_xml(vertices=TETRA, faces=TETRA_FACES, vertex='<vertex x="{}" y="{}" z="{}"/>',
             triangle='<triangle v1="{}" v2="{}" v3="{}"/>'):
    return ("<mesh><vertices>" + "\n".join(vertex.format(*v) for v in vertices)
            + "</vertices><triangles>" + "\n".join(triangle.format(*f) for f in faces)
            + "</triangles></mesh>")


def model(resources, build, unit="millimeter", extra=""):
    return (f'<?xml version="1.0" encoding="UTF-8"?>\n<model unit="{unit}" xmlns="{CORE}" '
            f'xmlns:m="{MATERIAL}" xmlns:p="{PRODUCTION}" {extra}><resources>{resources}'
            f"</resources><build>{build}</build></model>")


def commented(path):
    """The same package with a comment in its model: read by ElementTree alone."""
    with zipfile.ZipFile(path) as archive:
        members = {n: archive.read(n) for n in archive.namelist()}
    members["3D/3dmodel.model"] = members["3D/3dmodel.model"].replace(
        b"<resources>", b"<resources><!-- read by ElementTree -->", 1)
    target = path.with_name("slow_" + path.name)
    with zipfile.ZipFile(target, "w") as archive:
        for name, data in members.items():
            archive.writestr(name, data)
    return target


def assert_same_scene(a, b):
    assert (a.units, [p.name for p in a.parts]) == (b.units, [p.name for p in b.parts])
    assert dict(a.colors) == dict(b.colors)
    for p, q in zip(a.parts, b.parts):
        np.testing.assert_array_equal(p.mesh.vertices, q.mesh.vertices)
        np.testing.assert_array_equal(p.mesh.faces, q.mesh.faces)
        assert p.mesh.part_names == q.mesh.part_names
        if p.mesh.face_part is None or q.mesh.face_part is None:
            assert p.mesh.face_part is q.mesh.face_part
        else:
            np.testing.assert_array_equal(p.mesh.face_part, q.mesh.face_part)


# -- 3MF: the compiled scan reads what ElementTree reads ----------------------------
def variants(folder):
    """3MF models in the forms writers produce and the spec allows."""
    coloured = ('<basematerials id="1"><base name="red" displaycolor="#FF0000"/>'
                '<base name="blue" displaycolor="#0000FFFF"/></basematerials>'
                '<m:colorgroup id="5"><m:color color="#00FF00"/></m:colorgroup>')
    faces = [(0, 2, 1, ' pid="1" p1="1"'), (0, 1, 3, ""), (0, 3, 2, ' pid="5" p1="0"'),
             (1, 2, 3, ' p1="1"')]
    yield "plain", model(f'<object id="1" name="tetra" type="model">{mesh_xml()}</object>',
                         '<item objectid="1"/>')
    yield "attributes reordered, quoted and spaced", model(
        '<object id="1" name="t">' + mesh_xml(
            vertex="<vertex  z = '{2}'\ty=\"{1}\"\n x='{0}' extra='7' ></vertex>",
            triangle="<triangle v3='{2}' v1=\"{0}\" v2 = '{1}' />") + "</object>",
        '<item objectid="1"/>')
    yield "numbers of every form", model('<object id="1" name="t">' + mesh_xml(
        vertices=[("0.5e1", "-.25", "+3"), ("1.", "1E-3", "123456789e-9"),
                  ("0.12345678901234567890123", "98765432109876543210e-20", "-0"),
                  ("1e-310", "1.7976931348623157e2", "0000.00100")]) + "</object>",
        '<item objectid="1"/>')
    yield "colours, components, transforms, micron", model(
        coloured + '<object id="2" name="tetra" pid="1" pindex="0">'
        + mesh_xml(triangle='<triangle v1="{}" v2="{}" v3="{}"{}/>', faces=faces)
        + '</object><object id="3" name="pair"><components>'
        '<component objectid="2"/><component objectid="2" '
        'transform="1 0 0 0 1 0 0 0 1 5 0 0"/></components></object>',
        '<item objectid="3" transform="0 1 0 -1 0 0 0 0 1 1 2 3"/>'
        '<item objectid="2" partnumber="mirrored" transform="-1 0 0 0 1 0 0 0 1 0 0 0"/>',
        unit="micron")
    other = model('<object id="7" name="inner">' + mesh_xml() + "</object>", "")
    yield "production extension", (model(
        '<object id="1" name="outer"><components><component objectid="7" '
        'p:path="/3D/Objects/inner.model"/></components></object>', '<item objectid="1"/>'),
        {"3D/Objects/inner.model": other})


@pytest.mark.parametrize("case", [name for name, _ in variants(None)])
def test_3mf_scan_reads_what_elementtree_reads(tmp_path, case):
    text = dict(variants(tmp_path))[case]
    text, parts = text if isinstance(text, tuple) else (text, None)
    fast = load_scene(package(tmp_path, text, parts=parts))
    slow = load_scene(commented(tmp_path / "t.3mf"))
    assert_same_scene(fast, slow)
    assert all(len(p.mesh.faces) == 4 for p in fast.parts)


def test_3mf_colours_components_and_units(tmp_path):
    text = dict(variants(tmp_path))["colours, components, transforms, micron"]
    scene = load_scene(package(tmp_path, text))
    assert scene.units == "mm"
    assert [p.name for p in scene.parts] == ["tetra", "tetra_1", "mirrored"]
    turn = np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1.0]])        # the item's rotation
    first, second, mirrored = (p.mesh for p in scene.parts)
    np.testing.assert_allclose(first.vertices, (np.array(TETRA) @ turn.T + [1, 2, 3]) / 1000)
    np.testing.assert_allclose(second.vertices,
                               ((np.array(TETRA) + [5, 0, 0]) @ turn.T + [1, 2, 3]) / 1000)
    assert mirrored.volume > 0                                    # faces flipped back
    # faces: blue base, the object's own red base, green group, blue (p1 of object pid)
    names = [first.part_names[k] for k in first.face_part]
    assert names == ["blue", "red", "tetra_00ff00", "blue"]
    green = (0, 1.0, 0)             # a colour group's colours have no names: the part's
    assert dict(scene.colors) == {"blue": (0, 0, 1.0), "red": (1.0, 0, 0),
                                  "tetra_00ff00": green, "tetra_1_00ff00": green,
                                  "mirrored_00ff00": green}


@settings(max_examples=30, deadline=None)
@given(st.lists(st.floats(allow_nan=False, allow_infinity=False, width=64), min_size=12,
                max_size=12),
       st.sampled_from(["{!r}", "{:.9g}", "{:.17g}", "{:.3e}", "{:.25f}", "{:E}"]))
def test_3mf_numbers_read_as_python_reads_them(tmp_path_factory, values, form):
    folder = tmp_path_factory.mktemp("n")
    texts = [form.format(v) for v in values]
    target = package(folder, model('<object id="1" name="t">' + mesh_xml(
        vertices=[texts[i:i + 3] for i in range(0, 12, 3)]) + "</object>",
        '<item objectid="1"/>'))
    expected = np.array([float(t) for t in texts]).reshape(4, 3)
    if not (np.abs(expected) <= 1e12).all():
        with pytest.raises(MeshError):
            read_3mf(target)
        return
    np.testing.assert_array_equal(read_3mf(target).parts[0].mesh.vertices, expected)


@pytest.mark.parametrize("writer", ["cadpipe", "trimesh", "lib3mf"])
def test_3mf_geometry_matches_trimesh_for_files_of_each_writer(tmp_path, writer,
                                                                two_part_scene):
    scene = two_part_scene
    target = tmp_path / "cell.3mf"
    if writer == "cadpipe":
        export(scene, target)
    elif writer == "trimesh":
        tm = trimesh.Scene()
        for part in scene.parts:
            world = part.world_mesh()
            tm.add_geometry(trimesh.Trimesh(world.vertices, world.faces), node_name=part.name,
                            geom_name=part.name)
        target.write_bytes(tm.export(file_type="3mf"))
    else:
        target = lib3mf_package(scene, target)
    ours = load_scene(target)
    theirs = trimesh.load(target, force="mesh", process=False)
    theirs.merge_vertices(digits_vertex=8)
    assert sum(len(p.mesh.faces) for p in ours.parts) == len(theirs.faces)
    corners = np.concatenate([p.world_mesh().triangles.reshape(-1, 9) for p in ours.parts])
    np.testing.assert_allclose(np.sort(corners, axis=0),
                               np.sort(theirs.triangles.reshape(-1, 9), axis=0), atol=1e-9)
    assert sorted(p.name for p in ours.parts) == ["duct", "rod"]


def lib3mf_package(scene, target):
    """The scene written by the 3MF Consortium's library, one object per part."""
    import lib3mf

    wrapper = lib3mf.get_wrapper()
    model3mf = wrapper.CreateModel()
    for part in scene.parts:
        world = part.world_mesh()
        obj = model3mf.AddMeshObject()
        obj.SetName(part.name)
        obj.SetGeometry([lib3mf.Position(ctypes_floats(v)) for v in world.vertices],
                        [lib3mf.Triangle(ctypes_ints(f)) for f in world.faces])
        model3mf.AddBuildItem(obj, wrapper.GetIdentityTransform())
    model3mf.QueryWriter("3mf").WriteToFile(str(target))
    return target


def ctypes_floats(values):
    import ctypes

    return (ctypes.c_float * 3)(*map(float, values))


def ctypes_ints(values):
    import ctypes

    return (ctypes.c_uint32 * 3)(*map(int, values))


def test_3mf_round_trip_keeps_names_colours_and_labels_of_a_union(tmp_path, two_part_scene):
    scene = two_part_scene
    joined = cadpipe.Mesh.concatenate([p.world_mesh().with_parts((p.name,))
                                       for p in scene.parts])
    union = Scene("u", (ScenePart("union", joined),), units="mm",
                  colors={"duct": (1.0, 0, 0), "rod": (0, 0, 1.0)})
    back = load_scene(export(union, tmp_path / "u.3mf"))
    part = back.parts[0]
    assert part.name == "union" and part.mesh.part_names == ("duct", "rod")
    np.testing.assert_array_equal(part.mesh.face_part, joined.face_part)
    assert {k: tuple(np.round(v, 3)) for k, v in back.colors.items()} == \
        {"duct": (1.0, 0, 0), "rod": (0, 0, 1.0)}


# -- 3MF: hostile packages -----------------------------------------------------------
def _nested(levels):
    """Each object places the one below it twice: 2**levels copies of a tetrahedron."""
    objects = [f'<object id="1" name="t">{mesh_xml()}</object>']
    objects += [f'<object id="{i}"><components><component objectid="{i - 1}"/>'
                f'<component objectid="{i - 1}"/></components></object>'
                for i in range(2, levels + 2)]
    return model("".join(objects), f'<item objectid="{levels + 1}"/>')


HOSTILE = {
    "not-a-zip": lambda f: (f / "t.3mf").write_bytes(b"solid x\nendsolid x\n"),
    "no-model": lambda f: package(f, model("", "")).write_bytes(
        _without(package(f, model("", "")), "3D/3dmodel.model")),
    "dtd": lambda f: package(f, '<!DOCTYPE model [<!ENTITY a "aaaa">]>'
                             + model("", "")),
    "not-xml": lambda f: package(f, "<model><resources>"),
    "not-a-model": lambda f: package(f, f'<resources xmlns="{CORE}"/>'),
    "index-past-vertices": lambda f: package(f, model(
        f'<object id="1">{mesh_xml(faces=[(0, 1, 9)])}</object>', '<item objectid="1"/>')),
    "negative-index": lambda f: package(f, model(
        f'<object id="1">{mesh_xml(faces=[(0, 1, -2)])}</object>', '<item objectid="1"/>')),
    "vertex-without-z": lambda f: package(f, model(
        '<object id="1">' + mesh_xml(vertex='<vertex x="{}" y="{}" w="{}"/>') + "</object>",
        '<item objectid="1"/>')),
    "word-for-a-number": lambda f: package(f, model(
        '<object id="1">' + mesh_xml(vertices=[("x", 0, 0)] + TETRA[1:]) + "</object>",
        '<item objectid="1"/>')),
    "nan": lambda f: package(f, model(
        '<object id="1">' + mesh_xml(vertices=[("NaN", 0, 0)] + TETRA[1:]) + "</object>",
        '<item objectid="1"/>')),
    "missing-object": lambda f: package(f, model("", '<item objectid="4"/>')),
    "component-cycle": lambda f: package(f, model(
        '<object id="1"><components><component objectid="2"/></components></object>'
        '<object id="2"><components><component objectid="1"/></components></object>',
        '<item objectid="1"/>')),
    "bad-transform": lambda f: package(f, model(
        f'<object id="1">{mesh_xml()}</object>', '<item objectid="1" transform="1 2"/>')),
    "unknown-unit": lambda f: package(f, model(
        f'<object id="1">{mesh_xml()}</object>', '<item objectid="1"/>', unit="parsec")),
    "empty-build": lambda f: package(f, model(f'<object id="1">{mesh_xml()}</object>', "")),
}


def _without(path, member):
    buffer = io.BytesIO()
    with zipfile.ZipFile(path) as source, zipfile.ZipFile(buffer, "w") as target:
        for name in source.namelist():
            if name != member:
                target.writestr(name, source.read(name))
    return buffer.getvalue()


@pytest.mark.parametrize("case", HOSTILE)
def test_a_hostile_3mf_is_a_mesh_error_naming_it(tmp_path, case):
    HOSTILE[case](tmp_path)
    path = tmp_path / "t.3mf"
    for target in (path, commented(path)) if case not in ("not-a-zip", "no-model") else (path,):
        with pytest.raises(MeshError) as caught:
            load_scene(target)
        assert caught.value.file == str(target)


def test_3mf_builds_past_the_budgets_are_refused_before_they_are_placed(tmp_path):
    target = package(tmp_path, _nested(60))             # 2**60 tetrahedra from 61 objects
    with pytest.raises(LimitError, match="max_triangles"):
        load_scene(target)
    many = package(tmp_path, model('<object id="1">' + mesh_xml(
        faces=TETRA_FACES * 3000) + "</object>", '<item objectid="1"/>'), name="many.3mf")
    with cadpipe.limits.using(max_triangles=10_000), pytest.raises(LimitError) as caught:
        load_scene(many)                                # 12,000 rows, refused when counted
    assert caught.value.file == str(many)


def test_3mf_reader_errors_are_cadpipe_errors_for_truncated_packages(tmp_path, two_part_scene):
    export(two_part_scene, tmp_path / "cell.3mf")
    data = (tmp_path / "cell.3mf").read_bytes()
    for cut in (len(data) // 3, len(data) // 2, len(data) - 30):
        (tmp_path / "cut.3mf").write_bytes(data[:cut])
        with pytest.raises(CadpipeError):
            load_scene(tmp_path / "cut.3mf")


# -- welding -------------------------------------------------------------------------
@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(*[st.sampled_from([0.0, -0.0, 1.0, 0.5e-8, 1.5e-8, 2.5e-8, 1e-9,
                                             -3.25, 1e12, 123456.123456785])] * 3),
                min_size=1, max_size=60), st.integers(0, 3))
def test_welding_finds_the_points_np_unique_finds(points, repeat):
    points = np.array(points * (repeat + 1))
    first, inverse = unique_points(points, 8)
    rounded = np.round(points, 8) + 0.0
    _, expected_first = np.unique(rounded, axis=0, return_index=True)
    np.testing.assert_array_equal(first, np.sort(expected_first))
    np.testing.assert_array_equal(rounded[first][inverse], rounded)


# -- GLB: malformed accessors ----------------------------------------------------------
def _glb_edited(folder, change):
    """cadpipe's GLB of two boxes of two colours (two primitives), its JSON edited."""
    import json
    import struct

    box = cadpipe.primitives.box(1)
    boxes = cadpipe.Mesh.concatenate([box.with_parts(("a",)),
                                      box.transformed(np.eye(4) + np.eye(4, k=3) * 3)
                                      .with_parts(("b",))])
    path = export(Scene("s", (ScenePart("boxes", boxes),),
                        colors={"a": (1.0, 0, 0), "b": (0, 0, 1.0)}), folder / "x.glb")
    data = path.read_bytes()
    length = struct.unpack_from("<I", data, 12)[0]
    doc = json.loads(data[20:20 + length])
    change(doc)
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    body = struct.pack("<I4s", len(text), b"JSON") + text + data[20 + length:]
    path.write_bytes(struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body)
    return path


def _vec2(doc):
    doc["accessors"][doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"]]["type"] = \
        "VEC2"


def _shared_positions_shrunk(doc):
    """Both primitives share one POSITION accessor: give the first a shorter copy of it."""
    position = doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"]
    doc["accessors"].append(dict(doc["accessors"][position], count=4))
    doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = len(doc["accessors"]) - 1


@pytest.mark.parametrize("change", [_vec2, _shared_positions_shrunk])
def test_a_glb_with_malformed_accessors_is_a_mesh_error(tmp_path, change):
    path = _glb_edited(tmp_path, lambda doc: None)
    assert len(load_scene(path).parts[0].mesh.part_names) == 2     # as written: it reads
    path = _glb_edited(tmp_path, change)
    with pytest.raises(MeshError) as caught:
        load_scene(path)
    assert caught.value.file == str(path)
