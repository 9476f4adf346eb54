"""``cadpipe build``'s union: one pipe skips booleans; a large group is united in batches;
the memory of the whole command writing a large pipe in every format.

    .venv/bin/python benchmarks/bench_build.py [--points 20000] [--sides 16] [--repeat 5]
    .venv/bin/python benchmarks/bench_build.py --pipes 1000 [--kind short|long] [--repeat 3]
    .venv/bin/python benchmarks/bench_build.py --memory --points 2000000 [--json]

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

With ``--memory``: in a fresh process, ``cadpipe build`` of one pipe along a CSV helix
(``--points`` points, 16 sides, radius 2 cm, 200 turns per 2M points) into every format
(STL, 3MF, OBJ, PLY, GLB, .usda, .usdc, .usdz, one after the other as the command writes
them), its resident memory sampled every 2 ms: per stage (the command's own progress
stages) the peak, above the memory before the command and above that plus the mesh's
own arrays (vertices and faces), as multiples of those arrays. The same spec at 2,000
points is built first in that process, so compiled kernels and usd-core are loaded and
their one-time memory is not counted.
"""

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path as FilePath

import numpy as np

import cadpipe
from cadpipe.geometry.mesh import reserve_ids
from cadpipe.geometry.swept import float32_solid
from cadpipe.solids.booleans import as_solid, combine, united

from _common import settled


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
    return float32_solid(solid, part_of_id={original: "pipe"})


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


#: the formats ``--memory`` writes, in the command's order
FORMATS = ("stl", "3mf", "obj", "ply", "glb", "usda", "usdc", "usdz")


def helix_spec(folder, points, pitch):
    """A spec of one 16-sided pipe (radius 2 cm) along a CSV helix of ``points`` points
    (radius 1 m, 200 turns per 2M points, ``pitch`` apart); its file."""
    folder.mkdir(parents=True, exist_ok=True)
    t = np.linspace(0.0, 2 * np.pi * 200 * points / 2e6, points)
    np.savetxt(folder / "helix.csv", np.c_[np.cos(t), np.sin(t), pitch * t / (2 * np.pi)],
               delimiter=",", fmt="%.9f")
    spec = folder / "helix.toml"
    spec.write_text('name = "helix"\n[[parts]]\nkind = "pipe"\nname = "helix"\n'
                    'radius = 0.02\nsides = 16\npath = "helix.csv"\n')
    return spec


def build_memory(points, pitch, formats):
    """In this process: build the helix into ``formats`` through ``cadpipe build`` (after a
    2,000-point warm-up); {"mesh": bytes, "before": bytes, "stages": [(wall-clock start,
    text)], "end": wall-clock end, "load": load average}. The parent samples this
    process's memory: a thread here could not, since usd-core holds the interpreter's lock
    while it writes."""
    import cadpipe.cli.build as command
    from cadpipe.cli import main

    stages = []
    shown = command._Stages.__call__

    def staged(self, text, done, total):
        stages.append((time.time(), text))
        return shown(self, text, done, total)

    command._Stages.__call__ = staged
    with tempfile.TemporaryDirectory(prefix="bench-build-", dir=".") as folder:
        def build(name, count):
            spec = helix_spec(FilePath(folder) / name, count, pitch)
            outputs = [a for f in formats for a in ("-o", str(spec.with_suffix("." + f)))]
            if main(["build", str(spec), "-q", "--max-triangles", str(40 * count), *outputs]):
                raise SystemExit(f"cadpipe build of {count:,} points failed after "
                                 f"{stages[-1][1] if stages else 'no stage'}")

        build("warm", 2000)
        stages.clear()
        before = settled()
        build("big", points)
        end = time.time()
    # float64 vertices (16 per ring, the caps' two centres), int64 faces (32 per ring - 4)
    mesh = (16 * points + 2) * 24 + (32 * points - 4) * 24
    return {"mesh": mesh, "before": before, "stages": stages, "end": end,
            "load": os.getloadavg()[0]}


def memory(points, pitch, formats, as_json):
    """``build_memory`` in a fresh process, its resident memory sampled from here every
    2 ms; per stage its peak (and seconds): a table, or JSON."""
    child = subprocess.Popen([sys.executable, __file__, "--memory-child", "--points",
                              str(points), "--pitch", str(pitch), "--formats", *formats],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    samples, page = [], resource.getpagesize()
    while child.poll() is None:
        try:
            with open(f"/proc/{child.pid}/statm") as fh:
                samples.append((time.time(), int(fh.read().split()[1]) * page))
        except (OSError, IndexError):
            pass
        time.sleep(0.002)
    out, err = child.communicate()
    if child.returncode:
        raise SystemExit(err)
    result = json.loads(out.splitlines()[-1])
    ends = [t for t, _ in result["stages"][1:]] + [result["end"]]
    result["stages"] = [(text, max([r for t, r in samples if start <= t < end] or [0]),
                         end - start)
                        for (start, text), end in zip(result["stages"], ends)
                        if text != "meshing done"]
    del result["end"]
    if as_json:
        print(json.dumps(result))
        return
    mesh, before = result["mesh"], result["before"]
    print(f"cadpipe build of a {points:,}-point helix x 16 sides into {', '.join(formats)}: "
          f"mesh arrays {mesh / 1e6:,.0f} MB, {before / 1e6:,.0f} MB before the command; "
          f"load average {result['load']:.1f}")
    print(f"{'stage':44s} {'peak MB':>8s} {'above before':>12s} {'above mesh':>10s} "
          f"{'s':>7s}")
    for text, peak, seconds in result["stages"]:
        print(f"{text[:44]:44s} {peak / 1e6:8,.0f} {(peak - before) / mesh:11.2f}x "
              f"{(peak - before - mesh) / mesh:9.2f}x {seconds:7.1f}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=20000)
    parser.add_argument("--sides", type=int, default=16)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--pipes", type=int, help="compare the batched union of this many")
    parser.add_argument("--kind", choices=("short", "long"), default="short",
                        help="short: bench_assembly's 4-point 12-sided pipes; long: spline "
                             "pipes across the cube, 24 sides")
    parser.add_argument("--memory", action="store_true",
                        help="peak memory per stage of cadpipe build into every format")
    parser.add_argument("--memory-child", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--pitch", type=float, default=0.126,
                        help="--memory's helix pitch (below 0.04 its turns overlap)")
    parser.add_argument("--formats", nargs="+", choices=FORMATS, default=FORMATS)
    parser.add_argument("--json", action="store_true", help="--memory's figures as JSON")
    args = parser.parse_args()
    if args.memory_child:
        return print(json.dumps(build_memory(args.points, args.pitch, args.formats)))
    if args.memory:
        return memory(args.points, args.pitch, args.formats, args.json)
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
