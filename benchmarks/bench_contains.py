"""Which points are inside a mesh: ``Mesh.contains`` against trimesh and the brute force.

Helix pipes (16 sides) of about 1k, 10k and 100k triangles; 1k, 100k and 1M points
uniform in the pipe's box grown by a tenth each way (inside, near and outside the
tube). In one process, interleaved (A B A B, medians of wall seconds):

- ``Mesh.contains`` (its tree built in the untimed first round, as a mesh keeps it);
- trimesh's ``Trimesh.contains`` (ray tests; embree's when ``embreex`` is installed,
  its intersector kept on the Trimesh object as well);
- the brute-force numpy solid-angle sum that ``winding_numbers`` was (``tests/oracle.py``),
  where the pairs of points and triangles number at most ``--brute-pairs``.

Then the first query on a new mesh (tree or intersector built, 1k points), and how
many points each peer answers differently from cadpipe.

With ``--before DIR`` (a checkout of the code to compare, e.g. ``git archive main``
unpacked there), the narrow phase's containment test per state: a tool mesh of 1 or
64 small spheres (a probe each) set at 95 poses inside a closed 12.7k-triangle helix
tube, ``CollisionWorld.check()`` at each (no triangles cross, so the probes decide),
in child processes, this tree and DIR alternating, each importing its own cadpipe.

Run: .venv/bin/python benchmarks/bench_contains.py [--repeat 5] [--brute-pairs 1e7]
[--before DIR]
"""

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path as FilePath

import numpy as np
import trimesh

from cadpipe import Mesh, Pipe

sys.path.insert(0, str(FilePath(__file__).parent.parent / "tests"))
from _common import interleaved  # noqa: E402
from oracle import winding_numbers as brute  # noqa: E402

SIDES = 16
TRIANGLES = (1_000, 10_000, 100_000)
POINTS = (1_000, 100_000, 1_000_000)


def helix_mesh(triangles):
    count = max(3, triangles // (2 * SIDES))
    t = np.linspace(0, 2 * np.pi * 3, count)
    return Pipe(np.c_[np.cos(t), np.sin(t), 0.15 * t], 0.1, sides=SIDES).mesh()


def box_points(mesh, count, rng):
    lo, hi = mesh.bounds
    return rng.uniform(lo - 0.1 * (hi - lo), hi + 0.1 * (hi - lo), (count, 3))


CHILD = """
import json, sys, time, numpy as np, trimesh
from cadpipe import CollisionWorld, Mesh, Pipe
t = np.linspace(0, 4 * np.pi, 200)
centre = np.c_[np.cos(t), np.sin(t), 0.2 * t]
world = CollisionWorld()
world.add("cell", Pipe(centre, 0.3, sides=32).mesh())
ball = Mesh.from_trimesh(trimesh.creation.icosphere(1, 0.01))
grid = 0.03 * np.array([[i % 4, i // 4 % 4, i // 16] for i in range(int(sys.argv[1]))]) - 0.045
world.add("tool", Mesh.concatenate([ball.transformed(np.r_[np.c_[np.eye(3), g], [[0, 0, 0, 1]]])
                                    for g in grid]))
poses = [np.eye(4) for _ in range(5, 195, 2)]
for pose, k in zip(poses, range(5, 195, 2)):
    pose[:3, 3] = centre[k]
def states():
    hits = 0
    for pose in poses:
        world.set_pose("tool", pose)
        hits += len(world.check().collisions)
    return hits
hits = states()
wall, cpu = time.perf_counter(), time.process_time()
assert states() == hits == len(poses)
print(json.dumps([time.perf_counter() - wall, time.process_time() - cpu]))
"""


def child(tree, pieces):
    # run in ``tree``: ``python -c`` puts the working directory first on sys.path
    env = {**os.environ, "PYTHONPATH": tree}
    out = subprocess.run([sys.executable, "-c", CHILD, str(pieces)], env=env, cwd=tree,
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def per_state(before, repeat):
    here = str(FilePath(__file__).parent.parent)
    for pieces in (1, 64):
        times = {"after": [], "before": []}
        for _ in range(repeat):
            times["after"].append(child(here, pieces))
            times["before"].append(child(before, pieces))
        (aw, ac), (bw, bc) = (np.median(times[k], axis=0) for k in ("after", "before"))
        print(f"95 states, a tool of {pieces} pieces inside: after {aw * 1e3:.1f} ms wall, "
              f"{ac * 1e3:.1f} ms CPU; before {bw * 1e3:.1f} ms wall, {bc * 1e3:.1f} ms CPU "
              f"(before / after {bw / aw:.2f}x wall, {bc / ac:.2f}x CPU)")


def queries(mesh, tm, points, with_brute):
    runs = {"cadpipe": lambda: mesh.contains(points), "trimesh": lambda: tm.contains(points)}
    if with_brute:
        runs["brute"] = lambda: brute(mesh.triangles, points) > 0.5
    return runs


def first_queries(mesh, points):
    return {"cadpipe": lambda: Mesh(mesh.vertices, mesh.faces).contains(points),
            "trimesh": lambda: trimesh.Trimesh(mesh.vertices, mesh.faces,
                                               process=False).contains(points)}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--brute-pairs", type=float, default=1e7)
    parser.add_argument("--before", help="a checkout of the code to compare against")
    args = parser.parse_args()
    print(f"medians of {args.repeat} interleaved runs; load average "
          + " ".join(f"{x:.2f}" for x in os.getloadavg())
          + f"; trimesh {trimesh.__version__}, embree {trimesh.ray.has_embree}")
    print(f"{'triangles':>9} {'points':>9} {'cadpipe s':>10} {'trimesh s':>10} "
          f"{'brute s':>10} {'tm/cp':>7} {'brute/cp':>8}  differ (trimesh, brute)")
    rng = np.random.default_rng(0)
    for triangles in TRIANGLES:
        mesh = helix_mesh(triangles)
        tm = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
        for count in POINTS:
            points = box_points(mesh, count, rng)
            runs = queries(mesh, tm, points, count * len(mesh.faces) <= args.brute_pairs)
            repeat = args.repeat if count * len(mesh.faces) <= 1e9 else max(1, args.repeat // 2)
            times, results = interleaved(runs, repeat)
            ours = results["cadpipe"]
            differ = [int((results[n] != ours).sum()) if n in results else "-"
                      for n in ("trimesh", "brute")]
            b = times.get("brute")
            print(f"{len(mesh.faces):9d} {count:9d} {times['cadpipe']:10.4f} "
                  f"{times['trimesh']:10.4f} {b if b is not None else float('nan'):10.3f} "
                  f"{times['trimesh'] / times['cadpipe']:7.1f} "
                  f"{(b or float('nan')) / times['cadpipe']:8.0f}  {differ[0]}, {differ[1]}")
    print("first query on a new mesh (tree or ray intersector built), 1k points:")
    for triangles in TRIANGLES:
        mesh = helix_mesh(triangles)
        points = box_points(mesh, 1000, rng)
        times, _ = interleaved(first_queries(mesh, points), args.repeat)
        print(f"{len(mesh.faces):9d} {1000:9d} {times['cadpipe']:10.4f} {times['trimesh']:10.4f}")
    if args.before:
        per_state(args.before, args.repeat)


if __name__ == "__main__":
    main()
