"""Reading, checking and writing at size: cadpipe beside its peers, and peak memory.

Three comparisons in one process, interleaved A B A B (medians of ``--runs``):

- ``cadpipe check`` (:func:`cadpipe.check_mesh`: topology, orientation, volume,
  self-intersections, nested shells) against pymeshlab's topological measures plus
  its self-intersecting-face selection, on the same mesh;
- ``Mesh.load`` against ``trimesh.load`` (with trimesh's vertex merge, which is what
  gives a solid) on the same binary STL;
- every writer with normals against the same writer without them (GLB, .usdc).

Then, in a fresh process per format, the peak resident memory of writing a large
pipe (``--points`` points, 16 sides) minus the memory before the write, against the
size of the mesh's own arrays.

Run: .venv/bin/python benchmarks/bench_io.py [--runs 5] [--speed-points 20000] [--points 200000]
     .venv/bin/python benchmarks/bench_io.py --memory-only --points 2000000
"""

import argparse
import resource
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path as FilePath

import numpy as np

import cadpipe
from cadpipe.io.files import export, load_mesh
from cadpipe.solids.validity import check_mesh

FORMATS = ("stl", "3mf", "obj", "ply", "glb", "usda", "usdc", "usdz")


def wavy_pipe(points, sides):
    s = np.linspace(0, 10, points)
    path = np.c_[s, 0.2 * np.sin(s), 0.1 * np.cos(0.7 * s)]
    return cadpipe.Pipe(cadpipe.Path(path), 0.02, sides=sides).mesh()


def interleaved(runs, **contenders):
    """{name: median seconds}: each contender once per round, rounds in turn (A B A B)."""
    times = {name: [] for name in contenders}
    for _ in range(runs):
        for name, call in contenders.items():
            start = time.perf_counter()
            call()
            times[name].append(time.perf_counter() - start)
    return {name: float(np.median(t)) for name, t in times.items()}


def pymeshlab_check(path):
    import pymeshlab

    ms = pymeshlab.MeshSet()
    ms.load_new_mesh(str(path))
    ms.get_topological_measures()
    ms.compute_selection_by_self_intersections_per_face()
    return ms.current_mesh().selected_face_number()


def trimesh_load(path):
    import trimesh

    mesh = trimesh.load(path, process=False)
    mesh.merge_vertices()
    return mesh


def speed(runs, points):
    mesh = wavy_pipe(points, 25)
    print(f"mesh: {len(mesh.faces):,} triangles, {len(mesh.vertices):,} vertices; "
          f"medians of {runs} interleaved runs")
    with tempfile.TemporaryDirectory(prefix="bench-io-", dir=".") as folder:
        stl = export(mesh, FilePath(folder) / "pipe.stl", units="m")
        fresh = load_mesh(stl)
        rows = []
        t = interleaved(runs, cadpipe=lambda: check_mesh(load_mesh(stl)),
                        pymeshlab=lambda: pymeshlab_check(stl))
        rows.append(("check (load + check)", t["cadpipe"], "pymeshlab", t["pymeshlab"]))
        t = interleaved(runs, cadpipe=lambda: load_mesh(stl), trimesh=lambda: trimesh_load(stl))
        rows.append(("load STL", t["cadpipe"], "trimesh.load", t["trimesh"]))
        for suffix in ("glb", "usdc"):
            target = FilePath(folder) / f"pipe.{suffix}"
            t = interleaved(runs, normals=lambda target=target: export(fresh, target),
                            plain=lambda target=target: export(fresh, target, normals=False))
            rows.append((f"write {suffix} with normals", t["normals"], "without", t["plain"]))
    print(f"{'what':28s} {'cadpipe s':>10s}  {'peer':14s} {'peer s':>8s} {'ratio':>6s}")
    for what, ours, peer, theirs in rows:
        print(f"{what:28s} {ours:10.3f}  {peer:14s} {theirs:8.3f} {ours / theirs:6.2f}")


def resident():
    """This process's resident memory now, in bytes (Linux /proc)."""
    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * resource.getpagesize()


def peak_of_one_write(suffix, points):
    """Run in a child: build the pipe, then write it; print the mesh's bytes, the resident
    memory before the write and its peak during it (sampled every 2 ms), and seconds."""
    mesh = wavy_pipe(points, 16)
    arrays = mesh.vertices.nbytes + mesh.faces.nbytes
    before = resident()
    peak, writing = [before], threading.Event()

    def sample():
        while not writing.is_set():
            peak[0] = max(peak[0], resident())
            time.sleep(0.002)

    sampler = threading.Thread(target=sample)
    sampler.start()
    with tempfile.TemporaryDirectory(prefix="bench-io-", dir=".") as folder:
        start = time.perf_counter()
        export(mesh, FilePath(folder) / f"pipe.{suffix}")
        seconds = time.perf_counter() - start
    writing.set()
    sampler.join()
    print(arrays, before, peak[0], seconds)


def memory(points):
    print(f"peak memory of one write, {points:,}-point pipe x 16 sides (fresh process each)")
    print(f"{'format':8s} {'mesh MB':>9s} {'before MB':>9s} {'peak MB':>9s} {'added/mesh':>10s} "
          f"{'write s':>8s}")
    for suffix in FORMATS:
        run = subprocess.run([sys.executable, __file__, "--child", suffix, "--points",
                              str(points)], capture_output=True, text=True, check=True)
        arrays, before, after, seconds = map(float, run.stdout.split())
        added = max(after - before, 0.0)
        print(f"{suffix:8s} {arrays / 1e6:9.0f} {before / 1e6:9.0f} {after / 1e6:9.0f} "
              f"{added / arrays:10.2f} {seconds:8.2f}")


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--points", type=int, default=200_000,
                        help="path points of the memory runs' pipe (16 sides)")
    parser.add_argument("--speed-points", type=int, default=20_000,
                        help="path points of the speed runs' pipe (25 sides)")
    parser.add_argument("--memory-only", action="store_true")
    parser.add_argument("--child", choices=FORMATS)
    args = parser.parse_args()
    if args.child:
        return peak_of_one_write(args.child, args.points)
    if not args.memory_only:
        speed(args.runs, args.speed_points)
    memory(args.points)


if __name__ == "__main__":
    main()
