"""Test-only: everything a valid solid chain must pass, each against a reference
that is not the code under test: the triangle oracle (:mod:`tri_tri`), manifold3d's
status, trimesh's watertightness and volume, and STL and 3MF round trips (welded at
float32 as the files store it, then ``cadpipe check``'s report)."""

import io

import manifold3d
import numpy as np
import trimesh

from cadpipe import Mesh
from cadpipe.solids.validity import check_mesh
from tri_tri import self_intersections


def solid_problems(mesh, round_trip=True):
    """What is wrong with ``mesh`` as one valid solid: a list of sentences, empty if
    nothing."""
    v, f = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    problems = []
    crossing = self_intersections(v, f)
    if crossing:
        problems.append(f"tri_tri: {crossing} pairs of faces cut each other")
    status = manifold3d.Manifold(manifold3d.Mesh64(vert_properties=np.array(v),
                                                   tri_verts=f.astype(np.uint64))).status()
    if status != manifold3d.Error.NoError:
        problems.append(f"manifold3d: {status}")
    tm = trimesh.Trimesh(v, f, process=False)
    if not (tm.is_watertight and tm.is_winding_consistent and tm.volume > 0):
        problems.append("trimesh: not a watertight, consistently wound, positive solid")
    if round_trip:
        for kind in ("stl", "3mf"):
            back = trimesh.load(io.BytesIO(tm.export(file_type=kind)), file_type=kind,
                                force="mesh", process=False)
            back.merge_vertices(digits_vertex=None)     # float32 coordinates, welded exactly
            report = check_mesh(Mesh(back.vertices, back.faces))
            if not report["valid"] or len(back.faces) != len(f):
                problems.append(f"{kind} round trip: {report['problems']}, "
                                f"{len(back.faces)} faces of {len(f)}")
    return problems
