"""Collision checks: cadpipe's CollisionWorld vs trimesh's CollisionManager (FCL).

Part 1, a robot cell: a 7-link arm of capsule-like links, a 20k-triangle
workpiece and 3 safety pipes, posed at 10,000 random joint configurations;
each configuration: re-pose the links and find every colliding pair.

* per call: ``set_joints`` + ``check()`` per configuration, against trimesh's
  manager per configuration (``link_poses`` + ``set_transform`` +
  ``in_collision_internal``): the same forward kinematics on both sides;
* batched: one ``check_path`` call for all configurations, against the same
  trimesh loop fed by one batched forward-kinematics call (its best case).

trimesh gets the pipes as meshes and has no allowed-collision matrix (it reports
the touching neighbours too, which are dropped before comparing answers);
cadpipe also finds links wholly inside the workpiece, which FCL cannot see.

Part 2, pipe vs pipe: two safety pipes at 10,000 random relative poses:
cadpipe's analytic chains (per pose, batched over all poses, and batched through
the whole ``check_many`` funnel) against the same pipes' meshes in FCL.

Every figure is the best of ``--repeat`` runs after a warm-up run (the machine is
shared).

Run: .venv/bin/python benchmarks/bench_collision.py [--configs N] [--repeat R]
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


def best_of(repeat, run):
    """``(seconds, result)`` of the fastest of ``repeat`` runs of ``run()``, after one
    untimed run (caches, lazily built trees, the allocator's first growth)."""
    run()
    best = None
    for _ in range(repeat):
        start = time.perf_counter()
        result = run()
        seconds = time.perf_counter() - start
        if best is None or seconds < best[0]:
            best = (seconds, result)
    return best


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


def pairs_of(report):
    return {frozenset((a, b)): d.decided_by for a, b, d in report.collisions}


def robot_cell(configs, repeat):
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
    allowed = {frozenset((a, b)) for a, b, _ in world.allowed}
    qs = np.random.default_rng(0).uniform(-2.6, 2.6, (configs, 7))
    links = list(robot.link_meshes)
    world.check()                      # build BVHs and bounds before timing, as trimesh did

    def ours_per_call():
        out = []
        for q in qs:
            world.set_joints("arm", q)
            out.append(pairs_of(world.check()))
        return out

    def theirs(poses_of):
        out = []
        for poses in poses_of():
            for link, pose in zip(links, poses):
                manager.set_transform(link, pose)
            _, names = manager.in_collision_internal(return_names=True)
            out.append({frozenset(n) for n in names} - allowed)
        return out

    t_call, per_call = best_of(repeat, ours_per_call)
    t_batch, batch = best_of(repeat, lambda: world.check_path("arm", qs))
    t_theirs_call, answers = best_of(repeat, lambda: theirs(
        lambda: (robot.link_pose_array(q)[0] for q in qs)))
    t_theirs_batch, _ = best_of(repeat, lambda: theirs(lambda: robot.link_pose_array(qs)))

    same_batch = sum(pairs_of(batch[c]) == per_call[c] for c in range(configs))
    contained = sum(1 for o in per_call for v in o.values() if v == "containment")
    same = sum(1 for o, t in zip(per_call, answers)
               if {k for k, v in o.items() if v != "containment"} == t)
    print(f"robot cell: 7 links, {len(work.faces)}-triangle workpiece, 3 safety pipes, "
          f"{configs} configurations (best of {repeat})")
    print(f"  per call  cadpipe set_joints + check       {configs / t_call:9.0f} configs/s")
    print(f"            trimesh set_transform + manager  {configs / t_theirs_call:9.0f} configs/s"
          f"   ratio {t_theirs_call / t_call:5.2f}x")
    print(f"  batched   cadpipe check_path               {configs / t_batch:9.0f} configs/s")
    print(f"            trimesh, batched kinematics      {configs / t_theirs_batch:9.0f} configs/s"
          f"   ratio {t_theirs_batch / t_batch:5.2f}x")
    print(f"  check_path == check() loop: {same_batch}/{configs} configurations; same colliding "
          f"pairs as trimesh (containment aside): {same}/{configs}; containments only cadpipe "
          f"saw: {contained}")


def pipe_pair(poses, repeat):
    a = Pipe(Path.spline([[-1.0, -0.6, 0.0], [0.0, 0.4, 0.1], [1.0, -0.5, 0.0]], step=0.05),
             0.15, sides=32, caps="round")
    b = Pipe(Path.spline([[-0.8, 0.0, -0.3], [0.0, 0.3, 0.0], [0.9, 0.1, 0.2]], step=0.05),
             0.12, sides=32, caps="round")
    chain_a, chain_b = as_body(a, "a").chain, as_body(b, "b").chain
    world = CollisionWorld()
    world.add("a", a)
    world.add("b", b)
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
          f"{len(a.mesh().faces)} and {len(b.mesh().faces)} triangles; {poses} poses "
          f"(best of {repeat})")

    def fcl_loop(query, count):
        out = []
        for m in moves[:count]:
            objects[1].setTransform(fcl.Transform(m[:3, :3], m[:3, 3]))
            out.append(query())
        return np.array(out)

    request = fcl.CollisionRequest()
    t_fcl, fcl_hits = best_of(repeat, lambda: fcl_loop(
        lambda: fcl.collide(*objects, request, fcl.CollisionResult()) > 0, poses))
    t_call, call_hits = best_of(repeat, lambda: np.array(
        [chain_a.gap(chain_b, m, stop_below=0.0)[0] <= 0 for m in moves]))
    t_batch, batch_hits = best_of(repeat, lambda: chain_a.gaps(chain_b, moves,
                                                                stop_below=0.0)[0] <= 0)
    t_world, report = best_of(repeat, lambda: world.check_many({"b": moves}))
    print(f"  collide   FCL meshes                {poses / t_fcl:10.0f}/s")
    for label, seconds in (("cadpipe per pose", t_call), ("cadpipe batched", t_batch),
                           ("cadpipe check_many", t_world)):
        print(f"            {label:25s} {poses / seconds:10.0f}/s   ratio {t_fcl / seconds:6.2f}x")
    print(f"  batched == per pose: {int((batch_hits == call_hits).sum())}/{poses}; "
          f"check_many == per pose: {int((report.colliding == call_hits).sum())}/{poses}; "
          f"agree with FCL on the meshes: {int((batch_hits == fcl_hits).sum())}/{poses}")
    count = poses // 10
    distance = fcl.DistanceRequest()
    t_fcl, _ = best_of(repeat, lambda: fcl_loop(
        lambda: fcl.distance(*objects, distance, fcl.DistanceResult()), count))
    t_call, _ = best_of(repeat, lambda: [chain_a.gap(chain_b, m) for m in moves[:count]])
    t_batch, _ = best_of(repeat, lambda: chain_a.gaps(chain_b, moves[:count]))
    print(f"  distance  FCL meshes                {count / t_fcl:10.0f}/s   ({count} poses)")
    for label, seconds in (("cadpipe per pose", t_call), ("cadpipe batched", t_batch)):
        print(f"            {label:25s} {count / seconds:10.0f}/s   ratio {t_fcl / seconds:6.2f}x")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--configs", type=int, default=10_000)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    robot_cell(args.configs, args.repeat)
    pipe_pair(args.configs, args.repeat)


if __name__ == "__main__":
    main()
