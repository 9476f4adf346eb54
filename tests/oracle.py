"""Test-only references for pipe meshes, written apart from cadpipe's own checks.

:func:`crossing_faces` is an independent triangle-triangle intersection test (a
KD-tree over face centres, then every edge of one triangle against the interior
of the other); :func:`solid_problems` adds manifold3d's status, trimesh's
watertightness and round trips through STL and 3MF written by trimesh.
"""

import io

import manifold3d
import numpy as np
import trimesh


def _pierces(p, q, tri, tol):
    """(P,) True where segment p->q crosses the interior of triangle ``tri`` (P, 3, 3)."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    n = np.cross(b - a, c - a)
    size = np.linalg.norm(n, axis=1)
    n = n / np.where(size > 0, size, 1.0)[:, None]
    dp = np.einsum("ij,ij->i", p - a, n)
    dq = np.einsum("ij,ij->i", q - a, n)
    cross = ((dp > tol) & (dq < -tol)) | ((dp < -tol) & (dq > tol))
    with np.errstate(invalid="ignore", divide="ignore"):
        x = p + (dp / (dp - dq))[:, None] * (q - p)
    inside = np.ones(len(p), bool)
    for u, v in ((a, b), (b, c), (c, a)):
        inside &= np.einsum("ij,ij->i", np.cross(v - u, x - u), n) > tol
    return cross & inside & (size > 0)


def _box_pairs(low, high):
    """Pairs ``i < j`` of overlapping boxes: sort and sweep along the widest axis."""
    axis = int(np.argmax(high.max(axis=0) - low.min(axis=0)))
    order = np.argsort(low[:, axis], kind="stable")
    low, high = low[order], high[order]
    stop = np.searchsorted(low[:, axis], high[:, axis], side="right")
    count = stop - np.arange(len(low)) - 1
    i = np.repeat(np.arange(len(low)), count)
    j = i + 1 + (np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count))
    keep = ((low[i] <= high[j]) & (low[j] <= high[i])).all(axis=1)
    i, j = order[i[keep]], order[j[keep]]
    return np.minimum(i, j), np.maximum(i, j)


def crossing_faces(vertices, faces):
    """(K, 2) pairs of faces sharing no vertex whose triangles cut through each other
    (an edge of one passes through the other's interior, beyond a tolerance of 1e-9
    of the mesh size). Broad phase: boxes, sorted and swept."""
    vertices = np.asarray(vertices, float)
    faces = np.asarray(faces)
    tri = vertices[faces]
    size = float(np.ptp(vertices, axis=0).max())
    tol = 1e-9 * size
    i, j = _box_pairs(tri.min(axis=1) - tol, tri.max(axis=1) + tol)
    shared = (faces[i][:, :, None] == faces[j][:, None, :]).any(axis=(1, 2))
    i, j = i[~shared], j[~shared]
    hit = np.zeros(len(i), bool)
    for one, other in ((i, j), (j, i)):
        for k in range(3):
            p, q = tri[one, k], tri[one, (k + 1) % 3]
            hit |= _pierces(p, q, tri[other], tol)
    return np.stack([i[hit], j[hit]], 1)


def solid_problems(mesh, round_trip=True):
    """What is wrong with ``mesh`` as a solid, as a list of strings (empty: nothing)."""
    problems = []
    v, f = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    crossing = crossing_faces(v, f)
    if len(crossing):
        problems.append(f"{len(crossing)} pairs of faces cut each other")
    solid = manifold3d.Manifold(manifold3d.Mesh(v.astype(np.float32), f.astype(np.uint32)))
    if solid.status() != manifold3d.Error.NoError:
        problems.append(f"manifold3d: {solid.status()}")
    tm = trimesh.Trimesh(v, f, process=False)
    if not (tm.is_watertight and tm.is_winding_consistent and tm.volume > 0):
        problems.append("trimesh: not a watertight, consistently wound, positive solid")
    if round_trip:
        for kind in ("stl", "3mf"):
            data = tm.export(file_type=kind)
            back = trimesh.load(io.BytesIO(data), file_type=kind, force="mesh")
            if not (back.is_watertight and back.is_winding_consistent
                    and len(back.faces) == len(f)):
                problems.append(f"{kind} round trip: {len(back.faces)} faces of {len(f)}, "
                                f"watertight {back.is_watertight}")
    return problems
