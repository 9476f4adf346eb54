"""The exact narrow phase: does a pair touch, and how far apart is it?

* mesh vs mesh: FCL's BVH traversal (the engine trimesh uses) finds crossing
  triangles. It never sees one closed mesh wholly inside another -- no triangles
  cross -- so when it reports no contact, one probe point per connected piece
  of each mesh is tested against the other with the generalized winding number.
* chain vs chain: :mod:`cadpipe.collision.capsules`, in closed form.
* chain vs mesh: each chain unit as an FCL capsule against the mesh's BVH
  (a unit lying inside the mesh is caught by the probe test; a mesh inside a
  unit is caught by FCL, which treats the capsule as solid).

Every pair is evaluated in the mesh's own frame, so a BVH is built once per
body and never refitted. Touching counts as contact.
"""

from functools import cache

import numba
import numpy as np

from cadpipe.geometry.mesh import winding_numbers
from cadpipe.collision.bounds import KDOP_DIRECTIONS
from cadpipe.collision.hierarchy import chain_gaps

#: a winding number above this is "inside" (it is 1 inside a closed outward mesh)
INSIDE = 0.5

# One pose of one pair costs a few of these compiled loops instead of ~40 numpy calls
# on (1, 4, 4) arrays (per-state figures in docs/performance.md).
_jit = numba.njit(cache=True, nogil=True)


def relative(pose_a, pose_b):
    """Poses of b in a's frame, ``inv(pose_a) @ pose_b``, vectorized over leading axes
    (rigid poses: the inverse is the transposed rotation)."""
    pose_a, pose_b = np.asarray(pose_a, np.float64), np.asarray(pose_b, np.float64)
    if pose_a.shape != pose_b.shape:
        pose_a, pose_b = (np.ascontiguousarray(p) for p in np.broadcast_arrays(pose_a, pose_b))
    out = np.empty(pose_a.shape)
    _relative(pose_a.reshape(-1, 4, 4), pose_b.reshape(-1, 4, 4), out.reshape(-1, 4, 4))
    return out


@_jit
def _relative(pose_a, pose_b, out):
    for e in range(len(pose_a)):
        a, b, o = pose_a[e], pose_b[e], out[e]
        for r in range(3):
            for c in range(4):
                # row r of inv(a) is column r of a's rotation; its shift is -R^T t
                v = a[0, r] * b[0, c] + a[1, r] * b[1, c] + a[2, r] * b[2, c]
                if c == 3:
                    v -= a[0, r] * a[0, 3] + a[1, r] * a[1, 3] + a[2, r] * a[2, 3]
                o[r, c] = v
        o[3, 0], o[3, 1], o[3, 2], o[3, 3] = 0.0, 0.0, 0.0, 1.0


def _apply(matrix, points):
    """Points (..., K, 3) moved by matrices (..., 4, 4)."""
    return points @ matrix[..., :3, :3].swapaxes(-1, -2) + matrix[..., None, :3, 3]


def pseudo_normals(mesh):
    """Angle-weighted pseudo-normals of a closed mesh (Baerentzen and Aanaes, 2005):
    per face, per vertex, and per undirected edge (rows of ``mesh.edges_unique``).

    The sign of ``(p - q) . n`` at the nearest surface point ``q``, with ``n`` the
    pseudo-normal of the feature ``q`` lies on, tells inside from outside.
    """
    tri = mesh.triangles
    normals = mesh.face_normals
    corner = np.zeros((len(tri), 3))
    for k in range(3):
        e1 = tri[:, (k + 1) % 3] - tri[:, k]
        e2 = tri[:, (k + 2) % 3] - tri[:, k]
        cos = np.einsum("ij,ij->i", e1, e2) / np.maximum(
            np.linalg.norm(e1, axis=1) * np.linalg.norm(e2, axis=1), 1e-300)
        corner[:, k] = np.arccos(np.clip(cos, -1.0, 1.0))
    vertex = np.zeros((len(mesh.vertices), 3))
    np.add.at(vertex, mesh.faces.ravel(), (corner[:, :, None] * normals[:, None]).reshape(-1, 3))
    edge = np.zeros((len(mesh.edge_face_counts), 3))
    np.add.at(edge, mesh.edges_unique_inverse, np.repeat(normals, 3, axis=0))
    return normals, vertex, edge


def mesh_contains(body, points):
    """Which ``(P, 3)`` points (in the mesh's frame) lie inside the closed mesh body.

    For each point FCL finds the nearest triangle (a BVH query); the side is the
    sign against the pseudo-normal of the face, edge or vertex the nearest point
    lies on. Where that sign is too close to call, the winding number decides.
    """
    import fcl

    points = np.asarray(points, np.float64)
    lo, hi = body.mesh.bounds
    inside = np.all((points >= lo) & (points <= hi), axis=1)
    if not inside.any():
        return inside
    faces, vertices = body.mesh.faces, body.mesh.vertices
    normals, vertex, edge = body.pseudo_normals
    mesh_object = body.fcl_anchor
    probe = fcl.CollisionObject(fcl.Sphere(0.0), fcl.Transform())
    request = fcl.DistanceRequest(enable_nearest_points=True)
    unsure = []
    for k in inside.nonzero()[0]:
        probe.setTransform(fcl.Transform(points[k]))
        result = fcl.DistanceResult()
        fcl.distance(mesh_object, probe, request, result)
        q, t = np.asarray(result.nearest_points[0]), result.b1
        corners = vertices[faces[t]]
        bary = _barycentric(q, corners)
        small = bary < 1e-7
        if small.sum() >= 2:                      # nearest to a vertex
            n = vertex[faces[t, int(np.argmax(bary))]]
        elif small.any():                         # nearest to an edge
            i, j = faces[t][~small]
            n = edge[body.mesh.edge_index(i, j)]
        else:
            n = normals[t]
        offset = points[k] - q
        side = float(np.dot(offset, n))
        if abs(side) <= 1e-9 * np.linalg.norm(offset) * np.linalg.norm(n):
            unsure.append(k)
        inside[k] = side < 0
    if unsure:
        inside[unsure] = winding_numbers(body.mesh.triangles, points[unsure]) > INSIDE
    return inside


def _barycentric(q, corners):
    a, b, c = corners
    v0, v1, v2 = b - a, c - a, q - a
    d00, d01, d11 = v0 @ v0, v0 @ v1, v1 @ v1
    d20, d21 = v2 @ v0, v2 @ v1
    den = d00 * d11 - d01 * d01
    v = (d11 * d20 - d01 * d21) / den
    w = (d00 * d21 - d01 * d20) / den
    return np.array([1.0 - v - w, v, w])


def unit_poses(starts, ends):
    """4x4 poses placing FCL's z-aligned, centred capsule on each unit."""
    axis = ends - starts
    length = np.linalg.norm(axis, axis=1, keepdims=True)
    d = np.where(length > 0, axis / np.where(length > 0, length, 1.0), [0.0, 0.0, 1.0])
    c = d[:, 2]
    v = np.stack([-d[:, 1], d[:, 0], np.zeros(len(d))], axis=1)     # z x d
    k = np.zeros((len(d), 3, 3))
    k[:, 0, 1], k[:, 0, 2], k[:, 1, 2] = -v[:, 2], v[:, 1], -v[:, 0]
    k -= np.transpose(k, (0, 2, 1))
    flipped = c < -1.0 + 1e-12
    scale = np.where(flipped, 0.0, 1.0 / np.where(flipped, 1.0, 1.0 + c))
    rot = np.eye(3) + k + np.einsum("kij,kjl->kil", k, k) * scale[:, None, None]
    rot[flipped] = np.diag([1.0, -1.0, -1.0])
    poses = np.tile(np.eye(4), (len(d), 1, 1))
    poses[:, :3, :3] = rot
    poses[:, :3, 3] = 0.5 * (starts + ends)
    return poses


# -- yes / no ---------------------------------------------------------------------
def collide(body_a, poses_a, body_b, poses_b):
    """Do two bodies touch at each of E placements ``poses_a``, ``poses_b`` (E, 4, 4)?

    Returns ``(touching, contained)``, two (E,) bool arrays: ``contained`` marks
    contacts only the containment test saw (FCL reports no crossing). Chain
    pairs are decided analytically for all placements at once; mesh pairs call
    FCL once per placement (and per nearby unit), with everything around those
    calls batched.
    """
    if body_a.kind == "chain" and body_b.kind == "chain":
        gap = chain_gaps(body_a.chain, body_b.chain, relative(poses_a, poses_b), 0.0)[0]
        return gap <= 0.0, np.zeros(len(gap), bool)
    if body_a.kind == "chain":
        body_a, poses_a, body_b, poses_b = body_b, poses_b, body_a, poses_a
    rel = relative(poses_a, poses_b)
    touching = (_mesh_mesh if body_b.kind == "mesh" else _mesh_chain)(body_a, body_b, rel)
    contained = np.zeros(len(rel), bool)
    apart = (~touching).nonzero()[0]
    # no boundaries cross: one solid is inside the other exactly when a probe is
    if apart.size:
        contained[apart] = _inside(body_a, body_b, rel[apart])
        rest = apart[~contained[apart]]
        if body_b.kind == "mesh" and rest.size:
            contained[rest] = _inside(body_b, body_a, relative(rel[rest], np.repeat(
                _EYE[None], rest.size, axis=0)))      # the inverses (no broadcasting: slow)
    return touching | contained, contained


_EYE = np.eye(4)


def _inside(mesh_body, other, rel):
    """Whether ``other``, placed by each of ``rel`` (E, 4, 4) in the mesh's frame and
    touching no triangle, lies inside the mesh.

    Its probe is tested against the mesh only where it lies in the mesh's box and
    the other body's extreme points all fit the mesh's own 18-DOP (a solid inside
    another lies inside the other's hull).
    """
    if not mesh_body.closed:                                                  # a Surface
        return np.zeros(len(rel), bool)
    lo, hi, low, high, slack = mesh_body.inside_filter
    near = np.empty(len(rel), np.bool_)
    _could_be_inside(rel, other.probes, other.extremes, lo, hi, low, high, slack, near)
    if not near.any():
        return near
    near = near.nonzero()[0]
    inside = np.zeros(len(rel), bool)
    points = _apply(rel[near], other.probes)                                  # (e, K, 3)
    found = mesh_contains(mesh_body, points.reshape(-1, 3))
    inside[near] = found.reshape(len(near), points.shape[1]).any(axis=1)
    return inside


@_jit
def _could_be_inside(rel, probes, extremes, lo, hi, low, high, slack, out):
    """``out[e]``: some probe lies in the box ``lo``, ``hi`` and every extreme point
    within the 18-DOP ``low``, ``high`` (+- ``slack``), all moved by ``rel[e]``."""
    for e in range(len(rel)):
        m = rel[e]
        in_box = False
        for k in range(len(probes)):
            inside = True
            for r in range(3):
                v = m[r, 0] * probes[k, 0] + m[r, 1] * probes[k, 1] + m[r, 2] * probes[k, 2] \
                    + m[r, 3]
                inside = inside and lo[r] <= v <= hi[r]
            in_box = in_box or inside
        fits = in_box
        for k in range(len(extremes)):
            if not fits:
                break
            x = np.empty(3)
            for r in range(3):
                x[r] = m[r, 0] * extremes[k, 0] + m[r, 1] * extremes[k, 1] \
                    + m[r, 2] * extremes[k, 2] + m[r, 3]
            for d in range(9):
                v = KDOP_DIRECTIONS[d, 0] * x[0] + KDOP_DIRECTIONS[d, 1] * x[1] \
                    + KDOP_DIRECTIONS[d, 2] * x[2]
                fits = fits and low[d] - slack <= v <= high[d] + slack
        out[e] = fits


@cache
def _yes_no():
    """FCL's request for a plain yes/no answer (one contact, no contact data)."""
    import fcl

    return fcl.CollisionRequest(num_max_contacts=1, enable_contact=False)


def _mesh_mesh(body_a, body_b, rel):
    import fcl

    request = _yes_no()
    anchor, mover = body_a.fcl_anchor, body_b.fcl_mover
    touching = np.zeros(len(rel), bool)
    for e, pose in enumerate(rel):
        mover.setTransform(_transform(pose))
        touching[e] = fcl.collide(anchor, mover, request, fcl.CollisionResult()) > 0
    return touching


def _near_units(mesh_body, chain_body, rel):
    """``(entry, unit)`` index pairs whose unit's bounding ball reaches the mesh's
    box, entry by entry, with each unit's FCL pose in the mesh's frame."""
    centre, radius = chain_body.chain.unit_spheres
    lo, hi = mesh_body.mesh.bounds
    entry = np.empty(len(rel) * len(centre), np.int64)
    unit = np.empty(len(entry), np.int64)
    found = _balls_reaching_box(rel, centre, radius, lo, hi, entry, unit)
    entry, unit = entry[:found], unit[:found]
    return entry, unit, rel[entry] @ chain_body.fcl_units[1][unit]


@_jit
def _balls_reaching_box(rel, centre, radius, lo, hi, entry, unit):
    """Write the (entry, ball) pairs whose ball, moved by ``rel[entry]``, reaches the
    box ``lo``, ``hi``; returns how many."""
    count = 0
    for e in range(len(rel)):
        m = rel[e]
        for u in range(len(centre)):
            gap = 0.0
            for r in range(3):
                v = m[r, 0] * centre[u, 0] + m[r, 1] * centre[u, 1] + m[r, 2] * centre[u, 2] \
                    + m[r, 3]
                out = v - min(max(v, lo[r]), hi[r])
                gap += out * out
            if gap <= radius[u] * radius[u]:
                entry[count], unit[count] = e, u
                count += 1
    return count


def _mesh_chain(mesh_body, chain_body, rel):
    import fcl

    request = _yes_no()
    objects = chain_body.fcl_units[0]
    touching = np.zeros(len(rel), bool)
    for e, unit, pose in zip(*_near_units(mesh_body, chain_body, rel)):
        if touching[e]:
            continue
        objects[unit].setTransform(_transform(pose))
        touching[e] = fcl.collide(mesh_body.fcl_anchor, objects[unit], request,
                                  fcl.CollisionResult()) > 0
    return touching


# -- clearance ----------------------------------------------------------------------
def distance(body_a, pose_a, body_b, pose_b, containment=True):
    """``(distance, point_a, point_b, decided_by)`` in world coordinates.

    Distance 0 (and no points) when the bodies touch or (``containment``) one
    contains the other.
    """
    if body_a.kind == "chain" and body_b.kind == "chain":
        gap, pa, pb = body_a.chain.gap(body_b.chain, relative(pose_a, pose_b))
        if gap <= 0:
            return 0.0, None, None, "analytic"
        return gap, _apply(pose_a, pa[None])[0], _apply(pose_a, pb[None])[0], "analytic"
    swap = body_a.kind == "chain"
    if swap:
        body_a, pose_a, body_b, pose_b = body_b, pose_b, body_a, pose_a
    rel = relative(pose_a, pose_b)
    if body_b.kind == "mesh":
        body_b.fcl_mover.setTransform(_transform(rel))
        dist, pa, pb = _fcl_distance(body_a.fcl_anchor, body_b.fcl_mover)
    else:
        dist, pa, pb = _mesh_chain_distance(body_a, body_b, rel)
    decided = "fcl"
    if containment and dist > 0 and collide(body_a, _EYE[None], body_b, rel[None])[0][0]:
        dist, pa, pb, decided = 0.0, None, None, "containment"
    if dist <= 0:
        return 0.0, None, None, decided
    pa, pb = _apply(pose_a, np.stack([pa, pb]))
    return (dist, pb, pa, decided) if swap else (dist, pa, pb, decided)


def _transform(pose):
    import fcl

    return fcl.Transform(pose[:3, :3], pose[:3, 3])


def _fcl_distance(object_a, object_b):
    import fcl

    result = fcl.DistanceResult()
    dist = fcl.distance(object_a, object_b, fcl.DistanceRequest(enable_nearest_points=True),
                        result)
    return dist, np.array(result.nearest_points[0]), np.array(result.nearest_points[1])


def _mesh_chain_distance(mesh_body, chain_body, rel):
    """Smallest FCL distance from the mesh to a chain unit, units visited nearest
    box first and stopped once no remaining unit's box can be closer.

    FCL reports the mesh's nearest point reliably (in the mesh's frame); the
    chain's is recomputed as the unit surface point facing it.
    """
    chain = chain_body.chain.moved(rel)
    lo, hi = mesh_body.mesh.bounds
    ub = chain.unit_bounds
    lower = np.linalg.norm(np.maximum(np.maximum(lo - ub[:, 1], ub[:, 0] - hi), 0.0), axis=1)
    order = np.argsort(lower, kind="stable")
    objects, local = chain_body.fcl_units
    best, best_unit = (np.inf, None, None), None
    for unit in order:
        if lower[unit] >= best[0]:
            break
        objects[unit].setTransform(_transform(rel @ local[unit]))
        found = _fcl_distance(mesh_body.fcl_anchor, objects[unit])
        if found[0] < best[0]:
            best, best_unit = found, unit
        if best[0] <= 0:
            break
    dist, mesh_point = best[0], best[1]
    if dist <= 0:
        return dist, None, None
    a, b = chain.starts[best_unit], chain.ends[best_unit]
    axis = b - a
    t = np.clip(np.dot(mesh_point - a, axis) / max(np.dot(axis, axis), 1e-300), 0.0, 1.0)
    centre = a + t * axis
    towards = mesh_point - centre
    return dist, mesh_point, mesh_point - dist * towards / np.linalg.norm(towards)
