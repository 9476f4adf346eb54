"""Assemblies: unions, differences and intersections that keep part identity."""

import manifold3d
import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import cadpipe
from cadpipe import Assembly, HollowPipe, Pipe, primitives
from cadpipe.core.transform import placement

directions = st.tuples(*[st.floats(-1, 1)] * 3).filter(lambda v: np.linalg.norm(v) > 0.2)


def through_centre(direction, radius, sides=12):
    """A straight pipe through (0.5, 0.5, 0.5), so any two of them overlap."""
    d = 0.45 * np.asarray(direction) / np.linalg.norm(direction)
    return Pipe([0.5 - d, 0.5 + d], radius, sides)


@settings(max_examples=20, deadline=None)
@given(st.lists(st.tuples(directions, st.floats(0.02, 0.1)), min_size=2, max_size=6))
def test_union_of_overlapping_pipes_is_watertight_between_largest_and_sum(specs):
    units = [np.asarray(d) / np.linalg.norm(d) for d, _ in specs]
    assume(all(abs(u @ v) < 0.99 for i, u in enumerate(units) for v in units[i + 1:]))
    meshes = [through_centre(d, r).mesh() for d, r in specs]
    asm = Assembly()
    for i, mesh in enumerate(meshes):
        asm.add(f"pipe{i}", mesh)
    solid = asm.union()
    volumes = [m.volume for m in meshes]
    assert solid.is_watertight and solid.is_outward and solid.n_bodies == 1
    assert max(volumes) < solid.volume < sum(volumes)


def test_every_triangle_keeps_its_part_name_and_part_areas_add_up():
    a = through_centre((1, 0, 0), 0.1)
    b = through_centre((0, 1, 0.3), 0.08)
    far = primitives.box(0.2)
    asm = (Assembly().add("a", a).add("b", b)
           .add("far", far, transform=placement(translate=(3, 0, 0)))
           .subtract("hole", primitives.cylinder(0.03, 2.0, 16),
                     transform=placement(translate=(0.5, 0.5, 0.5))))
    solid = asm.union()
    assert solid.face_part is not None and len(solid.face_part) == len(solid.faces)
    assert set(solid.part_names) == {"a", "b", "far", "hole"}
    per_part = dict(zip(solid.part_names,
                        np.bincount(solid.face_part, weights=solid.face_areas,
                                    minlength=len(solid.part_names))))
    assert sum(per_part.values()) == pytest.approx(solid.area, rel=1e-12)
    # a union only removes surface; the untouched box keeps all of its own
    assert per_part["a"] < a.mesh().area and per_part["b"] < b.mesh().area
    assert per_part["far"] == pytest.approx(far.area, rel=1e-12)
    assert per_part["hole"] > 0                        # the bore's wall comes from the cutter


def manifold_of(mesh, transform=None):
    solid = mesh.to_manifold()
    return solid if transform is None else solid.transform(transform[:3])


@pytest.mark.parametrize("op", ["subtract", "intersect"])
def test_difference_and_intersection_agree_with_manifold3d(op):
    body = through_centre((1, 0.2, 0), 0.15, 24).mesh()
    tool = primitives.sphere(0.25, 32)
    move = placement(translate=(0.6, 0.5, 0.5), rotate=(10, 20, 30))
    asm = Assembly().add("body", body)
    getattr(asm, op)("tool", tool, transform=move)
    ours = asm.union()
    a, b = manifold_of(body), manifold_of(tool, move)
    direct = a - b if op == "subtract" else a ^ b
    assert ours.is_watertight
    assert ours.volume == pytest.approx(direct.volume(), rel=1e-9)
    assert ours.area == pytest.approx(direct.surface_area(), rel=1e-9)
    assert set(np.asarray(ours.part_names)[np.unique(ours.face_part)]) == {"body", "tool"}


def test_order_of_calls_does_not_change_the_solid():
    a, b = through_centre((1, 0, 0), 0.1).mesh(), through_centre((0, 0, 1), 0.1).mesh()
    hole = primitives.sphere(0.12, 24).transformed(placement(translate=(0.5, 0.5, 0.5)))
    first = Assembly().add("a", a).subtract("hole", hole).add("b", b).union()
    second = Assembly().subtract("hole", hole).add("b", b).add("a", a).union()
    assert first.volume == pytest.approx(second.volume, rel=1e-12)


def test_mirroring_transform_keeps_the_solid_outward():
    pipe = Pipe([[0, 0, 0], [1, 0.3, 0.2]], 0.1)
    solid = Assembly().add("p", pipe, transform=np.diag([-1.0, 1, 1, 1])).union()
    assert solid.is_outward and solid.volume == pytest.approx(pipe.mesh().volume, rel=1e-9)


def test_scene_in_parts_mode_keeps_transforms_colours_and_cuts():
    hollow = HollowPipe(Pipe([[0, 0, 0], [1, 0, 0]], 0.1, 16), 0.02)
    move = placement(translate=(0, 0, 2))
    asm = (Assembly(units="mm", name="cell")
           .add("duct", hollow, transform=move, color="#ff0000")
           .add("block", primitives.box(0.5), color=(0, 0, 1))
           .subtract("notch", primitives.box(0.2), transform=placement(translate=(0.25, 0, 0))))
    scene = asm.to_scene("parts")
    assert (scene.name, scene.units) == ("cell", "mm")
    parts = {p.name: p for p in scene.parts}
    assert set(parts) == {"duct", "block"}
    np.testing.assert_array_equal(parts["duct"].transform, move)
    assert parts["duct"].color == (1.0, 0.0, 0.0)
    assert parts["duct"].attributes["kind"] == "hollow pipe"
    # each part on its own, already cut: the duct is hollow, the block notched
    assert parts["duct"].mesh.volume == pytest.approx(hollow.mesh().volume, rel=1e-9)
    assert parts["block"].mesh.volume == pytest.approx(0.125 - 0.1 * 0.2 * 0.2, rel=1e-9)
    solid_scene = asm.to_scene("solid")
    assert len(solid_scene.parts) == 1 and solid_scene.parts[0].mesh is asm.union()
    assert dict(solid_scene.colors) == {"duct": (1.0, 0.0, 0.0), "block": (0.0, 0.0, 1.0)}


def test_export_writes_the_unioned_solid_to_stl(tmp_path):
    a, b = through_centre((1, 0, 0), 0.1), through_centre((0, 1, 0), 0.1)
    asm = Assembly().add("a", a).add("b", b)
    path = asm.export(tmp_path / "cell.stl")
    back = cadpipe.Mesh.load(path)                      # STL is in millimetres
    assert back.is_watertight and back.volume * 1e-9 == pytest.approx(asm.union().volume,
                                                                      rel=1e-6)


def test_assembly_results_are_cached_and_reset_by_new_parts():
    asm = Assembly().add("a", through_centre((1, 0, 0), 0.1))
    first = asm.union()
    assert asm.union() is first
    asm.add("b", through_centre((0, 1, 0), 0.1))
    assert asm.union() is not first and asm.union().volume > first.volume


def test_manifold_ids_of_parts_are_unique_across_assemblies():
    one = Assembly().add("x", primitives.box(1.0)).union()
    two = Assembly().add("y", primitives.box(1.0)).union()
    assert one.part_names == ("x",) and two.part_names == ("y",)


@pytest.mark.parametrize("build, error, match", [
    (lambda a: a.add("a", primitives.box(1)).add("a", primitives.box(1)), cadpipe.InputError,
     "already in the assembly"),
    (lambda a: a.add("", primitives.box(1)), cadpipe.InputError, "non-empty string"),
    (lambda a: a.add("x", "box"), cadpipe.InputError, "expected a Mesh, Pipe"),
    (lambda a: a.add("x", primitives.box(1), transform=np.eye(3)), cadpipe.InputError,
     "x: transform: expected a finite 4x4"),
    (lambda a: a.add("x", primitives.box(1), color="#12"), cadpipe.InputError, "color"),
    (lambda a: a.subtract("x", primitives.box(1)).union(), cadpipe.InputError,
     "add at least one part"),
    (lambda a: a.add("x", primitives.box(1)).intersect(
        "y", primitives.box(1), transform=placement(translate=(5, 0, 0))).union(),
     cadpipe.GeometryError, "nothing is left"),
    (lambda a: a.add("lid", cadpipe.Mesh(primitives.box(1).vertices,
                                         primitives.box(1).faces[1:])).union(),
     cadpipe.MeshError, "lid: not a closed solid"),
])
def test_bad_assemblies_raise_named_errors(build, error, match):
    with pytest.raises(error, match=match):
        build(Assembly())


def test_units_must_be_known():
    with pytest.raises(cadpipe.InputError, match="units"):
        Assembly(units="furlong")


def test_parts_whose_boxes_overlap_nothing_skip_boolean_work(monkeypatch):
    real, to_manifold = manifold3d.Manifold.batch_boolean, cadpipe.Mesh.to_manifold
    sizes, converted = [], []

    def spy(solids, op):
        sizes.append((len(solids), op))
        return real(solids, op)

    def spy_convert(mesh, *args, **kwargs):
        converted.append(len(mesh.faces))
        return to_manifold(mesh, *args, **kwargs)

    monkeypatch.setattr(manifold3d.Manifold, "batch_boolean", staticmethod(spy))
    monkeypatch.setattr(cadpipe.Mesh, "to_manifold", spy_convert)
    unit = primitives.box(1.0)
    asm = Assembly()
    for k in range(5):                                   # five cubes in a row, 1 apart
        asm.add(f"cube{k}", cadpipe.Mesh(unit.vertices + [2.0 * k, 0, 0], unit.faces))
    a, b = through_centre((1, 0, 0), 0.1).mesh(), through_centre((0, 1, 0), 0.1).mesh()
    asm.add("a", a, transform=placement(translate=(0, 5, 0)))
    asm.add("b", b, transform=placement(translate=(0, 5, 0)))
    solid = asm.union()
    assert solid.n_bodies == 6
    # one real union (the two crossing pipes); the cubes never reach manifold3d
    assert [n for n, op in sizes] == [2]
    assert sorted(converted) == sorted([len(a.faces), len(b.faces)])
    per_cube = np.bincount(solid.face_part)[:5]
    assert per_cube.tolist() == [len(unit.faces)] * 5    # the cubes' triangles are unchanged
    assert solid.part_names == ("cube0", "cube1", "cube2", "cube3", "cube4", "a", "b")


def test_a_single_pipe_is_its_own_mesh_with_no_manifold3d_round_trip(monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("a single part went through manifold3d")

    monkeypatch.setattr(cadpipe.Mesh, "to_manifold", refuse)
    pipe = Pipe(cadpipe.Path.spline([[0, 0, 0], [1, 0, 0.3], [2, 1, 0]], step=0.01), 0.05, 16)
    asm = Assembly().add("only", pipe, transform=placement(translate=(1, 2, 3)))
    solid = asm.union()
    mesh = pipe.mesh()
    np.testing.assert_array_equal(solid.faces, mesh.faces)
    np.testing.assert_allclose(solid.vertices, mesh.vertices + [1, 2, 3])
    assert solid.part_names == ("only",) and (solid.face_part == 0).all()
    from cadpipe.solids.validity import check_mesh
    assert check_mesh(solid)["valid"]
    part = asm.to_scene("parts").parts[0].mesh          # in its own frame, as made
    np.testing.assert_array_equal(part.vertices, mesh.vertices)


def test_subtracting_an_equal_solid_leaves_nothing_not_a_sliver():
    # found by the spec fuzzer: manifold3d left a zero-volume shell
    pipe = cadpipe.Pipe([[0, 0, 0], [1, 0, 0]], 0.0625, sides=4)
    asm = cadpipe.Assembly()
    asm.add("kept", pipe)
    asm.subtract("same", pipe)
    asm.subtract("cross", cadpipe.Pipe([[0, 0, 0], [0, 0, 1]], 0.0625, sides=3))
    with pytest.raises(cadpipe.GeometryError, match="nothing is left"):
        asm.union()


@pytest.mark.parametrize("suffix", ["stl", "3mf", "glb", "obj", "ply"])
def test_solids_touching_along_an_edge_stay_manifold_in_every_file(tmp_path, suffix):
    # manifold3d keeps the two copies of the shared edge apart by index only; a file of
    # float32 coordinates would weld them into an edge of four faces
    from cadpipe.solids.validity import check_mesh

    asm = Assembly().add("a", primitives.box(1.0)).add(
        "b", primitives.box(1.0), transform=placement(translate=(1, 1, 0)))
    solid = asm.union()
    reread = cadpipe.Mesh.load(asm.export(tmp_path / f"touch.{suffix}", "solid"))
    report = check_mesh(reread)
    assert report["valid"], report["problems"]
    assert reread.n_bodies == 2 and solid.volume == pytest.approx(2.0, rel=1e-5)


def test_pinched_copies_move_apart_by_little_into_their_own_fans():
    from cadpipe.geometry.swept import separated_pinches

    asm = Assembly().add("a", primitives.box(1.0)).add(
        "b", primitives.box(1.0), transform=placement(translate=(1, 1, 1)))   # a corner
    solid = asm.union()
    keys = np.unique(solid.vertices.astype(np.float32), axis=0)
    assert len(keys) == len(solid.vertices)            # no two vertices one in float32
    again = separated_pinches(solid, 1e-6)
    assert again is solid                              # nothing left to move
    moved = np.linalg.norm(solid.vertices - np.round(solid.vertices * 2) / 2, axis=1)
    assert moved.max() < 1e-5                          # within a few float32 steps


@pytest.mark.slow
def test_a_union_of_many_crossing_pipes_has_no_degenerate_face_in_any_file(tmp_path):
    # the 1,000-pipe union once held two faces of zero area; trimesh is the reference
    import trimesh

    rng = np.random.default_rng(7)
    asm = Assembly()
    while len(asm.parts) < 150:
        start = rng.uniform(0.1, 0.9, 3)
        steps = rng.normal(size=(3, 3))
        steps *= 0.15 / np.linalg.norm(steps, axis=1, keepdims=True)
        path = np.clip(np.vstack([start, start + np.cumsum(steps, axis=0)]), 0.0, 1.0)
        try:
            asm.add(f"pipe{len(asm.parts)}", Pipe(path, 0.01, 12).mesh())
        except cadpipe.CadpipeError:
            continue
    solid = asm.union()
    for mesh in (solid, cadpipe.Mesh.load(asm.export(tmp_path / "u.stl", units="m"))):
        tm = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
        assert tm.nondegenerate_faces(height=1e-12).all()
        assert tm.is_watertight and tm.is_winding_consistent


def test_a_large_group_reports_progress_within_its_union_and_unites_the_same_solid():
    rng = np.random.default_rng(3)
    asm = Assembly()
    meshes = []
    for k in range(80):                  # 80 rods crossing in one cube: one group
        a, b = rng.uniform(0, 1, 3), rng.uniform(0, 1, 3)
        meshes.append(Pipe([a, b], 0.03, sides=6).mesh())
        asm.add(f"rod{k}", meshes[-1])
    calls = []
    solid = asm.union(progress=lambda *call: calls.append(call))
    union = [(text, done, total) for text, done, total in calls if text.startswith("union")]
    # solids united so far, moving within the one group (batches of about sqrt(80))
    assert union[0] == ("union of 80 solids in 1 group", 0, 80)
    moves = [done for text, done, _ in union if text == "union of 80 solids in 1 group"]
    assert moves == sorted(moves) and len(set(moves)) >= 8
    joins = [(done, total) for text, done, total in union
             if text == "union of 80 solids in 1 group: joining 9 batches"]
    assert joins == [(k, 8) for k in range(1, 9)]        # 9 batches joined in pairs: 8 calls
    # the same solid as manifold3d's single union of the same meshes
    whole = manifold3d.Manifold.batch_boolean(
        [m.to_manifold(f"rod{k}", k + 1) for k, m in enumerate(meshes)], manifold3d.OpType.Add)
    assert solid.volume == pytest.approx(whole.volume(), rel=1e-9)
    assert cadpipe.check_mesh(solid)["valid"]
