"""Reading, checking and writing at size: cadpipe beside its peers, and peak memory.

Comparisons in one process, interleaved A B A B (medians of ``--runs`` of wall and
CPU seconds, ratios cadpipe / peer; the load average is printed with them):

- ``cadpipe check`` (load the STL, then :func:`cadpipe.check_mesh`: topology,
  orientation, volume, self-intersections, nested shells) against pymeshlab
  loading the same STL and computing its topological measures plus its
  self-intersecting-face selection; and, on two crossing pipes, whether both
  flag the same faces;
- ``Mesh.load`` against ``trimesh.load(path, force="mesh")`` (which merges
  vertices, as cadpipe welds them; in a GLB only where their normals agree too) on
  the same pipe as STL, OBJ, PLY, 3MF and GLB;
- GLB and ``.usdc`` with normals against the same write without them, against
  trimesh's GLB export and a plain usd-core stage (points and indices only), and
  both formats written from one mesh (the shading is computed once and shared):
  for the pipe as ``Pipe.mesh()`` makes it (its inner rings' normals from their ring
  neighbours) and for its arrays alone (a mesh read from a file: the general passes);
  and usd-core alone holding the normals as cadpipe writes them (indexed faceVarying)
  against vertex normals on a mesh whose crease vertices are split, as glTF's are;
- the mesh's topology (``geometry.topology``): the edge table against ``np.unique`` of
  the edge keys, watertightness against trimesh's on a new ``Trimesh``, and the
  bodies' vertex labels against scipy's connected components (``np.unique`` and scipy
  are what cadpipe used before).

Then, in a fresh process per format, the peak resident memory of writing a large
pipe (``--points`` points, 16 sides) above the memory before the write (freed memory
handed back to the system first, and the writer warmed up on a small pipe), against
the size of the mesh's own arrays (vertices and faces), and numpy's own peak
(tracemalloc sees numpy's buffers, not usd-core's).

Run: OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_io.py --speed-only [--runs 5]
     [--speed-points 20000 (1M triangles)]
     .venv/bin/python benchmarks/bench_io.py --memory-only --points 2000000
"""

import argparse
import os
import subprocess
import sys
import tempfile
import threading
import time
import tracemalloc
from pathlib import Path as FilePath

import numpy as np

import cadpipe
from cadpipe.geometry.topology import edge_table
from cadpipe.core.formats import export, load_mesh
from cadpipe.io.normals import shading_normals
from cadpipe.geometry.intersect import self_intersections
from cadpipe.solids.validity import check_mesh

from _common import resident, settled

FORMATS = ("stl", "3mf", "obj", "ply", "glb", "usda", "usdc", "usdz")
#: the memory runs' peer: usd-core alone holding the same points, counts and indices
PXR = "pxr.usdc"
#: the memory run of a PLY whose faces carry three colours (vertices split where they meet)
PLY3 = "3-colour.ply"
EXTRA = (PXR, PLY3)
LOAD_FORMATS = ("stl", "obj", "ply", "3mf", "glb")
#: a write over this many bytes above the mesh misses issue 16's target
LIMIT = 4e9


def wavy_pipe(points, sides):
    s = np.linspace(0, 10, points)
    path = np.c_[s, 0.2 * np.sin(s), 0.1 * np.cos(0.7 * s)]
    return cadpipe.Pipe(cadpipe.Path(path), 0.02, sides=sides).mesh()


def interleaved(runs, **contenders):
    """{name: (median wall s, median CPU s)}: each contender once untimed (compilation,
    caches), then once per round, each round starting one contender later (A B C, B C A,
    C A B, ...). CPU time is the process's, so it includes any thread a contender leaves
    spinning (OpenBLAS's do, after a matrix product, on a busy machine): run with
    ``OPENBLAS_NUM_THREADS=1`` to keep that out of the next contender's figure.

    The order turns because what runs after a contender that frees much memory pays for
    it: here, a large write right after trimesh's GLB export took 2-6x its time in the
    kernel's copy into the page cache (this virtual machine reports freed pages to its
    host, virtio-balloon free page reporting, and pages handed back fault in again when
    used), and a fixed A B C order charged that to one contender every round."""
    for call in contenders.values():
        call()
    times = {name: [] for name in contenders}
    names = list(contenders)
    for round_ in range(runs):
        turn = round_ % len(names)
        for name in names[turn:] + names[:turn]:
            call = contenders[name]
            wall, cpu = time.perf_counter(), time.process_time()
            call()
            times[name].append((time.perf_counter() - wall, time.process_time() - cpu))
    return {name: tuple(np.median(t, axis=0)) for name, t in times.items()}


def pymeshlab_check(path):
    """pymeshlab's checks of a mesh file: the indices of the self-intersecting faces."""
    import pymeshlab

    ms = pymeshlab.MeshSet()
    ms.load_new_mesh(str(path))
    ms.get_topological_measures()
    ms.compute_selection_by_self_intersections_per_face()
    return np.flatnonzero(ms.current_mesh().face_selection_array())


def trimesh_load(path):
    """trimesh's load, which merges vertices as cadpipe welds them (``process=True``;
    a GLB's only where the normals agree too)."""
    import trimesh

    return trimesh.load(path, force="mesh")


def pxr_plain(mesh, path, normals=None):
    """The least a usd-core user writes: one Mesh prim, points, counts and indices;
    ``normals``: also the mesh's shading normals, ``"indexed"`` (faceVarying, indexed
    per corner: cadpipe's layout) or ``"split"`` (per vertex, the crease vertices
    split into copies as in glTF, which changes the points and indices)."""
    from pxr import Sdf, Usd, UsdGeom, Vt

    from cadpipe.io.normals import split_for_normals

    points, faces = mesh.vertices.astype(np.float32), mesh.faces.astype(np.int32).ravel()
    if normals == "split":
        points, faces, shading = split_for_normals(mesh)
    stage = Usd.Stage.CreateInMemory()
    geom = UsdGeom.Mesh.Define(stage, "/pipe")
    geom.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points))
    geom.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(mesh.faces), 3,
                                                                  np.int32)))
    geom.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(faces.view(np.int32).ravel()))
    if normals == "split":
        geom.CreateNormalsAttr(Vt.Vec3fArray.FromNumpy(shading))
        geom.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    elif normals == "indexed":
        shading = shading_normals(mesh)
        primvar = UsdGeom.PrimvarsAPI(geom).CreatePrimvar(
            "normals", Sdf.ValueTypeNames.Normal3fArray, UsdGeom.Tokens.faceVarying)
        primvar.SetIndices(Vt.IntArray.FromNumpy(shading.corner_index))
        primvar.Set(Vt.Vec3fArray.FromNumpy(shading.normals))
    stage.GetRootLayer().Export(str(path))


def banded(mesh):
    """``mesh`` with its faces in three colours, in bands of 5,000 faces."""
    return mesh.with_parts(["red", "green", "blue"], (np.arange(len(mesh.faces)) // 5000) % 3)


def numpy_split(mesh):
    """The sort-based PLY colour split (cadpipe's before): one vertex per distinct
    (vertex, label) pair through ``np.unique`` of packed keys."""
    key = mesh.faces * len(mesh.part_names) + mesh.face_part[:, None]
    unique, faces = np.unique(key, return_inverse=True)
    return np.divmod(unique, len(mesh.part_names)), faces.reshape(-1, 3)


def cadpipe_split(mesh):
    from cadpipe.io.trimesh_formats import _copies_per_label

    faces = np.empty(mesh.faces.shape, np.int32)
    return _copies_per_label(mesh.faces, mesh.face_part, len(mesh.vertices), faces), faces


def same_findings(folder):
    """Two crossing pipes in one STL: the faces cadpipe and pymeshlab call crossing."""
    bent = cadpipe.Pipe(cadpipe.Path.spline([[0, 0, 0], [1, 0, 0], [1, 1, 0.5], [0, 1, 1]],
                                            step=0.05), 0.1, sides=12).mesh()
    rod = cadpipe.Pipe([[0.5, -1, 0.0], [0.5, 1, 0.01]], 0.05, sides=8).mesh()
    stl = export(cadpipe.Mesh.concatenate([bent, rod]), FilePath(folder) / "crossing.stl",
                 units="m")
    ours = np.unique(self_intersections(load_mesh(stl)))
    theirs = pymeshlab_check(stl)
    return len(ours), len(theirs), bool(np.array_equal(ours, theirs))


def numpy_edges(mesh):
    """The edge table as cadpipe made it before ``geometry.topology``: ``np.unique`` of
    the directed edges' keys, with the inverse and the counts."""
    e = mesh.edges
    return np.unique(mesh.edge_keys(e[:, 0], e[:, 1]), return_inverse=True,
                     return_counts=True)


def scipy_labels(mesh):
    """Connected pieces as cadpipe found them before: scipy's connected components of
    the edges' sparse graph."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    e, count = mesh.edges, len(mesh.vertices)
    graph = coo_matrix((np.ones(len(e), np.int8), (e[:, 0], e[:, 1])), shape=(count, count))
    return connected_components(graph, directed=False)[1]


def fresh(mesh):
    """A new mesh object of the same arrays and ring runs (as ``Pipe.mesh()`` gives
    them): nothing cached from an earlier write."""
    return cadpipe.Mesh.trusted(mesh.vertices, mesh.faces, ring_runs=mesh.ring_runs)


def bare(mesh):
    """A new mesh object of the same arrays alone, as a mesh read from a file is."""
    return cadpipe.Mesh.trusted(mesh.vertices, mesh.faces)


def speed(runs, points):
    import trimesh

    mesh = wavy_pipe(points, 25)
    print(f"mesh: {len(mesh.faces):,} triangles, {len(mesh.vertices):,} vertices; "
          f"medians of {runs} interleaved runs; load average {os.getloadavg()[0]:.1f}")
    rows = []
    with tempfile.TemporaryDirectory(prefix="bench-io-", dir=".") as folder:
        out = FilePath(folder)
        stl = export(mesh, out / "pipe.stl", units="m")
        t = interleaved(runs, cadpipe=lambda: check_mesh(load_mesh(stl)),
                        pymeshlab=lambda: pymeshlab_check(stl))
        rows.append(("check (load + check)", t["cadpipe"], "pymeshlab", t["pymeshlab"]))
        for suffix in LOAD_FORMATS:
            target = export(mesh, out / f"load.{suffix}")
            t = interleaved(runs, cadpipe=lambda target=target: load_mesh(target),
                            trimesh=lambda target=target: trimesh_load(target))
            rows.append((f"load {suffix}", t["cadpipe"], "trimesh.load", t["trimesh"]))
        tm = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
        t = interleaved(runs, normals=lambda: export(fresh(mesh), out / "a.glb"),
                        plain=lambda: export(fresh(mesh), out / "b.glb", normals=False),
                        trimesh=lambda: tm.export(out / "c.glb"),
                        general=lambda: export(bare(mesh), out / "e.glb"))
        rows.append(("write glb with normals", t["normals"], "without", t["plain"]))
        rows.append(("write glb with normals", t["normals"], "trimesh (none)", t["trimesh"]))
        rows.append(("  arrays alone (general)", t["general"], "without", t["plain"]))
        t = interleaved(runs, normals=lambda: export(fresh(mesh), out / "a.usdc"),
                        plain=lambda: export(fresh(mesh), out / "b.usdc", normals=False),
                        pxr=lambda: pxr_plain(mesh, out / "c.usdc"),
                        general=lambda: export(bare(mesh), out / "e.usdc"))
        rows.append(("write usdc with normals", t["normals"], "without", t["plain"]))
        rows.append(("write usdc with normals", t["normals"], "plain pxr", t["pxr"]))
        rows.append(("  arrays alone (general)", t["general"], "without", t["plain"]))
        t = interleaved(runs, indexed=lambda: pxr_plain(fresh(mesh), out / "f.usdc", "indexed"),
                        split=lambda: pxr_plain(fresh(mesh), out / "g.usdc", "split"),
                        plain=lambda: pxr_plain(mesh, out / "h.usdc"))
        rows.append(("pxr, normals indexed", t["indexed"], "plain pxr", t["plain"]))
        rows.append(("pxr, normals split", t["split"], "plain pxr", t["plain"]))

        def both(normals, made=fresh):
            shared = made(mesh)
            export(shared, out / "d.usdc", normals=normals)
            export(shared, out / "d.glb", normals=normals)

        t = interleaved(runs, normals=lambda: both(True), plain=lambda: both(False),
                        general=lambda: both(True, bare))
        rows.append(("usdc + glb, one mesh", t["normals"], "without normals", t["plain"]))
        rows.append(("  arrays alone (general)", t["general"], "without normals", t["plain"]))
        colours = banded(mesh)
        t = interleaved(runs, cadpipe=lambda: cadpipe_split(colours),
                        numpy=lambda: numpy_split(colours))
        rows.append(("PLY 3-colour vertex split", t["cadpipe"], "np.unique", t["numpy"]))
        t = interleaved(runs, normals=lambda: shading_normals(fresh(mesh)),
                        general=lambda: shading_normals(bare(mesh)))
        rows.append(("shading normals alone", t["normals"], "arrays alone", t["general"]))
        t = interleaved(runs, cadpipe=lambda: edge_table(mesh.faces, len(mesh.vertices)),
                        numpy=lambda: numpy_edges(mesh))
        rows.append(("edge table", t["cadpipe"], "np.unique", t["numpy"]))
        t = interleaved(runs, cadpipe=lambda: bare(mesh).is_watertight,
                        trimesh=lambda: trimesh.Trimesh(mesh.vertices, mesh.faces,
                                                        process=False).is_watertight)
        rows.append(("watertight", t["cadpipe"], "trimesh", t["trimesh"]))
        t = interleaved(runs, cadpipe=lambda: bare(mesh).body_labels,
                        scipy=lambda: scipy_labels(mesh))
        rows.append(("bodies (vertex labels)", t["cadpipe"], "scipy", t["scipy"]))
        findings = same_findings(folder)
    print(f"{'what':26s} {'cadpipe wall':>12s} {'CPU':>7s}  {'peer':16s} {'wall':>7s} "
          f"{'CPU':>7s}  {'ratio wall':>10s} {'CPU':>6s}")
    for what, (ours, ours_cpu), peer, (theirs, theirs_cpu) in rows:
        print(f"{what:26s} {ours:12.3f} {ours_cpu:7.3f}  {peer:16s} {theirs:7.3f} "
              f"{theirs_cpu:7.3f}  {ours / theirs:10.2f} {ours_cpu / theirs_cpu:6.2f}")
    ours, theirs, same = findings
    print(f"crossing pipes: faces in crossing pairs, cadpipe {ours}, pymeshlab {theirs}, "
          f"same faces: {same}")
    print(f"load average after: {os.getloadavg()[0]:.1f}")


def peak_of_one_write(suffix, points):
    """Run in a child: build the pipe, write a small one in the same format (so compiled
    kernels and libraries are loaded before), then write the pipe; print the mesh's
    bytes, the resident memory before the write and its peak during it (sampled every
    2 ms), numpy's peak above the start of the write (tracemalloc) and seconds."""
    mesh = wavy_pipe(points, 16)
    colours = banded(mesh) if suffix == PLY3 else None
    arrays = mesh.vertices.nbytes + mesh.faces.nbytes
    with tempfile.TemporaryDirectory(prefix="bench-io-", dir=".") as folder:
        small = wavy_pipe(100, 16)
        export(banded(small) if suffix == PLY3 else small,
               FilePath(folder) / f"warm.{suffix.split('.')[-1]}")
    before = settled()
    peak, writing = [before], threading.Event()

    def sample():
        while not writing.is_set():
            peak[0] = max(peak[0], resident())
            time.sleep(0.002)

    sampler = threading.Thread(target=sample)
    sampler.start()
    with tempfile.TemporaryDirectory(prefix="bench-io-", dir=".") as folder:
        tracemalloc.start()
        start = time.perf_counter()
        if suffix == PXR:
            pxr_plain(mesh, FilePath(folder) / "pipe.usdc")
        elif suffix == PLY3:
            export(colours, FilePath(folder) / "pipe.ply")
        else:
            export(mesh, FilePath(folder) / f"pipe.{suffix}")
        seconds = time.perf_counter() - start
        traced = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    writing.set()
    sampler.join()
    print(arrays, before, peak[0], traced, seconds)


def memory(points, formats=FORMATS):
    print(f"peak memory of one write, {points:,}-point pipe x 16 sides (fresh process each); "
          f"load average {os.getloadavg()[0]:.1f}")
    print(f"{'format':8s} {'mesh MB':>8s} {'before MB':>9s} {'peak MB':>8s} {'added MB':>8s} "
          f"{'added/mesh':>10s} {'numpy/mesh':>10s} {'write s':>8s}  under 4 GB")
    for suffix in formats:
        run = subprocess.run([sys.executable, __file__, "--child", suffix, "--points",
                              str(points)], capture_output=True, text=True, check=True)
        arrays, before, after, traced, seconds = map(float, run.stdout.split())
        added = max(after - before, 0.0)
        print(f"{suffix:8s} {arrays / 1e6:8.0f} {before / 1e6:9.0f} {after / 1e6:8.0f} "
              f"{added / 1e6:8.0f} {added / arrays:10.2f} {traced / arrays:10.2f} "
              f"{seconds:8.1f}  {'yes' if added < LIMIT else 'NO'}", flush=True)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--points", type=int, default=200_000,
                        help="path points of the memory runs' pipe (16 sides)")
    parser.add_argument("--speed-points", type=int, default=20_000,
                        help="path points of the speed runs' pipe (25 sides)")
    parser.add_argument("--memory-only", action="store_true")
    parser.add_argument("--speed-only", action="store_true")
    parser.add_argument("--formats", nargs="+", choices=(*FORMATS, *EXTRA),
                        default=(*FORMATS, *EXTRA),
                        help=f"formats of the memory runs (each in its own process; {PXR}: "
                             f"a plain usd-core stage of points, counts and indices; {PLY3}: "
                             "the pipe's faces in three colours)")
    parser.add_argument("--child", choices=(*FORMATS, *EXTRA))
    args = parser.parse_args()
    if args.child:
        return peak_of_one_write(args.child, args.points)
    if not args.memory_only:
        speed(args.runs, args.speed_points)
    if not args.speed_only:
        memory(args.points, args.formats)


if __name__ == "__main__":
    main()
