"""Collision checks: cadpipe's CollisionWorld vs trimesh's CollisionManager (FCL).

Part 1, a robot cell: a 7-link arm of capsule-like links, a 20k-triangle
workpiece and 3 safety pipes, posed at 10,000 random joint configurations.
Per configuration: re-pose the links and find every colliding pair. trimesh
gets the pipes as meshes and has no allowed-collision matrix (it reports the
touching neighbours too, which are dropped before comparing answers); cadpipe
also finds links wholly inside the workpiece, which FCL cannot see.

Part 2, pipe vs pipe: two safety pipes at 10,000 random relative poses,
cadpipe's analytic chains vs the same pipes' meshes in FCL (collide and
distance).

Run: .venv/bin/python benchmarks/bench_collision.py [--configs N]
"""

import argparse
import time

import fcl
import numpy as np
import trimesh
from scipy.spatial.transform import Rotation

from cadpipe import CollisionWorld, Mesh, Path, Pipe
from cadpipe.collision import Joint, Robot
from cadpipe.collision.bodies import as_body


def arm():
    """Seven capsule links (0.3 m, radius 4 cm) on alternating revolute joints."""
    link = Mesh.from_trimesh(trimesh.creation.capsule(height=0.3, radius=0.04, count=[12, 12]))
    link = link.transformed(trimesh.transformations.translation_matrix([0, 0, 0.15]))
    up = np.eye(4)
    up[2, 3] = 0.3
    joints, parent = [], "base"
    for k in range(7):
        axis = np.array([0.0, 0.0, 1.0]) if k % 2 == 0 else np.array([0.0, 1.0, 0.0])
        joints.append(Joint(f"j{k}", "revolute", parent, f"link{k}", up if k else np.eye(4),
                            axis, -2.6, 2.6))
        parent = f"link{k}"
    return Robot("arm", joints, {f"link{k}": link for k in range(7)})


def cell():
    """The workpiece (a 20,000-triangle torus) and three safety pipes around it."""
    work = Mesh.from_trimesh(trimesh.creation.torus(0.35, 0.12, major_sections=100,
                                                    minor_sections=100))
    place = np.eye(4)
    place[:3, 3] = (0.6, 0.0, 0.5)
    pipes = [Pipe(Path.spline(points, step=0.02), 0.03, sides=24, caps="round") for points in (
        [[0.2, -0.6, 0.2], [0.5, -0.4, 0.9], [0.9, -0.2, 1.0], [1.1, 0.3, 0.6]],
        [[-0.5, 0.5, 0.1], [0.0, 0.6, 0.6], [0.5, 0.7, 1.1], [0.9, 0.5, 1.3]],
        [[0.3, 0.4, 0.0], [0.7, 0.3, 0.2], [1.0, -0.1, 0.3], [1.0, -0.6, 0.5]])]
    return work, place, pipes


def robot_cell(configs):
    robot = arm()
    work, place, pipes = cell()
    world = CollisionWorld()
    world.add_robot(robot)
    world.add("workpiece", work, transform=place)
    for k, p in enumerate(pipes):
        world.add(f"pipe{k}", p)
    manager = trimesh.collision.CollisionManager()
    for link, pose in robot.link_poses(None).items():
        manager.add_object(link, robot.link_meshes[link].to_trimesh(), transform=pose)
    manager.add_object("workpiece", work.to_trimesh(), transform=place)
    for k, p in enumerate(pipes):
        manager.add_object(f"pipe{k}", p.mesh().to_trimesh())
    allowed = {frozenset((a, b)) for a, b, _ in world.allowed()}
    rng = np.random.default_rng(0)
    qs = rng.uniform(-2.6, 2.6, (configs, 7))

    world.check()                      # build BVHs and bounds before timing, as trimesh did
    ours, start = [], time.perf_counter()
    for q in qs:
        world.set_joints("arm", q)
        ours.append({frozenset((a, b)): d.decided_by for a, b, d in world.check().collisions})
    t_ours = time.perf_counter() - start

    theirs, start = [], time.perf_counter()
    for q in qs:
        for link, pose in robot.link_poses(q).items():
            manager.set_transform(link, pose)
        _, names = manager.in_collision_internal(return_names=True)
        theirs.append({frozenset(n) for n in names} - allowed)
    t_theirs = time.perf_counter() - start

    contained = sum(1 for o in ours for v in o.values() if v == "containment")
    same = sum(1 for o, t in zip(ours, theirs)
               if {k for k, v in o.items() if v != "containment"} == t)
    print(f"robot cell: 7 links, {len(work.faces)}-triangle workpiece, 3 safety pipes, "
          f"{configs} configurations")
    print(f"  cadpipe CollisionWorld.check   {configs / t_ours:9.0f} configs/s")
    print(f"  trimesh CollisionManager (FCL) {configs / t_theirs:9.0f} configs/s")
    print(f"  ratio cadpipe / trimesh         {t_theirs / t_ours:9.2f}x")
    print(f"  same colliding pairs (containment aside): {same}/{configs}; containments only "
          f"cadpipe saw: {contained}")


def pipe_pair(poses):
    a = Pipe(Path.spline([[-1.0, -0.6, 0.0], [0.0, 0.4, 0.1], [1.0, -0.5, 0.0]], step=0.05),
             0.15, sides=32, caps="round")
    b = Pipe(Path.spline([[-0.8, 0.0, -0.3], [0.0, 0.3, 0.0], [0.9, 0.1, 0.2]], step=0.05),
             0.12, sides=32, caps="round")
    chain_a, chain_b = as_body(a, "a").chain, as_body(b, "b").chain
    objects = []
    for p in (a, b):
        m = p.mesh()
        bvh = fcl.BVHModel()
        bvh.beginModel(len(m.vertices), len(m.faces))
        bvh.addSubModel(np.array(m.vertices), np.array(m.faces))
        bvh.endModel()
        objects.append(fcl.CollisionObject(bvh, fcl.Transform()))
    rng = np.random.default_rng(1)
    moves = np.tile(np.eye(4), (poses, 1, 1))
    moves[:, :3, :3] = Rotation.random(poses, random_state=rng).as_matrix()
    moves[:, :3, 3] = rng.uniform(-0.8, 0.8, (poses, 3))
    print(f"pipe vs pipe: {len(a.path) - 1} and {len(b.path) - 1} units; meshes of "
          f"{len(a.mesh().faces)} and {len(b.mesh().faces)} triangles; {poses} poses")
    request = fcl.CollisionRequest()
    for label, ours, theirs in (
            ("collide", lambda m: chain_a.gap(chain_b.moved(m), stop_below=0.0)[0] <= 0,
             lambda: fcl.collide(*objects, request, fcl.CollisionResult()) > 0),
            ("distance", lambda m: chain_a.gap(chain_b.moved(m))[0],
             lambda: fcl.distance(*objects, fcl.DistanceRequest(), fcl.DistanceResult()))):
        count = poses if label == "collide" else poses // 10
        start = time.perf_counter()
        for m in moves[:count]:
            ours(m)
        t_ours = time.perf_counter() - start
        start = time.perf_counter()
        for m in moves[:count]:
            objects[1].setTransform(fcl.Transform(m[:3, :3], m[:3, 3]))
            theirs()
        t_theirs = time.perf_counter() - start
        print(f"  {label:8s} cadpipe {count / t_ours:9.0f}/s  FCL meshes {count / t_theirs:9.0f}/s"
              f"  ratio {t_theirs / t_ours:6.2f}x  ({count} poses)")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--configs", type=int, default=10_000)
    args = parser.parse_args()
    robot_cell(args.configs)
    pipe_pair(args.configs)


if __name__ == "__main__":
    main()
