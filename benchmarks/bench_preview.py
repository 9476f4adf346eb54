"""Offscreen preview speed: cadpipe's numpy z-buffer against VTK and matplotlib.

One 200k-triangle pipe (a helix, 50 sides) is drawn to a 960x720 PNG by
cadpipe.io.preview.render_png, by pyvista/VTK off screen (software OpenGL: OSMesa or
EGL, whichever the wheel finds; no GPU) and by matplotlib's Agg backend
(Poly3DCollection, painter's algorithm). Each call is one-shot, as a preview is; the
fastest of several runs is reported (the machine may be shared).

Run: .venv/bin/python benchmarks/bench_preview.py
"""

import tempfile
import time
from pathlib import Path as FilePath

import numpy as np

from cadpipe import Path, Pipe
from cadpipe.io.preview import render_png, write_html

SIZE = (960, 720)


def helix():
    t = np.linspace(0, 6 * np.pi, 2000)
    return Pipe(Path(np.column_stack([np.cos(t), np.sin(t), t / 6])), radius=0.15,
                sides=50).mesh()


def best_of(func, repeat):
    """Fastest of ``repeat`` timed calls after a warm-up (imports, first allocations)."""
    func()
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        func()
        times.append(time.perf_counter() - start)
    return min(times)


def pyvista_png(mesh, out):
    import pyvista as pv

    faces = np.column_stack([np.full(len(mesh.faces), 3), mesh.faces]).ravel()
    plotter = pv.Plotter(off_screen=True, window_size=SIZE)
    plotter.add_mesh(pv.PolyData(np.asarray(mesh.vertices), faces), color="#4e79a7")
    plotter.screenshot(out)
    plotter.close()


def matplotlib_png(mesh, out):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    fig = plt.figure(figsize=(SIZE[0] / 100, SIZE[1] / 100), dpi=100)
    ax = fig.add_subplot(projection="3d")
    ax.add_collection3d(Poly3DCollection(mesh.triangles, facecolors="#4e79a7",
                                         shade=True, linewidths=0))
    lo, hi = mesh.bounds
    ax.set(xlim=(lo[0], hi[0]), ylim=(lo[1], hi[1]), zlim=(lo[2], hi[2]))
    fig.savefig(out)
    plt.close(fig)


def main():
    mesh = helix()
    print(f"mesh: {len(mesh.faces):,} triangles, image {SIZE[0]}x{SIZE[1]}")
    with tempfile.TemporaryDirectory() as folder:
        folder = FilePath(folder)
        ours = best_of(lambda: render_png(mesh, folder / "a.png", size=SIZE), 5)
        html = best_of(lambda: write_html(mesh, folder / "a.html"), 3)
        vtk = best_of(lambda: pyvista_png(mesh, folder / "b.png"), 3)
        mpl = best_of(lambda: matplotlib_png(mesh, folder / "c.png"), 3)
    print(f"cadpipe render_png     {ours:7.3f} s")
    print(f"pyvista/VTK offscreen  {vtk:7.3f} s   ({vtk / ours:5.2f}x cadpipe's time)")
    print(f"matplotlib Agg         {mpl:7.3f} s   ({mpl / ours:5.2f}x cadpipe's time)")
    print(f"cadpipe write_html     {html:7.3f} s")


if __name__ == "__main__":
    main()
