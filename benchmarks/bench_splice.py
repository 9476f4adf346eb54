"""Splicing speed: a chain of 1,000 pipes (random sides 3..16, 200 points each).

Prints seconds and output vertices per second for both transition kinds.
Run: .venv/bin/python benchmarks/bench_splice.py
"""

import time

import numpy as np

import cadpipe

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
    pipes = chain(np.random.default_rng(0))
    print(f"chain of {PIPES} pipes x {POINTS} points, sides 3..16")
    print(f"{'transition':12} {'seconds':>8} {'vertices':>10} {'Mvert/s':>8} {'watertight':>10}")
    for mode in ("lcm", "merge"):
        start = time.perf_counter()
        mesh = cadpipe.splice(*pipes, transition=mode)
        sec = time.perf_counter() - start
        rate = len(mesh.vertices) / sec / 1e6
        print(f"{mode:12} {sec:8.3f} {len(mesh.vertices):10,} {rate:8.2f} "
              f"{str(mesh.is_watertight):>10}")


if __name__ == "__main__":
    main()
