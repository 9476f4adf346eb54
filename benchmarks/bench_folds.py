"""The self-intersection search and the swept solid: what they cost (issues 10 and 15).

In one process, interleaved (A B A B, medians of wall and CPU seconds):

- ``Pipe.folds()`` alone (the search) and ``Pipe.mesh()`` on a 2-point pipe of length 1000
  and radius 0.001, a 1k and a 100k point helix (16 sides, radius 0.05), and a helix
  whose turns overlap (r_min 5e-4 .. r_max 0.05 on a 10k point helix, issue 10's
  variable-radius case);
- cadpipe against trimesh's ``sweep_polygon`` at 1k points;
- the cost of a swept pipe against a clean one: the 1k point helix with and without
  a last leg that crosses it (the union then merges that stretch only);
- a yes/no against the full answer: a 3k point coil whose turns overlap everywhere,
  ``Pipe(strict=True).mesh()`` (refused at the first meeting units) against
  ``Pipe.folds()`` (every finding).

With ``--before DIR`` (a checkout of the code to compare, e.g. ``git archive main``
unpacked there) the helix 100k mesh is also timed in child processes, this tree and
DIR alternating, each child importing its own cadpipe.

Run: .venv/bin/python benchmarks/bench_folds.py [--repeat 7] [--before DIR]
"""

import argparse
import json
import os
import subprocess
import sys
import time
import warnings

import numpy as np
import shapely
import trimesh

import cadpipe

SIDES, RADIUS = 16, 0.05


def helix(points, turns_per_100k=20):
    t = np.linspace(0, 2 * np.pi * turns_per_100k * points / 100_000, points)
    return np.c_[np.cos(t), np.sin(t), 0.5 * t / (2 * np.pi)]


def timed(build):
    wall, cpu = time.perf_counter(), time.process_time()
    build()
    return time.perf_counter() - wall, time.process_time() - cpu


def interleaved(runs, repeat):
    for build in runs.values():
        build()
    times = {name: [] for name in runs}
    for _ in range(repeat):
        for name, build in runs.items():
            times[name].append(timed(build))
    return {name: np.median(t, axis=0) for name, t in times.items()}


CHILD = """
import json, sys, time, numpy as np, cadpipe
t = np.linspace(0, 2 * np.pi * 20, 100_000)
path = np.c_[np.cos(t), np.sin(t), 0.5 * t / (2 * np.pi)]
cadpipe.Pipe(path[:1000], 0.05, sides=16).mesh()
wall, cpu = time.perf_counter(), time.process_time()
cadpipe.Pipe(path, 0.05, sides=16).mesh()
print(json.dumps([time.perf_counter() - wall, time.process_time() - cpu]))
"""


def child(tree):
    # run in ``tree``: ``python -c`` puts the working directory first on sys.path
    env = {**os.environ, "PYTHONPATH": tree}
    out = subprocess.run([sys.executable, "-c", CHILD], env=env, cwd=tree,
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def row(label, wall, cpu, extra=""):
    print(f"{label:44} {wall * 1e3:11.3f} {cpu * 1e3:11.3f}  {extra}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--before", help="a checkout of the code to compare against")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    print(f"medians of {args.repeat} interleaved runs; load average "
          + " ".join(f"{x:.2f}" for x in os.getloadavg()))
    print(f"{'case':44} {'wall ms':>11} {'cpu ms':>11}")

    long_thin = cadpipe.Pipe([[0, 0, 0], [1000.0, 0, 0]], 0.001, sides=SIDES)
    h1k, h100k = helix(1000), helix(100_000)
    t = np.linspace(0, 2 * np.pi * 2, 10_000)
    tight = np.c_[np.cos(t), np.sin(t), 0.08 * t / (2 * np.pi)]       # turns 0.08 apart
    variable = np.linspace(5e-4, 0.05, len(tight))
    cases = {
        "2-point, length 1000, r 0.001: folds()":
            lambda: long_thin.replace()._tubes.folds(),
        "2-point, length 1000, r 0.001: mesh()":
            lambda: cadpipe.Pipe([[0, 0, 0], [1000.0, 0, 0]], 0.001, sides=SIDES).mesh(),
        "helix 1k: folds()": lambda: cadpipe.Pipe(h1k, RADIUS, sides=SIDES).folds(),
        "helix 100k: folds()": lambda: cadpipe.Pipe(h100k, RADIUS, sides=SIDES).folds(),
        "helix 100k: mesh()": lambda: cadpipe.Pipe(h100k, RADIUS, sides=SIDES).mesh(),
        "helix 10k, r 5e-4..0.05, turns 0.08 apart: folds()":
            lambda: cadpipe.Pipe(tight, variable, sides=SIDES).folds(),
    }
    for label, (wall, cpu) in interleaved(cases, args.repeat).items():
        row(label, wall, cpu)

    angles = np.arange(SIDES) * 2 * np.pi / SIDES
    polygon = shapely.Polygon(RADIUS * np.c_[np.cos(angles), np.sin(angles)])
    peers = interleaved({
        "cadpipe": lambda: cadpipe.Pipe(h1k, RADIUS, sides=SIDES).mesh(),
        "trimesh": lambda: trimesh.creation.sweep_polygon(polygon, h1k)}, args.repeat)
    for name, (wall, cpu) in peers.items():
        row(f"helix 1k mesh: {name}", wall, cpu,
            "" if name == "trimesh" else
            f"trimesh / cadpipe {peers['trimesh'][0] / wall:.2f}x wall, "
            f"{peers['trimesh'][1] / cpu:.2f}x cpu")

    # a last leg from outside the helix straight through its first turn
    crossing = np.vstack([h1k, h1k[-1] + [0.6, 0, 0], [1.6, 0.0, 0.02], [0.0, 0.0, 0.02]])
    clean = h1k
    swept = cadpipe.Pipe(crossing, RADIUS, sides=SIDES)
    merged = swept.mesh().attributes["merged"]
    assert "merged" not in cadpipe.Pipe(clean, RADIUS, sides=SIDES).mesh().attributes
    costs = interleaved({
        "clean": lambda: cadpipe.Pipe(clean, RADIUS, sides=SIDES).mesh(),
        "swept": lambda: cadpipe.Pipe(crossing, RADIUS, sides=SIDES).mesh()}, args.repeat)
    for name, (wall, cpu) in costs.items():
        row(f"helix 1k, {name} (swept: a last leg crosses it): mesh()", wall, cpu,
            "" if name == "clean" else
            f"{wall / costs['clean'][0]:.1f}x clean wall, {cpu / costs['clean'][1]:.1f}x cpu; "
            f"merged {merged}")

    t = np.linspace(0, 2 * np.pi * 3, 3_000)
    coil = np.c_[np.cos(t), np.sin(t), 0.05 * t / (2 * np.pi)]          # turns 0.05 apart

    def refused():
        try:
            cadpipe.Pipe(coil, RADIUS, sides=SIDES, strict=True).mesh()
        except cadpipe.GeometryError:
            return
        raise AssertionError("the coil overlaps itself")

    answers = interleaved({
        "full answer: folds()": lambda: cadpipe.Pipe(coil, RADIUS, sides=SIDES).folds(),
        "yes/no: strict mesh() refused": refused}, args.repeat)
    full = answers["full answer: folds()"]
    for name, (wall, cpu) in answers.items():
        row(f"coil 3k, overlapping, {name}", wall, cpu,
            "" if name.startswith("full") else
            f"{full[0] / wall:.1f}x faster wall, {full[1] / cpu:.1f}x cpu")

    if args.before:
        here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
        runs = {"after (this tree)": [], "before": []}
        for _ in range(args.repeat):
            runs["after (this tree)"].append(child(here))
            runs["before"].append(child(args.before))
        for name, values in runs.items():
            wall, cpu = np.median(values, axis=0)
            row(f"helix 100k mesh(), {name}", wall, cpu, "child processes, alternating")
    print("load average after: " + " ".join(f"{x:.2f}" for x in os.getloadavg()))


if __name__ == "__main__":
    main()
