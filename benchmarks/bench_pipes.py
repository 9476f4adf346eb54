"""Pipe building speed: cadpipe vs trimesh's sweep_polygon (and VTK's tube filter), alone and
interleaved in one process.

Each case is timed three ways, every figure a median over --repeat runs:

- alone: one method's runs back to back, each result dropped before the next (a script
  that builds one pipe after another);
- interleaved: A B A B ... in the same process, the peers' work between cadpipe's runs (a
  program that does other things too: their memory traffic is what cadpipe must live with);
- kept: interleaved, but every result is kept until the case ends, so no output memory can
  be reused (sizes up to --keep-up-to points).

Cases: helixes of 1k, 10k, 100k and 1M points (16 sides, radius 0.05) and a long thin
straight pipe (2 points, length 1000, radius 0.001). Prints wall and CPU seconds (CPU time
is steadier on a shared machine), each mode's ratio to the alone runs and trimesh / cadpipe.

``--no-recycling`` sets ``cadpipe.geometry.buffers.RETAIN_BYTES = 0``: every output array is
fresh numpy memory, as before the output blocks were recycled.

Run: .venv/bin/python benchmarks/bench_pipes.py [--repeat 7] [--sizes 1000 10000 ...] [--vtk]
[--no-recycling]
"""

import argparse
import os
import time

import numpy as np
import shapely
import trimesh

import cadpipe
from cadpipe.geometry import buffers

SIDES, RADIUS = 16, 0.05
LONG = ("long thin", np.array([[0.0, 0.0, 0.0], [1000.0, 0.0, 0.0]]), 0.001)


def helix(points):
    """A helix of 20 turns per 100k points (the pitch of the 100k case at every size)."""
    t = np.linspace(0, 40 * np.pi * points / 100_000, points)
    return np.c_[np.cos(t), np.sin(t), 0.5 * t / (2 * np.pi)]


def peers(path, radius, vtk):
    """(name, build) of each method for one path."""
    angles = np.arange(SIDES) * 2 * np.pi / SIDES
    polygon = shapely.Polygon(radius * np.c_[np.cos(angles), np.sin(angles)])
    out = [("cadpipe", lambda: cadpipe.Pipe(path, radius, sides=SIDES).mesh()),
           ("trimesh", lambda: trimesh.creation.sweep_polygon(polygon, path))]
    if vtk:
        import pyvista as pv

        line = pv.lines_from_points(path)
        out.append(("VTK tube", lambda: line.tube(radius=radius, n_sides=SIDES, capping=True)))
    return out


def timed(build):
    wall, cpu = time.perf_counter(), time.process_time()
    result = build()
    return time.perf_counter() - wall, time.process_time() - cpu, result


def run_case(methods, repeat, mode):
    """{name: (wall, cpu) medians} over ``repeat`` runs, in ``mode``."""
    times = {name: [] for name, _ in methods}
    kept = []
    rounds = [[m] * repeat for m in methods] if mode == "alone" else [methods] * repeat
    for batch in rounds:
        for name, build in batch:
            wall, cpu, result = timed(build)
            times[name].append((wall, cpu))
            if mode == "kept":
                kept.append(result)
            del result
    del kept
    return {name: np.median(t, axis=0) for name, t in times.items()}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--sizes", type=int, nargs="*", default=[1000, 10_000, 100_000, 1_000_000])
    parser.add_argument("--no-long", action="store_true", help="skip the long thin pipe")
    parser.add_argument("--keep-up-to", type=int, default=100_000)
    parser.add_argument("--vtk", action="store_true", help="add VTK's tube filter (PyVista)")
    parser.add_argument("--no-recycling", action="store_true",
                        help="fresh numpy memory for every output (as before recycling)")
    args = parser.parse_args()
    if args.no_recycling:
        buffers.RETAIN_BYTES = 0
    cases = [(f"helix {n:,}", helix(n), RADIUS) for n in args.sizes]
    if not args.no_long:
        cases.append(LONG)
    print(f"{SIDES} sides; medians of {args.repeat} runs; output recycling "
          f"{'off' if args.no_recycling else 'on'}; load average "
          + " ".join(f"{x:.2f}" for x in os.getloadavg()))
    print(f"{'case':16} {'mode':12} {'method':9} {'wall s':>8} {'cpu s':>8} "
          f"{'/ alone: wall':>13} {'cpu':>6} {'trimesh / cadpipe: wall':>23} {'cpu':>6}")
    for label, path, radius in cases:
        methods = peers(path, radius, args.vtk)
        for _, build in methods:                # warm up imports and caches
            build()
        modes = ["alone", "interleaved"] + (["kept"] if len(path) <= args.keep_up_to else [])
        alone = None
        for mode in modes:
            result = run_case(methods, args.repeat, mode)
            alone = alone or result
            for name, (wall, cpu) in result.items():
                versus = result["trimesh"] / result[name] if name == "cadpipe" else None
                print(f"{label:16} {mode:12} {name:9} {wall:8.4f} {cpu:8.4f} "
                      f"{wall / alone[name][0]:12.2f}x {cpu / alone[name][1]:5.2f}x"
                      + ("" if versus is None else f" {versus[0]:22.2f}x {versus[1]:5.2f}x"))
    print("load average after: " + " ".join(f"{x:.2f}" for x in os.getloadavg()))


if __name__ == "__main__":
    main()
