"""Agreement with independent references over thousands of random poses.

Collision: manifold3d's intersection volume of the same solids (> 0 iff they
collide, containment included), away from a thin tolerance band. Distance:
python-fcl's own answer for the same shapes (BVHs, or capsules for pipes).
Each fixture draws its poses at once from a seeded generator; the meshes are
small so the whole file runs in a few seconds per fixture.
"""

import fcl
import manifold3d
import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

from cadpipe import CollisionWorld, Mesh, Path, Pipe
from cadpipe.collision import Box, Joint, Robot
from oracle import fcl_bvh

N_POSES = 2000
#: a pair "collides" for the oracle when its intersection volume exceeds this
VOLUME_EPS = 1e-9


def poses(seed, n, spread):
    """``n`` random rigid poses: uniform rotations, translations in a cube."""
    rng = np.random.default_rng(seed)
    out = np.tile(np.eye(4), (n, 1, 1))
    out[:, :3, :3] = Rotation.random(n, random_state=rng).as_matrix()
    out[:, :3, 3] = rng.uniform(-spread, spread, (n, 3))
    return out


def volume(solid_a, solid_b, pose_b):
    return (solid_a ^ solid_b.transform(pose_b[:3])).volume()


def torus(major=1.0, minor=0.3):
    return Mesh.from_trimesh(trimesh.creation.torus(major, minor, major_sections=16,
                                                    minor_sections=8))


def c_shape():
    solid = manifold3d.Manifold.cube((2.0, 2.0, 1.0)) - manifold3d.Manifold.cube(
        (1.5, 1.0, 1.2)).translate((0.5, 0.5, -0.1))
    return Mesh.from_manifold(solid.translate((-1.0, -1.0, -0.5)))


def fcl_distance(geom_a, pose_a, geom_b, pose_b):
    obj_a = fcl.CollisionObject(geom_a, fcl.Transform(pose_a[:3, :3], pose_a[:3, 3]))
    obj_b = fcl.CollisionObject(geom_b, fcl.Transform(pose_b[:3, :3], pose_b[:3, 3]))
    return fcl.distance(obj_a, obj_b, fcl.DistanceRequest(), fcl.DistanceResult())


def capsules(pipe, pose):
    """FCL capsules (with world poses) of a constant-radius pipe's collision units
    (:meth:`Pipe.collision_units`: segments and miter-tip capsules)."""
    starts, ends, radii, _ = pipe.collision_units()
    starts, ends = (q @ pose[:3, :3].T + pose[:3, 3] for q in (starts, ends))
    out = []
    for a, b, r in zip(starts, ends, radii):
        axis = b - a
        length = float(np.linalg.norm(axis))
        m = np.eye(4)
        m[:3, 3] = 0.5 * (a + b)
        if length > 0:
            m[:3, :3] = Rotation.align_vectors([axis], [[0, 0, 1]])[0].as_matrix()
            out.append((fcl.Capsule(float(r), length), m))
        else:
            out.append((fcl.Sphere(float(r)), m))
    return out


def agreement(ours, volumes, band_ok):
    """Every disagreement with the oracle must lie in the tolerance band; returns
    the counts of colliding and apart poses so a test can check both occur."""
    hit = volumes > VOLUME_EPS
    disagree = np.flatnonzero(ours != hit)
    bad = [k for k in disagree if not band_ok(k)]
    assert not bad, f"{len(bad)} poses disagree with manifold3d, e.g. pose {bad[0]}"
    assert len(disagree) <= 0.01 * len(ours)
    return int(hit.sum()), int((~hit).sum())


def run(world, name, all_poses, solid_a, solid_b, other="a"):
    ours = np.empty(len(all_poses), bool)
    stages = []
    vols = np.empty(len(all_poses))
    for k, pose in enumerate(all_poses):
        world.set_pose(name, pose)
        report = world.check()
        ours[k] = bool(report.collisions)
        stages.append(report.pairs[0].decided_by)
        vols[k] = volume(solid_a, solid_b, pose)
    return ours, np.array(stages), vols


@pytest.mark.parametrize("fixture", ["tori", "boxes", "concave"])
def test_meshes_agree_with_manifold_and_fcl(fixture):
    shapes = {"tori": (torus(), torus(), 1.6), "boxes": (Box((2.0, 2.0, 2.0)), Mesh.from_trimesh(
        trimesh.creation.box(extents=(0.4, 0.5, 0.3))), 1.4),
        "concave": (c_shape(), Mesh.from_trimesh(trimesh.creation.icosphere(1, 0.2)), 1.1)}
    a, b, spread = shapes[fixture]
    world = CollisionWorld()
    world.add("a", a)
    world.add("b", b)
    mesh_a = world.bodies[0].mesh
    all_poses = poses({"tori": 1, "boxes": 2, "concave": 3}[fixture], N_POSES, spread)
    ours, stages, vols = run(world, "b", all_poses, mesh_a.to_manifold(), b.to_manifold())
    # FCL and manifold3d are both exact on the same triangles: only grazing poses differ
    hits, misses = agreement(ours, vols, band_ok=lambda k: ours[k] and vols[k] <= 1e-6)
    assert hits > 200 and misses > 200
    if fixture != "tori":
        assert (stages == "containment").sum() > 20          # FCL alone misses these
    assert {"aabb", "fcl"} <= set(stages)
    apart = np.flatnonzero(~ours)[:400]
    geom_a, geom_b = fcl_bvh(mesh_a), fcl_bvh(b)
    for k in apart:
        world.set_pose("b", all_poses[k])
        expected = fcl_distance(geom_a, np.eye(4), geom_b, all_poses[k])
        assert world.distance("a", "b").distance == pytest.approx(expected, abs=1e-6)


def test_linked_tori_are_decided_by_the_exact_test():
    """Linked rings, tilted so that no axis plane separates their shadows: no
    certificate can exist, and the exact test still finds them apart."""
    tilt = np.eye(4)
    tilt[:3, :3] = Rotation.from_euler("xyz", [30, 40, 20], degrees=True).as_matrix()
    linked = np.eye(4)
    linked[:3, :3] = Rotation.from_euler("x", 90, degrees=True).as_matrix()
    linked[:3, 3] = (1.0, 0.0, 0.0)
    world = CollisionWorld()
    world.add("a", torus(), transform=tilt)
    world.add("b", torus(), transform=tilt @ linked)
    solids = [torus().to_manifold().transform(m[:3]) for m in (tilt, tilt @ linked)]
    for axis in range(3):                      # every axis-plane shadow overlaps
        to_z = np.eye(3)[[(axis + 1) % 3, (axis + 2) % 3, axis]]
        shadows = [s.transform(np.hstack([to_z, np.zeros((3, 1))])).project() for s in solids]
        assert (shadows[0] ^ shadows[1]).area() > 0.01
    report = world.check()
    assert not report.collisions and report.pairs[0].decided_by == "fcl"
    assert world.separate("a", "b") is None
    assert (solids[0] ^ solids[1]).volume() == 0
    assert world.distance("a", "b").distance > 0.3


def pipe_pair():
    """Two smooth pipes (a spline, a filleted zigzag): their meshes stay within 2 % of
    a radius of the round tubes, so that is the oracle's tolerance band."""
    arc = Path.spline([[-1.0, -0.6, 0.0], [0.0, 0.4, 0.1], [1.0, -0.5, 0.0]], step=0.08)
    zig = Path([[-0.8, 0.0, -0.3], [-0.2, 0.3, 0.0], [0.4, -0.2, 0.2], [0.9, 0.1, 0.0]])
    return (Pipe(arc, 0.15, sides=24, caps="round"),
            Pipe(zig.filleted(0.2), 0.12, sides=24, caps="round", corners="round"))


def test_pipes_agree_with_manifold_on_their_meshes_and_with_fcl_capsules():
    pipe_a, pipe_b = pipe_pair()
    world = CollisionWorld()
    world.add("a", pipe_a)
    world.add("b", pipe_b)
    all_poses = poses(5, N_POSES, 1.0)
    ours, stages, vols = run(world, "b", all_poses, pipe_a.mesh().to_manifold(),
                             pipe_b.mesh().to_manifold())
    assert set(stages) <= {"aabb", "obb", "kdop", "analytic"}
    band = 0.02 * 0.15

    def within_band(k):
        gap = world.bodies[0].chain.gap(world.bodies[1].chain, all_poses[k])[0]
        return abs(gap) < band

    hits, misses = agreement(ours, vols, within_band)
    assert hits > 200 and misses > 200
    caps_a = capsules(pipe_a, np.eye(4))
    for k in np.flatnonzero(~ours)[:150]:
        world.set_pose("b", all_poses[k])
        caps_b = capsules(pipe_b, all_poses[k])
        expected = min(fcl_distance(ga, pa, gb, pb) for ga, pa in caps_a for gb, pb in caps_b)
        assert world.distance("a", "b").distance == pytest.approx(expected, abs=1e-6)


def test_pipe_against_mesh_agrees_with_manifold_and_fcl():
    pipe, _ = pipe_pair()
    points, radius, band = pipe.path.points * 0.3, 0.06, 0.02 * 0.06
    ring = torus(1.0, 0.45)
    world, thinner = CollisionWorld(), CollisionWorld()
    for w, r in ((world, radius), (thinner, radius - band)):
        w.add("ring", ring)
        w.add("pipe", Pipe(points, r, caps="round"))
    all_poses = poses(6, N_POSES, 1.5)
    ours, stages, vols = run(world, "pipe", all_poses, ring.to_manifold(),
                             Pipe(points, radius, sides=24, caps="round").mesh().to_manifold())

    def within_band(k):            # the polygonal mesh lies within ``band`` of the round tube
        if ours[k]:
            thinner.set_pose("pipe", all_poses[k])
            return not thinner.check().collisions
        return world.distance("ring", "pipe").distance < band

    hits, misses = agreement(ours, vols, within_band)
    assert hits > 200 and misses > 200 and (stages == "containment").sum() > 20
    bvh, mesh = fcl_bvh(ring), ring.to_trimesh()
    units = world.body("pipe").chain
    s = np.linspace(0.0, 1.0, 201)
    for k in np.flatnonzero(~ours)[:150]:
        world.set_pose("pipe", all_poses[k])
        found = world.distance("ring", "pipe").distance
        # FCL's capsule distance (GJK) returns points on the shapes: an upper bound,
        # up to ~4e-5 above the true distance here
        fcl_found = min(fcl_distance(bvh, np.eye(4), g, p) for g, p in capsules(
            Pipe(points, radius), all_poses[k]))
        # the units' axes sampled against the mesh: an upper bound too, and no more than
        # half a sample step above the true distance (a distance is 1-Lipschitz)
        chain = units.moved(all_poses[k])
        axis = chain.ends - chain.starts
        samples = (chain.starts[:, None] + s[:, None] * axis[:, None]).reshape(-1, 3)
        sampled = trimesh.proximity.closest_point(mesh, samples)[1].min() - radius
        step = 0.5 * np.linalg.norm(axis, axis=1).max() / (len(s) - 1)
        assert found <= min(fcl_found, sampled) + 1e-12
        assert found >= sampled - step - 1e-12


def small_arm():
    """Three capsule-like links on revolute joints (a planar-ish arm)."""
    link = Mesh.from_trimesh(trimesh.creation.capsule(height=0.6, radius=0.08, count=[8, 8]))
    link = link.transformed(trimesh.transformations.translation_matrix([0, 0, 0.3]))
    up = np.eye(4)
    up[2, 3] = 0.6
    joints = [Joint("j1", "revolute", "base", "l1", np.eye(4), np.array([1.0, 0, 0]), -3, 3),
              Joint("j2", "revolute", "l1", "l2", up, np.array([1.0, 0, 0]), -3, 3),
              Joint("j3", "revolute", "l2", "l3", up, np.array([0.0, 1.0, 0]), -3, 3)]
    return Robot("arm", joints, {"l1": link, "l2": link, "l3": link}), link


def test_small_arm_agrees_with_manifold():
    robot, link = small_arm()
    world = CollisionWorld()
    world.add_robot(robot)
    obstacle = Mesh.from_trimesh(trimesh.creation.box(extents=(0.5, 0.5, 0.3)))
    place = np.eye(4)
    place[:3, 3] = (0.0, 0.45, 0.7)
    world.add("block", obstacle, transform=place)
    assert world.allowed == [("l1", "l2", "adjacent links"), ("l2", "l3", "adjacent links")]
    rng = np.random.default_rng(7)
    configs = rng.uniform(-3, 3, (N_POSES, 3))
    link_solid, block = link.to_manifold(), obstacle.to_manifold().transform(place[:3])
    ours, truth = [], []
    for q in configs:
        world.set_joints("arm", q)
        report = world.check()
        ours.append(sorted((a, b) for a, b, _ in report.collisions))
        p = robot.link_poses(q)
        hits = [(n, "block") for n in ("l1", "l2", "l3")
                if (link_solid.transform(p[n][:3]) ^ block).volume() > VOLUME_EPS]
        if (link_solid.transform(p["l1"][:3]) ^ link_solid.transform(p["l3"][:3])).volume() \
                > VOLUME_EPS:
            hits.append(("l1", "l3"))
        truth.append(sorted(hits))
    wrong = [k for k in range(N_POSES) if ours[k] != truth[k]]
    assert len(wrong) <= 0.002 * N_POSES, wrong[:5]
    assert sum(1 for t in truth if ("l1", "l3") in t) > 20
    assert sum(1 for t in truth if t) > 200 and sum(1 for t in truth if not t) > 200
