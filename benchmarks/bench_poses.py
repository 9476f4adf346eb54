"""One pipe pose at a time: cadpipe's per-pose calls against FCL on the meshed pipes.

Two spline safety pipes (radii 0.15 and 0.12, round caps; as meshes 32 sides) and the
second pipe against a 1,536-triangle torus, at ``--poses`` random relative poses. Per
pose, as a planner or fixture asks:

* collide: ``set_pose`` + ``check(first_hit=True)``, and ``collide_at(a, b, pose_a,
  pose_b)`` (no scene change), against ``fcl.collide`` on the meshes;
* distance: ``set_pose`` + ``distance()``, and ``distance_at``, against
  ``fcl.distance`` on the meshes (on a tenth of the poses);

and batched, ``check_many`` over all poses. Distances are compared with FCL's on the
meshes (they differ by the round tube against its 32-gon mesh, up to
``r (1 - cos(pi / 32))``) and per pose against batched.

Every figure is the median of ``--repeat`` rounds, all methods interleaved in one
process (A B A B ...) after one untimed round; the machine is shared, so read the
ratios (``uptime`` is printed).

Run: .venv/bin/python benchmarks/bench_poses.py [--poses N] [--repeat R]
"""

import argparse
import os

import fcl
import numpy as np
from scipy.spatial.transform import Rotation

from _common import fcl_object, interleaved, pipe_scene
from cadpipe import CollisionWorld


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=10_000)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    a, b, torus = pipe_scene()
    worlds = {"pipe-pipe": CollisionWorld().add("a", a).add("b", b),
              "pipe-mesh": CollisionWorld().add("a", torus).add("b", b)}
    fixed = {"pipe-pipe": fcl_object(a.mesh()), "pipe-mesh": fcl_object(torus)}
    mover = fcl_object(b.mesh())
    rng = np.random.default_rng(1)
    moves = np.tile(np.eye(4), (args.poses, 1, 1))
    moves[:, :3, :3] = Rotation.random(args.poses, random_state=rng).as_matrix()
    moves[:, :3, 3] = rng.uniform(-0.8, 0.8, (args.poses, 3))
    few = moves[:max(1, args.poses // 10)]
    eye = np.eye(4)
    request, distance_request = fcl.CollisionRequest(), fcl.DistanceRequest()

    def fcl_loop(anchor, query, poses):
        def run():
            out = np.empty(len(poses))
            for k, m in enumerate(poses):
                mover.setTransform(fcl.Transform(m[:3, :3], m[:3, 3]))
                out[k] = query(anchor, mover)
            return out
        return run

    def per_pose(query, poses):
        def run():
            out = np.empty(len(poses))
            for k, m in enumerate(poses):
                out[k] = query(m)
            return out
        return run

    def hit(x, y):
        return fcl.collide(x, y, request, fcl.CollisionResult()) > 0

    def apart(x, y):
        return fcl.distance(x, y, distance_request, fcl.DistanceResult())

    runs = {}
    for kind, world in worlds.items():
        def moved_check(m, world=world):
            world.set_pose("b", m)
            return bool(world.check(first_hit=True))

        def moved_distance(m, world=world):
            world.set_pose("b", m)
            return world.distance("a", "b").distance

        runs.update({
            f"{kind} collide: FCL meshes": fcl_loop(fixed[kind], hit, moves),
            f"{kind} collide: set_pose + check(first_hit=True)": per_pose(moved_check, moves),
            f"{kind} collide: collide_at": per_pose(
                lambda m, world=world: world.collide_at("a", "b", eye, m), moves),
            f"{kind} collide: check_many (batched)":
                lambda world=world: world.check_many({"b": moves}).colliding,
            f"{kind} distance: FCL meshes": fcl_loop(fixed[kind], apart, few),
            f"{kind} distance: set_pose + distance()": per_pose(moved_distance, few),
            f"{kind} distance: distance_at": per_pose(
                lambda m, world=world: world.distance_at("a", "b", eye, m), few),
        })
    print(f"pipes of {len(worlds['pipe-pipe'].body('a').chain.starts)} and "
          f"{len(worlds['pipe-pipe'].body('b').chain.starts)} units (meshes of "
          f"{len(a.mesh().faces)} and {len(b.mesh().faces)} triangles), a "
          f"{len(torus.faces)}-triangle torus; {args.poses} poses, distance on {len(few)}; "
          f"medians of {args.repeat} interleaved rounds; load average "
          f"{os.getloadavg()[0]:.1f} before")
    seconds, out = interleaved(runs, args.repeat)
    for label, s in seconds.items():
        query = label.split(":")[0]
        n = len(few) if "distance" in query else len(moves)
        print(f"  {label:52s} {n / s:10.0f}/s   ratio to FCL "
              f"{seconds[f'{query}: FCL meshes'] / s:6.2f}x")
    for kind in worlds:
        base = out[f"{kind} collide: collide_at"]
        same = int((out[f"{kind} collide: check_many (batched)"] == base).sum())
        world = int((out[f"{kind} collide: set_pose + check(first_hit=True)"] == base).sum())
        mesh = int((out[f"{kind} collide: FCL meshes"] == base).sum())
        d = out[f"{kind} distance: distance_at"]
        print(f"  {kind}: collide_at == check() {world}/{len(moves)}, == check_many "
              f"{same}/{len(moves)}, == FCL on the meshes {mesh}/{len(moves)}; distance_at == "
              f"distance() {int((d == out[f'{kind} distance: set_pose + distance()']).sum())}"
              f"/{len(few)}, largest difference to FCL's on the meshes "
              f"{np.abs(d - out[f'{kind} distance: FCL meshes']).max():.2e}")
    print(f"  load average after: {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
