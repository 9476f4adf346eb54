"""Splicing speed: a chain of 1,000 pipes (random sides 3..16, 200 points each), alone and
interleaved with other work in one process.

For both transition kinds: medians over --repeat runs of the splice alone (back to back,
each result dropped), interleaved with a trimesh sweep of a 100,000-point helix (A B A B in
one process), and interleaved with every result kept (no output memory can be reused); wall
and CPU seconds, output vertices per second. The pipe-building helpers are bench_pipes'.
Run: .venv/bin/python benchmarks/bench_splice.py [--repeat 7]
"""

import argparse
import os

import numpy as np

import cadpipe
from bench_pipes import RADIUS, helix, peers, run_case

PIPES, POINTS = 1000, 200


def chain(rng):
    """Pipes along a wide helix, each a 200-point arc, with gaps for the transitions."""
    pipes = []
    for i in range(PIPES):
        a = np.linspace(i, i + 0.7, POINTS) * 2 * np.pi / 40
        pts = np.c_[3 * np.cos(a), 3 * np.sin(a), 0.02 * i + 0.01 * np.sin(8 * a)]
        pipes.append(cadpipe.Pipe(pts, rng.uniform(0.02, 0.05), sides=int(rng.integers(3, 17))))
    return pipes


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7)
    args = parser.parse_args()
    pipes = chain(np.random.default_rng(0))
    other = peers(helix(100_000), RADIUS, vtk=False)[1]          # trimesh's sweep
    print(f"chain of {PIPES} pipes x {POINTS} points, sides 3..16; medians of {args.repeat} "
          "runs; load average " + " ".join(f"{x:.2f}" for x in os.getloadavg()))
    print(f"{'transition':10} {'mode':12} {'wall s':>8} {'cpu s':>8} {'wall / alone':>12} "
          f"{'vertices':>10} {'Mvert/s':>8} {'watertight':>10}")
    for mode_name in ("lcm", "merge"):
        def build(mode_name=mode_name):
            return cadpipe.splice(*pipes, transition=mode_name)

        mesh = build()
        alone = None
        for mode in ("alone", "interleaved", "kept"):
            methods = [("splice", build)] + ([] if mode == "alone" else [other])
            wall, cpu = run_case(methods, args.repeat, mode)["splice"]
            alone = alone or wall
            print(f"{mode_name:10} {mode:12} {wall:8.3f} {cpu:8.3f} {wall / alone:11.2f}x "
                  f"{len(mesh.vertices):10,} {len(mesh.vertices) / wall / 1e6:8.2f} "
                  f"{str(mesh.is_watertight):>10}")
    print("load average after: " + " ".join(f"{x:.2f}" for x in os.getloadavg()))


if __name__ == "__main__":
    main()
