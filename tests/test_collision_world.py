"""CollisionWorld: the public API, its reports and its errors."""

import numpy as np
import pytest
import trimesh

import cadpipe
from cadpipe import CollisionWorld, InputError, Mesh, MeshError, Path, Pipe
from cadpipe.collision import STAGES, Box, Capsule, Sphere, bounds


def shift(x=0.0, y=0.0, z=0.0):
    m = np.eye(4)
    m[:3, 3] = (x, y, z)
    return m


def cube(size=1.0):
    return Mesh.from_trimesh(trimesh.creation.box(extents=(size, size, size)))


def test_exported_from_the_package():
    assert cadpipe.CollisionWorld is CollisionWorld


def test_touching_and_apart_pairs_are_reported_in_insertion_order():
    world = CollisionWorld()
    world.add("c", cube(), transform=shift(10))
    world.add("a", cube())
    world.add("b", cube(), transform=shift(0.5))
    world.add("d", Sphere(0.4), transform=shift(10.5))
    report = world.check()
    assert [(a, b) for a, b, _ in report.collisions] == [("c", "d"), ("a", "b")]
    assert all(d.colliding and d.phase == "world" for _, _, d in report.collisions)
    decided = {(p.a, p.b): p.decided_by for p in report.pairs}
    assert decided[("c", "a")] == "aabb"
    assert decided[("a", "b")] == "fcl"
    assert decided[("c", "d")] == "fcl"
    assert set(decided.values()) <= set(STAGES)


def test_same_group_pairs_are_self_collisions_and_come_first():
    world = CollisionWorld()
    world.add("tool", cube(), transform=shift(5))
    world.add("obstacle", cube(), transform=shift(5.5))
    world.add("l1", cube(), group="arm")
    world.add("l2", cube(), transform=shift(0.9), group="arm")
    world.add("l3", cube(), transform=shift(1.8), group="arm")
    world.allow("l1", "l2", reason="adjacent links")
    report = world.check()
    assert [(a, b, d.phase) for a, b, d in report.collisions] == [
        ("l2", "l3", "self"), ("tool", "obstacle", "world")]
    assert report.allowed == [("l1", "l2", "adjacent links")]
    assert world.allowed == [("l1", "l2", "adjacent links")]


def test_stop_after_self_collision_leaves_the_rest_unchecked():
    world = CollisionWorld()
    world.add("l1", cube(), group="arm")
    world.add("l2", cube(), transform=shift(0.5), group="arm")
    world.add("wall", cube(), transform=shift(0.7))
    stopped = world.check(stop_after_self=True)
    assert stopped.stopped_after_self
    assert [(a, b) for a, b, _ in stopped.collisions] == [("l1", "l2")]
    assert {p.decided_by for p in stopped.pairs if p.phase == "world"} == {"not checked"}
    full = world.check()
    assert not full.stopped_after_self
    assert len(full.collisions) == 3
    world.set_pose("l2", shift(3))
    clean = world.check(stop_after_self=True)
    assert not clean.stopped_after_self and [(a, b) for a, b, _ in clean.collisions] == [
        ("l1", "wall")]


def test_a_solid_inside_another_is_a_collision():
    world = CollisionWorld()
    world.add("big", cube(4.0))
    world.add("small", cube(0.5), transform=shift(0.3, -0.2, 0.1))
    world.add("ball", Sphere(0.2), transform=shift(-1, 1, 1))
    world.add("pipe", Pipe([[-1, -1, -1], [1, -1, -1], [1, 1, -1]], 0.1, caps="round"))
    hits = {(a, b): d.decided_by for a, b, d in world.check().collisions}
    assert hits == {("big", "small"): "containment", ("big", "ball"): "containment",
                    ("big", "pipe"): "containment"}
    # the other way round: the big solid is never inside the small one
    assert world.distance("small", "big").colliding
    assert world.distance("small", "big").decided_by == "containment"


def test_box_stages_decide_what_they_can():
    world = CollisionWorld()
    rot = np.eye(4)
    rot[:3, :3] = trimesh.transformations.rotation_matrix(np.pi / 4, [0, 0, 1])[:3, :3]
    world.add("a", Box((4.0, 0.2, 0.2)), transform=rot)
    # inside a's AABB but clear of its OBB: decided without the narrow phase
    world.add("b", Box((0.2, 0.2, 0.2)), transform=shift(1.2, -1.2, 0))
    report = world.check()
    assert report.pairs[0].decided_by in ("obb", "kdop")
    assert not report.collisions


def test_moved_objects_are_checked_again_and_static_pairs_reuse_results():
    world = CollisionWorld()
    world.add("a", cube())
    world.add("b", cube(), transform=shift(0.5))
    assert world.check().collisions
    assert world.check().collisions          # cached, same answer
    world.set_pose("b", shift(3))
    assert not world.check().collisions
    np.testing.assert_allclose(world.pose("b"), shift(3))
    np.testing.assert_allclose(world.bounds("b"), [[2.5, -0.5, -0.5], [3.5, 0.5, 0.5]])


def test_distance_reports_clearance_and_closest_points():
    world = CollisionWorld()
    world.add("a", cube())
    world.add("b", Sphere(0.5), transform=shift(2, 0, 0))
    world.add("p", Capsule(0.25, 1.0), transform=shift(0, 3, 0))
    c = world.distance("a", "b")
    assert not c.colliding
    assert c.distance == pytest.approx(1.0, abs=1e-6)
    np.testing.assert_allclose(c.point_a, [0.5, 0, 0], atol=1e-6)
    np.testing.assert_allclose(c.point_b, [1.5, 0, 0], atol=1e-6)
    c = world.distance("b", "p")
    assert c.distance == pytest.approx(np.hypot(2, 3) - 0.75, abs=1e-9)
    assert np.linalg.norm(c.point_b - c.point_a) == pytest.approx(c.distance, abs=1e-9)
    c = world.distance("p", "a")
    assert c.distance == pytest.approx(2.25, abs=1e-6)
    np.testing.assert_allclose(c.point_a[1], 2.75, atol=1e-6)
    np.testing.assert_allclose(c.point_b[1], 0.5, atol=1e-6)


def test_inside_tells_where_a_tool_path_leaves_the_pipe():
    world = CollisionWorld()
    world.add("fixture", Pipe([[0, 0, 0], [10, 0, 0], [10, 10, 0]], 1.0, caps="round"),
              transform=shift(0, 0, 5))
    path = np.array([[1, 0, 5], [9, 0.5, 5], [9.5, 9, 5], [12, 9, 5]])
    result = world.inside("fixture", path)
    np.testing.assert_array_equal(result.inside, [True, True, True, False])
    assert result.exit_segment == 2
    np.testing.assert_allclose(result.exit_point, [11, 9, 5], atol=1e-9)
    assert not result.all_inside
    # both ends inside, but the straight move cuts the corner of the bend
    cut = world.inside("fixture", [[5, 0, 5], [10, 5, 5]])
    assert cut.inside.all() and not cut.all_inside
    t = cut.exit_fraction
    point = np.array([5, 0, 5]) + t * np.array([5, 5, 0])
    np.testing.assert_allclose(cut.exit_point, point)
    assert np.hypot(point[0] - 10, point[1] - 0) > 1 - 1e-9      # on the wall, past the bend
    inside = world.inside("fixture", [[1, 0, 5], [10, 1, 5], [10, 9, 5]])
    assert inside.all_inside and inside.exit_point is None
    outside = world.inside("fixture", [[0, 5, 5], [5, 0, 5]])
    assert outside.exit_segment == 0 and outside.exit_fraction == 0.0


def test_a_large_scene_finds_exactly_the_touching_neighbours():
    world = CollisionWorld()
    for k in range(60):
        world.add(f"s{k}", Sphere(0.3), transform=shift(0.5 * k))
    assert [(a, b) for a, b, _ in world.check().collisions] == [
        (f"s{k}", f"s{k + 1}") for k in range(59)]


def test_report_to_dict_is_plain_data():
    world = CollisionWorld()
    world.add("a", cube())
    world.add("b", cube(), transform=shift(0.5))
    data = world.check().to_dict()
    assert data["collisions"] == [{"a": "a", "b": "b", "decided_by": "fcl", "phase": "world"}]
    assert data["counts"] == {"fcl": 1}
    assert not data["stopped_after_self"]


@pytest.mark.parametrize("transform, match", [
    (np.full((4, 4), np.nan), "NaN or infinite"),
    (np.eye(3), "4x4"),
    (np.diag([2.0, 1.0, 1.0, 1.0]), "rigid"),
    (np.diag([-1.0, 1.0, 1.0, 1.0]), "rigid"),
    ("spam", "4x4 matrix of numbers"),
])
def test_bad_transforms_are_refused(transform, match):
    world = CollisionWorld()
    with pytest.raises(InputError, match=match):
        world.add("a", cube(), transform=transform)
    world.add("b", cube())
    with pytest.raises(InputError, match=match):
        world.set_pose("b", transform)
    world.add("c", cube())
    with pytest.raises(InputError, match=match):
        world.collide_at("c", "b", np.eye(4), transform)
    np.testing.assert_array_equal(world.pose("b"), np.eye(4))      # a refused pose moves nothing


def test_unknown_names_and_bad_objects_are_refused():
    world = CollisionWorld()
    world.add("a", cube())
    for call in (lambda: world.distance("a", "ghost"), lambda: world.allow("ghost", "a"),
                 lambda: world.set_pose("ghost", np.eye(4)), lambda: world.separate("a", "x"),
                 lambda: world.inside("ghost", [[0, 0, 0]])):
        with pytest.raises(InputError, match="unknown object 'ghost'|unknown object 'x'"):
            call()
    with pytest.raises(InputError, match="already in the world"):
        world.add("a", cube())
    with pytest.raises(InputError, match="cannot collide with itself"):
        world.allow("a", "a")
    with pytest.raises(InputError, match="cannot check a str"):
        world.add("b", "a mesh")
    with pytest.raises(InputError, match="needs a pipe"):
        world.inside("a", [[0, 0, 0]])
    with pytest.raises(InputError, match="non-empty string"):
        world.add("", cube())


def test_open_meshes_are_refused_where_a_solid_is_needed():
    box = trimesh.creation.box()
    open_box = Mesh(box.vertices, box.faces[:-2])
    with pytest.raises(MeshError, match="not a closed solid"):
        CollisionWorld().add("lid-less", open_box)
    flipped = Mesh(box.vertices, box.faces[:, ::-1])
    with pytest.raises(MeshError, match="inward"):
        CollisionWorld().add("inside-out", flipped)


def test_pipes_are_never_tessellated():
    world = CollisionWorld()
    world.add("p", Pipe(Path([[0, 0, 0], [1, 0, 0], [2, 1, 0]]), 0.1))
    body = world.bodies[0]
    assert body.kind == "chain" and body.mesh is None


@pytest.mark.parametrize("size", [1e-6, 1e-3, 1.0])
@pytest.mark.parametrize("offset", [0.0, 1.0, 300.0])
def test_bounds_contain_objects_of_any_size_anywhere(size, offset):
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(int(size * 1e6) + int(offset))
    mesh = trimesh.creation.icosphere(2, radius=size)
    mesh.vertices = mesh.vertices * [1.0, 0.4, 0.2]          # an ellipsoid: a real OBB fit
    world = CollisionWorld()
    pose = np.eye(4)
    pose[:3, :3] = Rotation.random(random_state=rng).as_matrix()
    pose[:3, 3] = offset + size * rng.uniform(-1, 1, 3)
    world.add("part", Mesh.from_trimesh(mesh), transform=pose)
    points = mesh.vertices @ pose[:3, :3].T + pose[:3, 3]
    lo, hi = world.bounds("part")
    assert np.all(points >= lo) and np.all(points <= hi)
    body = world.body("part")
    centre, axes, half = body.obb
    assert np.all(np.abs((mesh.vertices - centre) @ axes) <= half)
    kdop, _, _ = world.checker.placed()
    reach = points @ bounds.KDOP_DIRECTIONS.T
    assert np.all(reach >= kdop[0, 0]) and np.all(reach <= kdop[0, 1])


def test_micrometre_meshes_are_checked_like_metre_ones():
    import fcl

    world = CollisionWorld()
    ball = trimesh.creation.icosphere(2, radius=1e-6)
    world.add("a", Mesh.from_trimesh(ball))
    world.add("b", Mesh.from_trimesh(ball), transform=shift(1.9e-6))
    world.add("c", Mesh.from_trimesh(ball), transform=shift(4.5e-6))
    report = world.check()
    objects = []
    for x in (0.0, 1.9e-6, 4.5e-6):
        bvh = fcl.BVHModel()
        bvh.beginModel(len(ball.vertices), len(ball.faces))
        bvh.addSubModel(ball.vertices, ball.faces)
        bvh.endModel()
        objects.append(fcl.CollisionObject(bvh, fcl.Transform(np.array([x, 0.0, 0.0]))))
    expected = {(n[i], n[j]) for n in ["abc"] for i in range(3) for j in range(i + 1, 3)
                if fcl.collide(objects[i], objects[j], fcl.CollisionRequest(),
                               fcl.CollisionResult())}
    assert {(a, b) for a, b, _ in report.collisions} == expected == {("a", "b")}
