"""One pipe through ``Assembly.union``: booleans skipped vs the full manifold3d round trip.

    .venv/bin/python benchmarks/bench_build.py [--points 20000] [--sides 16] [--repeat 5]

A single pipe overlaps nothing, so ``Assembly.union`` now returns its mesh as made
(placed, labelled). Before, every build took the full union path: the mesh into
manifold3d (``Manifold(Mesh64)``, its checks), a ``batch_boolean``, ``simplify`` at
float32 resolution and back into a labelled Mesh. Both run here on the same pipe,
interleaved A B A B ``--repeat`` times; medians and their ratio are printed.
"""

import argparse
import statistics
import time

import numpy as np

import cadpipe
from cadpipe.solids.booleans import as_solid, combine, exportable, reserve_ids


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


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=20000)
    parser.add_argument("--sides", type=int, default=16)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()

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
