"""Export speed: cadpipe's writers vs trimesh's on a one-million-triangle pipe.

A wavy pipe of 20,000 rings x 25 sides (999,996 triangles), one process. Each
writer gets a freshly built mesh object (no cached normals) and writes a file
to the same temporary folder; best of 3. trimesh has no USD writer, so .usdc is
timed alone. The 3MF output is read back with trimesh to check it holds the
same triangles.

Run: .venv/bin/python benchmarks/bench_export.py
"""

import tempfile
import time
from pathlib import Path as FilePath

import numpy as np
import trimesh

import cadpipe
from cadpipe.io.stl import write_stl
from cadpipe.io.threemf import write_3mf
from cadpipe.io.usd import write_usd

RINGS, SIDES, RADIUS = 20_000, 25, 0.02
TARGETS = {"STL (binary)": (0.1, 3.0), ".usdc": (0.5, None), "3MF": (None, 3.0)}


def best_of(write, fresh, target, repeat=3):
    """Least seconds of ``write(fresh(), target)`` over ``repeat`` runs into a new file.

    Making the object and deleting the previous file are not timed.
    """
    best = np.inf
    for _ in range(repeat):
        obj = fresh()
        target.unlink(missing_ok=True)
        start = time.perf_counter()
        write(obj, target)
        best = min(best, time.perf_counter() - start)
    return best


def trimesh_export(tm, target):
    tm.export(target)


def main():
    s = np.linspace(0, 10, RINGS)
    path = np.c_[s, 0.2 * np.sin(s), 0.1 * np.cos(0.7 * s)]
    base = cadpipe.Pipe(path, RADIUS, sides=SIDES).mesh()
    vertices, faces = np.array(base.vertices), np.array(base.faces)
    print(f"mesh: {len(faces):,} triangles, {len(vertices):,} vertices")

    def fresh_mesh():
        return cadpipe.Mesh(vertices, faces)

    def fresh_trimesh():
        return trimesh.Trimesh(vertices, faces, process=False)

    rows = []
    with tempfile.TemporaryDirectory(prefix="bench-export-", dir=".") as folder:
        out = FilePath(folder)
        stl = best_of(write_stl, fresh_mesh, out / "a.stl")
        stl_peer = best_of(trimesh_export, fresh_trimesh, out / "b.stl")
        rows.append(("STL (binary)", stl, stl_peer))
        usdc = best_of(write_usd, fresh_mesh, out / "a.usdc")
        rows.append((".usdc", usdc, None))
        three = best_of(write_3mf, fresh_mesh, out / "a.3mf")
        three_peer = best_of(trimesh_export, fresh_trimesh, out / "b.3mf", repeat=1)
        rows.append(("3MF", three, three_peer))
        back = trimesh.load(out / "a.3mf", force="mesh", process=False)
        same = np.array_equal(np.asarray(back.triangles, np.float32),
                              base.triangles.astype(np.float32))
        sizes = {p.name: p.stat().st_size for p in out.iterdir()}

    print(f"{'format':14s} {'cadpipe s':>10s} {'trimesh s':>10s} {'speed-up':>9s}  target")
    for name, ours, peer in rows:
        limit, ratio = TARGETS[name]
        speedup = peer / ours if peer else None
        met = (limit is None or ours <= limit) and (ratio is None or speedup >= ratio)
        wanted = " and ".join(filter(None, [f"<= {limit} s" if limit else "",
                                            f">= {ratio}x trimesh" if ratio else ""]))
        peer_text = f"{peer:10.3f}" if peer else f"{'-':>10s}"
        speedup_text = f"{speedup:8.1f}x" if speedup else f"{'-':>9s}"
        print(f"{name:14s} {ours:10.3f} {peer_text} {speedup_text}  {wanted}: "
              f"{'met' if met else 'MISSED'}")
    print(f"3MF read back by trimesh: same float32 triangles = {same}")
    print("file sizes (MB): " + ", ".join(f"{k} {v / 1e6:.1f}" for k, v in sorted(sizes.items())))


if __name__ == "__main__":
    main()
