"""``cadpipe build``'s union: one pipe skips booleans; a large group is united in batches.

    .venv/bin/python benchmarks/bench_build.py [--points 20000] [--sides 16] [--repeat 5]
    .venv/bin/python benchmarks/bench_build.py --pipes 1000 [--kind short|long] [--repeat 3]

A single pipe overlaps nothing, so ``Assembly.union`` now returns its mesh as made
(placed, labelled). Before, every build took the full union path: the mesh into
manifold3d (``Manifold(Mesh64)``, its checks), a ``batch_boolean``, ``simplify`` at
float32 resolution and back into a labelled Mesh. Both run here on the same pipe,
interleaved A B A B ``--repeat`` times; medians and their ratio are printed.

With ``--pipes N``: the union of N crossing pipes (``--kind short``:
``bench_assembly``'s random pipes; ``long``: spline pipes across the cube; one
group either way) as ``cadpipe.solids.booleans.united`` computes it (about sqrt(N)
batches, then joined in pairs, so progress can be reported after each call)
against one manifold3d ``batch_boolean`` of all, interleaved; CPU seconds (manifold3d
runs threads) and wall seconds, medians, and the volumes, which must agree.
"""

import argparse
import os
import statistics
import time

import numpy as np

import cadpipe
from cadpipe.solids.booleans import as_solid, combine, exportable, reserve_ids, united


def helix(points):
    t = np.linspace(0.0, 20 * np.pi, points)
    return np.c_[np.cos(t), np.sin(t), 0.05 * t]


def skipped(pipe):
    """What ``cadpipe build`` does now for one part."""
    return cadpipe.Assembly().add("pipe", pipe).union()


def round_trip(pipe):
    """What it did before: validate in manifold3d, union, simplify, back to a Mesh."""
    (original,) = reserve_ids(1)
    solid = combine([as_solid(pipe.mesh(), "pipe", original)])
    return exportable(solid, part_of_id={original: "pipe"})


def long_pipes(count, seed=0):
    """``count`` spline pipes (24 sides, radius 2 cm) from side to side of a unit cube, each
    crossing many others: the scene of ``tests/test_build_interrupt.py``."""
    rng = np.random.default_rng(seed)
    meshes = []
    for _ in range(count):
        a, b = rng.uniform(0, 1, 3), rng.uniform(0, 1, 3)
        middle = (a + b) / 2 + rng.normal(0, 0.02, 3)
        path = cadpipe.Path.spline(np.round([a, middle, b], 4), step=0.01)
        meshes.append(cadpipe.Pipe(path, 0.02, sides=24).mesh())
    return meshes


def batched_union(count, kind, repeat):
    """The union of ``count`` crossing pipes: in batches (cadpipe) vs one call."""
    import manifold3d

    from bench_assembly import random_pipes

    meshes = random_pipes(count, 0) if kind == "short" else long_pipes(count)
    ids = iter(reserve_ids(count))
    solids = [as_solid(m, f"pipe{k}", next(ids)) for k, m in enumerate(meshes)]

    def one_call():
        whole = manifold3d.Manifold.batch_boolean(solids, manifold3d.OpType.Add)
        whole.num_tri()
        return whole

    def batches():
        whole = united(solids)
        whole.num_tri()
        return whole

    peers = {"cadpipe, batches": batches, "manifold3d, one call": one_call}
    cpu, wall, volume = ({name: [] for name in peers} for _ in range(3))
    for _ in range(repeat):
        for name, func in peers.items():
            start, clock = time.process_time(), time.perf_counter()
            volume[name] = func().volume()
            cpu[name].append(time.process_time() - start)
            wall[name].append(time.perf_counter() - clock)
    print(f"union of {count} crossing {kind} pipes; medians of {repeat} interleaved runs; "
          f"load average {os.getloadavg()[0]:.1f}")
    base = statistics.median(cpu["manifold3d, one call"])
    for name in peers:
        print(f"{name:<24}CPU {statistics.median(cpu[name]):8.2f} s "
              f"({statistics.median(cpu[name]) / base:4.2f}x)  wall "
              f"{statistics.median(wall[name]):8.2f} s  volume {volume[name]:.12g}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=20000)
    parser.add_argument("--sides", type=int, default=16)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--pipes", type=int, help="compare the batched union of this many")
    parser.add_argument("--kind", choices=("short", "long"), default="short",
                        help="short: bench_assembly's 4-point 12-sided pipes; long: spline "
                             "pipes across the cube, 24 sides")
    args = parser.parse_args()
    if args.pipes:
        return batched_union(args.pipes, args.kind, args.repeat)

    pipe = cadpipe.Pipe(helix(args.points), 0.02, sides=args.sides)
    triangles = len(pipe.mesh().faces)
    print(f"one pipe: {args.points} path points, {args.sides} sides, {triangles} triangles; "
          f"{args.repeat} interleaved runs")
    peers = {"union, booleans skipped": skipped, "full manifold3d round trip": round_trip}
    seconds = {name: [] for name in peers}
    sizes = {}
    for _ in range(args.repeat):
        for name, func in peers.items():
            start = time.perf_counter()
            sizes[name] = len(func(pipe).faces)
            seconds[name].append(time.perf_counter() - start)
    base = statistics.median(seconds["union, booleans skipped"])
    for name in peers:
        median = statistics.median(seconds[name])
        print(f"{name:<30}median {median:8.3f} s  {median / base:6.1f}x  "
              f"{sizes[name]} triangles out")


if __name__ == "__main__":
    main()
