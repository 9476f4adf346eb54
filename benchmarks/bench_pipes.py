"""Pipe building speed: cadpipe vs trimesh's sweep_polygon vs VTK's tube filter (PyVista).

A helix of 100,000 points, 16 sides, one process. Prints seconds, output vertices
per second, watertightness and ratios. Run: .venv/bin/python benchmarks/bench_pipes.py
"""

import time

import numpy as np
import pyvista as pv
import shapely
import trimesh

import cadpipe

POINTS, SIDES, RADIUS = 100_000, 16, 0.05


def best_of(func, repeat=3):
    best, result = np.inf, None
    for _ in range(repeat):
        start = time.perf_counter()
        result = func()
        best = min(best, time.perf_counter() - start)
    return best, result


def watertight(vertices, faces):
    return cadpipe.Mesh(vertices, faces).is_watertight


def main():
    t = np.linspace(0, 40 * np.pi, POINTS)
    helix = np.c_[np.cos(t), np.sin(t), 0.5 * t / (2 * np.pi)]
    rows = []

    sec, mesh = best_of(lambda: cadpipe.Pipe(helix, RADIUS, sides=SIDES).mesh())
    rows.append(("cadpipe Pipe.mesh()", sec, len(mesh.vertices), mesh.is_watertight))

    polygon = shapely.Polygon(RADIUS * np.c_[np.cos(np.arange(SIDES) * 2 * np.pi / SIDES),
                                             np.sin(np.arange(SIDES) * 2 * np.pi / SIDES)])
    sec, tm = best_of(lambda: trimesh.creation.sweep_polygon(polygon, helix), repeat=1)
    rows.append(("trimesh sweep_polygon", sec, len(tm.vertices), watertight(tm.vertices, tm.faces)))

    line = pv.lines_from_points(helix)

    def vtk_tube():
        return line.tube(radius=RADIUS, n_sides=SIDES, capping=True)

    sec, raw = best_of(vtk_tube)
    tri = raw.triangulate()
    rows.append(("VTK tube (raw)", sec, raw.n_points,
                 watertight(tri.points, tri.faces.reshape(-1, 4)[:, 1:])))

    def vtk_clean():
        return vtk_tube().triangulate().clean()

    sec, clean = best_of(vtk_clean)
    rows.append(("VTK tube + clean()", sec, clean.n_points,
                 watertight(clean.points, clean.faces.reshape(-1, 4)[:, 1:])))

    ours = rows[0][1]
    print(f"helix of {POINTS:,} points, {SIDES} sides, radius {RADIUS}")
    print(f"{'method':24} {'seconds':>9} {'vertices':>10} {'Mvert/s':>8} {'watertight':>10} "
          f"{'cadpipe faster by':>18}")
    for name, sec, verts, tight in rows:
        print(f"{name:24} {sec:9.3f} {verts:10,} {verts / sec / 1e6:8.1f} {str(tight):>10} "
              f"{sec / ours:17.1f}x")


if __name__ == "__main__":
    main()
