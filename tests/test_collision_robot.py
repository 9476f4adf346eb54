"""Robots from URDF: kinematics, allowed pairs and self-collision on the real Panda arm."""

from pathlib import Path as FilePath

import numpy as np
import pytest

from cadpipe import CollisionWorld, InputError, SpecError
from cadpipe.collision import Robot, srdf_disabled_pairs

PANDA = FilePath(__file__).parent.parent / "assets" / "robots" / "panda"
URDF, SRDF = PANDA / "panda.urdf", PANDA / "panda.srdf"
READY = [0, -0.785398, 0, -2.35619, 0, 1.5707, 0.785398, 0.001]
#: a folded pose where link5 swings into link1 (found by search, confirmed below)
FOLDED = [-1.726, 1.544, -2.348, -3.057, -1.026, 3.718, -1.363, 0.033]


@pytest.fixture(scope="module")
def panda():
    return Robot.from_urdf(URDF, srdf=SRDF)


def test_forward_kinematics_matches_yourdfpy(panda):
    import yourdfpy

    reference = yourdfpy.URDF.load(str(URDF), load_meshes=False)
    rng = np.random.default_rng(3)
    limits = [(j.lower, j.upper) for j in panda.joints if j.name in panda.actuated]
    for _ in range(20):
        q = [rng.uniform(lo, hi) for lo, hi in limits]
        reference.update_cfg(np.array(q))
        for link, pose in panda.link_poses(q).items():
            np.testing.assert_allclose(pose, reference.get_transform(link, panda.base),
                                       atol=1e-12)


def test_links_closed_adjacent_pairs_and_srdf(panda):
    assert set(panda.link_meshes) == {f"panda_link{i}" for i in range(8)} | {
        "panda_hand", "panda_leftfinger", "panda_rightfinger"}
    assert all(m.is_watertight for m in panda.link_meshes.values())
    adjacent = [(a, b) for a, b, r in panda.allowed_pairs if r == "adjacent links"]
    # link7 -> hand skips the geometry-less flange link8, as MoveIt does
    assert ("panda_link7", "panda_hand") in adjacent and len(adjacent) == 10
    srdf = srdf_disabled_pairs(SRDF)
    assert len(srdf) == 35 and ("panda_link0", "panda_link2", "srdf: Never") in srdf
    assert panda.actuated[-1] == "panda_finger_joint1"          # the mimic finger is derived


def test_adjacent_links_touch_but_are_allowed():
    bare = Robot.from_urdf(URDF)                 # adjacency only, no SRDF
    world = CollisionWorld()
    world.add_robot(bare, READY)
    assert not world.check().collisions
    # the same links without the allowed pairs: the adjacent ones really touch
    loose = CollisionWorld()
    for link, pose in bare.link_poses(READY).items():
        loose.add(link, bare.link_meshes[link], transform=pose, group="panda")
    touching = {(a, b) for a, b, _ in loose.check().collisions}
    adjacent = {(a, b) for a, b, _ in bare.allowed_pairs}
    assert len(touching & adjacent) >= 7
    assert touching <= adjacent


def test_non_adjacent_links_touching_are_reported(panda):
    world = CollisionWorld()
    world.add_robot(panda, FOLDED)
    report = world.check()
    assert [(a, b, d.phase) for a, b, d in report.collisions] == [
        ("panda_link1", "panda_link5", "self")]
    poses = panda.link_poses(FOLDED)
    solids = [panda.link_meshes[n].transformed(poses[n]).to_manifold()
              for n in ("panda_link1", "panda_link5")]
    assert (solids[0] ^ solids[1]).volume() > 1e-9           # manifold3d agrees
    world.set_joints("panda", READY)
    assert not world.check().collisions


def test_self_collision_stops_the_check_as_the_source_does(panda):
    from cadpipe.collision import Box

    world = CollisionWorld()
    world.add_robot(panda, FOLDED)
    world.add("table", Box((2.0, 2.0, 0.1)), transform=np.eye(4))
    report = world.check(stop_after_self=True)
    assert report.stopped_after_self
    assert [a for a, _, _ in report.collisions] == ["panda_link1"]
    full = world.check()
    assert ("panda_link0", "table") in {(a, b) for a, b, _ in full.collisions}


def test_joint_values_are_checked(panda):
    with pytest.raises(InputError, match="has 8 joints"):
        panda.link_poses([0.0, 0.1])
    with pytest.raises(InputError, match="unknown joint 'elbow'"):
        panda.link_poses({"elbow": 1.0})
    with pytest.raises(InputError, match="panda_joint4=0.5 is outside its limits"):
        panda.link_poses({"panda_joint4": 0.5})
    with pytest.raises(InputError, match="outside its limits"):
        panda.link_poses([np.nan] * 8)
    world = CollisionWorld()
    world.add_robot(panda, READY)
    with pytest.raises(InputError, match="no robot in group 'arm'"):
        world.set_joints("arm", READY)
    with pytest.raises(InputError, match="already in the world"):
        world.add_robot(panda, READY)


def test_bad_robot_files_are_refused(tmp_path):
    with pytest.raises(SpecError, match="no such URDF"):
        Robot.from_urdf(tmp_path / "missing.urdf")
    broken = tmp_path / "broken.urdf"
    broken.write_text("<robot name='x'><link name='a'>")
    with pytest.raises(SpecError, match="not readable XML"):
        Robot.from_urdf(broken)
    for text, said in (("<robot/>", "a <robot> with no name and no <link>"),   # ur3.urdf's
                       ("<robot name='r'/>", "a <robot> with no <link>"),
                       ("<sdf><model name='m'/></sdf>", "this is a <sdf>")):
        broken.write_text(text)
        with pytest.raises(SpecError, match="not a URDF robot") as info:
            Robot.from_urdf(broken)
        assert said in str(info.value)
    with pytest.raises(SpecError, match="no such SRDF"):
        srdf_disabled_pairs(tmp_path / "missing.srdf")
