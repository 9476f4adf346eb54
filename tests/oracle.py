"""Test-only references for meshes, written apart from cadpipe's own checks.

:func:`crossing_faces` is an independent triangle-triangle intersection test (an
rtree over the faces' boxes, then every edge of one triangle against the interior
of the other, vectorized over the candidate pairs); :func:`solid_problems` adds
manifold3d's status, trimesh's watertightness and round trips through STL and 3MF
written by trimesh (welded at float32 as the files store it, then ``cadpipe check``'s
report). :func:`winding_numbers` is the brute-force solid-angle sum over every
triangle, in numpy, that ``cadpipe.geometry.winding``'s tree must reproduce. Faces
that share a vertex are neighbours in a valid mesh and
are not tested; touching within 1e-9 of the mesh size is not counted (coplanar
contact is a matter of rounding, not a wrong result).
"""

import io

import fcl
import manifold3d
import numpy as np
import trimesh

from cadpipe import Mesh
from cadpipe.solids.validity import check_mesh


def winding_numbers(triangles, points, chunk=2_000_000):
    """Generalized winding number of the triangles (F, 3, 3) at each point (P, 3): the
    signed solid angles (Van Oosterom and Strackee) summed over 4 pi, every triangle
    for every point, in chunks of about ``chunk`` pairs."""
    out = np.empty(len(points))
    step = max(1, chunk // max(len(triangles), 1))
    for start in range(0, len(points), step):
        r = triangles[None, :, :, :] - points[start:start + step, None, None, :]
        n = np.linalg.norm(r, axis=3)
        a, b, c = r[:, :, 0], r[:, :, 1], r[:, :, 2]
        det = np.einsum("pfi,pfi->pf", a, np.cross(b, c))
        dots = (n[:, :, 0] * n[:, :, 1] * n[:, :, 2]
                + np.einsum("pfi,pfi->pf", a, b) * n[:, :, 2]
                + np.einsum("pfi,pfi->pf", b, c) * n[:, :, 0]
                + np.einsum("pfi,pfi->pf", c, a) * n[:, :, 1])
        out[start:start + step] = np.arctan2(det, dots).sum(axis=1) / (2 * np.pi)
    return out


def _pierces(p, q, tri, tol):
    """(P,) True where segment p->q crosses the interior of triangle ``tri`` (P, 3, 3)."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    n = np.cross(b - a, c - a)
    size = np.linalg.norm(n, axis=1)
    n = n / np.where(size > 0, size, 1.0)[:, None]
    dp = np.einsum("ij,ij->i", p - a, n)
    dq = np.einsum("ij,ij->i", q - a, n)
    cross = ((dp > tol) & (dq < -tol)) | ((dp < -tol) & (dq > tol))
    t = np.divide(dp, dp - dq, out=np.zeros_like(dp), where=cross)
    x = p + t[:, None] * (q - p)
    inside = np.ones(len(p), bool)
    for u, v in ((a, b), (b, c), (c, a)):
        edge = v - u
        length = np.linalg.norm(edge, axis=1)
        inside &= np.einsum("ij,ij->i", np.cross(edge, x - u), n) > tol * length
    return cross & inside & (size > 0)


def _box_pairs(low, high):
    """Pairs ``i < j`` of overlapping boxes (an rtree query)."""
    from rtree import index

    tree = index.Index(((i, (*low[i], *high[i]), None) for i in range(len(low))),
                       properties=index.Property(dimension=3))
    ids, counts = tree.intersection_v(low, high)
    first = np.repeat(np.arange(len(low)), counts.astype(np.int64))
    ids = ids.astype(np.int64)
    keep = first < ids
    return first[keep], ids[keep]


def crossing_faces(vertices, faces):
    """(K, 2) pairs of faces sharing no vertex whose triangles cut through each other
    (an edge of one passes through the other's interior, beyond a tolerance of 1e-9
    of the mesh size)."""
    vertices = np.asarray(vertices, float)
    faces = np.asarray(faces, np.int64)
    if not len(faces):
        return np.empty((0, 2), np.int64)
    tri = vertices[faces]
    size = float(np.ptp(vertices, axis=0).max()) or 1.0
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


def self_intersections(vertices, faces):
    """Number of face pairs (sharing no vertex) that cut through each other."""
    return len(crossing_faces(vertices, faces))


def solid_problems(mesh, round_trip=True):
    """What is wrong with ``mesh`` as a solid, as a list of strings (empty: nothing)."""
    v, f = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    if not len(f):
        return ["no triangles"]
    problems = []
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
            back = trimesh.load(io.BytesIO(tm.export(file_type=kind)), file_type=kind,
                                force="mesh", process=False)
            back.merge_vertices(digits_vertex=None)     # float32 coordinates, welded exactly
            report = check_mesh(Mesh(back.vertices, back.faces))
            if not (report["valid"] and back.is_watertight and back.is_winding_consistent
                    and back.volume > 0 and len(back.faces) == len(f)):
                problems.append(f"{kind} round trip: {report['problems']}, "
                                f"{len(back.faces)} faces of {len(f)}, "
                                f"watertight {back.is_watertight}")
    return problems


def fcl_bvh(mesh):
    """The mesh as python-fcl's BVH model: FCL as the reference for collision answers."""
    bvh = fcl.BVHModel()
    bvh.beginModel(len(mesh.vertices), len(mesh.faces))
    bvh.addSubModel(np.array(mesh.vertices), np.array(mesh.faces))
    bvh.endModel()
    return bvh


def crease_normals(vertices, faces, crease_angle):
    """(3F, 3) shading normal at each corner of ``faces.ravel()`` by the crease rule, the
    slow and plain way: per corner, the faces around its vertex whose normals lie within
    ``crease_angle`` degrees of its own face's, summed weighted by their angle at the
    vertex (``np.arctan2``), made unit. A corner of a degenerate face takes the sum
    over all faces at its vertex."""
    v, f = np.asarray(vertices, np.float64), np.asarray(faces)
    corners = v[f]                                                   # (F, 3, 3)
    normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    length = np.linalg.norm(normal, axis=1)
    unit = normal / np.where(length > 0, length, 1.0)[:, None]
    angles = np.empty(f.shape)
    for k in range(3):
        u = corners[:, (k + 1) % 3] - corners[:, k]
        w = corners[:, (k + 2) % 3] - corners[:, k]
        angles[:, k] = np.arctan2(np.linalg.norm(np.cross(u, w), axis=1),
                                  np.einsum("ij,ij->i", u, w))
    at_vertex = [[] for _ in range(len(v))]
    for face, row in enumerate(f):
        for k, vertex in enumerate(row):
            at_vertex[vertex].append((face, k))
    limit = np.cos(np.radians(crease_angle)) - 1e-6
    out = np.zeros((3 * len(f), 3))
    for face, row in enumerate(f):
        for k, vertex in enumerate(row):
            around = np.array(at_vertex[vertex])
            near = unit[around[:, 0]] @ unit[face] >= limit if length[face] > 0 else True
            picked = around[near] if length[face] > 0 else around
            total = (unit[picked[:, 0]] * angles[picked[:, 0], picked[:, 1]][:, None]).sum(0)
            out[3 * face + k] = total / max(np.linalg.norm(total), 1e-300)
    return out
