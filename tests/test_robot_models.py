"""Stock robots from the example-robot-data wheel: package resolution, open meshes,
forward kinematics of every frame, and verdicts against python-fcl."""

import shutil
from pathlib import Path as FilePath

import numpy as np
import pytest

from cadpipe import CollisionWorld, InputError
from cadpipe.collision import Robot
from cadpipe.collision.packages import resolve

PANDA = FilePath(__file__).parent.parent / "assets" / "robots" / "panda"


def _robots_folder():
    from cadpipe.collision.packages import _python_prefixes

    for prefix in _python_prefixes():
        folder = prefix / "share" / "example-robot-data" / "robots"
        if folder.is_dir():
            return folder
    raise AssertionError("example-robot-data is in the test extra but not installed")


ROBOTS = _robots_folder()
ALL_URDFS = sorted(ROBOTS.rglob("*.urdf"))
WITH_GEOMETRY = [f for f in ALL_URDFS if "<collision" in f.read_text(errors="replace")]
#: a file of the wheel whose mimic joints name joints it does not have
BROKEN = {"alex_psyonic_hands.urdf": "mimics unknown joint"}
#: arms, quadrupeds, humanoids, hands: (URDF below robots/, SRDF or None)
SAMPLE = [
    ("panda_description/urdf/panda.urdf", "panda_description/srdf/panda.srdf"),
    ("ur_description/urdf/ur5_robot.urdf", None),
    ("solo_description/robots/solo12.urdf", None),
    ("anymal_b_simple_description/robots/anymal.urdf", None),
    ("talos_data/robots/talos_reduced.urdf", None),
    ("romeo_description/urdf/romeo_small.urdf", None),
    ("g1_description/urdf/g1_29dof_rev_1_0.urdf", None),
    ("allegro_hand_description/urdf/allegro_right_hand.urdf", None),
]


def _random_configurations(robot, count, rng):
    lower, upper = robot.limits
    lower, upper = np.where(np.isfinite(lower), lower, -np.pi), np.where(np.isfinite(upper),
                                                                         upper, np.pi)
    return rng.uniform(lower, upper, size=(count, len(lower)))


@pytest.mark.slow
def test_every_stock_urdf_with_collision_geometry_loads():
    assert len(WITH_GEOMETRY) >= 60
    loaded = 0
    for urdf in WITH_GEOMETRY:
        if urdf.name in BROKEN:
            with pytest.raises(InputError, match=BROKEN[urdf.name]):
                Robot.from_urdf(urdf)
            continue
        robot = Robot.from_urdf(urdf)
        poses = robot.frame_poses(robot.default[None], robot.frames[-1])
        assert np.isfinite(poses).all(), urdf
        lower, upper = robot.limits
        assert np.all((robot.default >= lower) & (robot.default <= upper)), urdf
        for link in robot.link_meshes:
            assert link in robot.open_links or robot.link_meshes[link].is_watertight
        loaded += 1
    assert loaded == len(WITH_GEOMETRY) - len(BROKEN)


@pytest.fixture(scope="module")
def sample():
    return {urdf: Robot.from_urdf(ROBOTS / urdf, srdf=srdf and ROBOTS / srdf)
            for urdf, srdf in SAMPLE}


def _fcl_object(mesh):
    import fcl

    bvh = fcl.BVHModel()
    bvh.beginModel(len(mesh.vertices), len(mesh.faces))
    bvh.addSubModel(np.asarray(mesh.vertices), np.asarray(mesh.faces))
    bvh.endModel()
    return fcl.CollisionObject(bvh, fcl.Transform())


@pytest.mark.parametrize("urdf", [u for u, _ in SAMPLE])
def test_self_collision_verdicts_match_fcl(sample, urdf):
    """Every link pair at random configurations: cadpipe's verdict is FCL's on the
    same meshes, except that cadpipe also sees one link wholly inside another."""
    import fcl

    robot = sample[urdf]
    world = CollisionWorld()
    world.add_robot(robot)
    rng = np.random.default_rng(11)
    q = _random_configurations(robot, 6, rng)
    reports = world.check_path(robot.name, q)
    objects = {k: _fcl_object(m) for k, m in robot.link_meshes.items()}
    first, second = np.triu_indices(len(world.names), k=1)
    request = fcl.CollisionRequest()
    compared = hits = 0
    for c, poses in enumerate(robot.link_pose_array(q)):
        by_link = dict(zip(robot.link_meshes, poses))
        report = reports[c]
        for pair in report.pairs:
            if pair.decided_by in ("allowed", "containment"):
                continue
            a, b = objects[pair.a], objects[pair.b]
            a.setTransform(fcl.Transform(by_link[pair.a][:3, :3], by_link[pair.a][:3, 3]))
            b.setTransform(fcl.Transform(by_link[pair.b][:3, :3], by_link[pair.b][:3, 3]))
            expected = fcl.collide(a, b, request, fcl.CollisionResult()) > 0
            assert pair.colliding == expected, (urdf, c, pair)
            compared += 1
            hits += expected
    assert compared > 50
    assert len(first) > 0


def test_frame_poses_match_yourdfpy_for_frames_without_geometry(sample):
    import yourdfpy

    robot = sample[SAMPLE[0][0]]
    reference = yourdfpy.URDF.load(str(ROBOTS / SAMPLE[0][0]), load_meshes=False)
    q = _random_configurations(robot, 5, np.random.default_rng(2))
    many = robot.frame_poses(q, "panda_hand")
    assert many.shape == (5, 4, 4)
    for c in range(5):
        reference.update_cfg(q[c])
        np.testing.assert_allclose(many[c], reference.get_transform("panda_hand", robot.base),
                                   atol=1e-12)
    local = Robot.from_urdf(PANDA / "panda.urdf")
    one = local.frame_poses(q[0], "panda_hand_tcp")
    reference = yourdfpy.URDF.load(str(PANDA / "panda.urdf"), load_meshes=False)
    reference.update_cfg(q[0])
    np.testing.assert_allclose(one, reference.get_transform("panda_hand_tcp", local.base),
                               atol=1e-12)
    assert "panda_hand_tcp" not in local.link_meshes
    with pytest.raises(InputError, match="no such link"):
        local.frame_poses(q[0], "tool0")


def test_packages_resolve_through_every_route(tmp_path, monkeypatch):
    package = tmp_path / "somewhere" / "my_robot"
    (package / "urdf").mkdir(parents=True)
    (package / "meshes").mkdir()
    urdf = package / "urdf" / "r.urdf"
    urdf.write_text("<robot name='r'/>")
    # walking up from the URDF: the folder's name, then its package.xml
    assert resolve("package://my_robot/meshes/a.stl", urdf) == package / "meshes" / "a.stl"
    assert resolve("package:///my_robot/meshes/a.stl", urdf) == package / "meshes" / "a.stl"
    other = tmp_path / "renamed"
    shutil.copytree(package, other)
    (other / "package.xml").write_text("<package><name>my_robot</name></package>")
    assert resolve("package://my_robot/m.stl", other / "urdf" / "r.urdf") == other / "m.stl"
    # explicit folders: a mapping, a package folder or its parent; then ROS_PACKAGE_PATH
    elsewhere = tmp_path / "elsewhere.urdf"
    assert resolve("package://my_robot/m.stl", elsewhere, {"my_robot": other}) == other / "m.stl"
    assert resolve("package://my_robot/m.stl", elsewhere, [package.parent]) == package / "m.stl"
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(package.parent))
    assert resolve("package://my_robot/m.stl", elsewhere) == package / "m.stl"
    monkeypatch.delenv("ROS_PACKAGE_PATH")
    with pytest.raises(InputError, match="package 'nowhere' .* not found; searched") as caught:
        resolve("package://nowhere/m.stl", elsewhere, [tmp_path])
    assert str(tmp_path / "nowhere") in str(caught.value) and caught.value.key == "package_dirs"
    assert resolve("meshes/a.stl", urdf) == urdf.parent / "meshes" / "a.stl"


def test_a_stock_urdf_copied_away_finds_its_meshes_in_the_wheel(tmp_path, monkeypatch):
    """Walking up from a copy finds no package: the wheel's share folder does."""
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)
    source = ROBOTS / SAMPLE[0][0]
    copy = tmp_path / "mine.urdf"
    shutil.copy(source, copy)
    assert "package://example-robot-data/" in copy.read_text()
    robot = Robot.from_urdf(copy)
    reference = Robot.from_urdf(source)
    assert list(robot.link_meshes) == list(reference.link_meshes)
    for link, mesh in robot.link_meshes.items():
        np.testing.assert_array_equal(mesh.vertices, reference.link_meshes[link].vertices)


def test_missing_mesh_is_an_input_error_naming_it(tmp_path):
    urdf = tmp_path / "r.urdf"
    urdf.write_text("<robot name='r'><link name='a'><collision><geometry>"
                    "<mesh filename='package://ghost_pkg/m.stl'/></geometry></collision>"
                    "</link></robot>")
    with pytest.raises(InputError, match="package 'ghost_pkg'"):
        Robot.from_urdf(urdf)
    urdf.write_text("<robot name='r'><link name='a'><collision><geometry>"
                    "<mesh filename='m.stl'/></geometry></collision></link></robot>")
    with pytest.raises(InputError, match="collision mesh m.stl not found"):
        Robot.from_urdf(urdf)


def _open_box_robot(tmp_path):
    """A two-link robot whose second link's mesh is a box missing its top, behind a
    fixed joint with a zero axis, and a prismatic joint whose range excludes 0."""
    import trimesh

    box = trimesh.creation.box(extents=[0.2, 0.2, 0.2])
    box.update_faces(box.face_normals[:, 2] < 0.9)
    box.export(tmp_path / "open.stl")
    trimesh.creation.box(extents=[0.1, 0.1, 0.1]).export(tmp_path / "closed.stl")
    urdf = tmp_path / "r.urdf"
    urdf.write_text("""<robot name='r'>
      <link name='base'><collision><geometry><mesh filename='closed.stl'/></geometry>
      </collision></link>
      <link name='mid'/>
      <link name='cup'><collision><geometry><mesh filename='open.stl'/></geometry>
      </collision></link>
      <joint name='fix' type='fixed'><parent link='base'/><child link='mid'/>
        <origin xyz='0 0 1'/><axis xyz='0 0 0'/></joint>
      <joint name='slide' type='prismatic'><parent link='mid'/><child link='cup'/>
        <axis xyz='1 0 0'/><limit lower='0.5' upper='1.5' effort='1' velocity='1'/></joint>
    </robot>""")
    return urdf


def test_open_meshes_hull_or_as_given_zero_axis_and_default_pose(tmp_path):
    from cadpipe.collision import Box

    urdf = _open_box_robot(tmp_path)
    hulled = Robot.from_urdf(urdf)
    assert "convex hull" in hulled.notes["cup"] and "base" not in hulled.notes
    assert hulled.link_meshes["cup"].is_watertight
    assert hulled.default.tolist() == [1.0]                 # 0 is outside [0.5, 1.5]
    pose = hulled.frame_poses(None, "cup")
    np.testing.assert_allclose(pose[:3, 3], [1.0, 0.0, 1.0])     # no NaN below the fixed joint
    kept = Robot.from_urdf(urdf, open_meshes="as given")
    assert "kept as given" in kept.notes["cup"] and kept.open_links == {"cup"}
    # a small box inside the cup: inside the hull, but an open cup has no inside
    for robot, inside in ((hulled, True), (kept, False)):
        world = CollisionWorld()
        world.add_robot(robot)
        world.add("pebble", Box((0.02, 0.02, 0.02)), transform=pose)
        assert bool(world.check().collisions) == inside
        # the cup's walls collide either way
        wall = pose.copy()
        wall[0, 3] += 0.1
        world.set_pose("pebble", wall)
        assert world.check().collisions
    with pytest.raises(InputError, match="open_meshes"):
        Robot.from_urdf(urdf, open_meshes="repair")
