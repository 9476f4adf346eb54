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

import numpy as np

from .capsules import BATCH

#: a winding number above this is "inside" (it is 1 inside a closed outward mesh)
INSIDE = 0.5


def _relative(pose_a, pose_b):
    """Pose of b in a's frame."""
    inv = np.eye(4)
    inv[:3, :3] = pose_a[:3, :3].T
    inv[:3, 3] = -pose_a[:3, :3].T @ pose_a[:3, 3]
    return inv @ pose_b


def _apply(matrix, points):
    return points @ matrix[:3, :3].T + matrix[:3, 3]


def winding_numbers(triangles, points):
    """Generalized winding number of a closed triangle soup at each point.

    The sum of the signed solid angles of the triangles seen from the point
    (Van Oosterom and Strackee's formula) over 4 pi: 1 inside a closed outward
    mesh, 0 outside. Vectorized over triangles, batched over points.
    """
    points = np.asarray(points, np.float64)
    out = np.empty(len(points))
    step = max(1, BATCH // max(len(triangles), 1))
    for start in range(0, len(points), step):
        rel = triangles[None] - points[start:start + step, None, None, :]
        a, b, c = rel[:, :, 0], rel[:, :, 1], rel[:, :, 2]
        la, lb, lc = (np.linalg.norm(x, axis=-1) for x in (a, b, c))
        det = np.einsum("pfi,pfi->pf", a, np.cross(b, c))
        den = (la * lb * lc + np.einsum("pfi,pfi->pf", a, b) * lc
               + np.einsum("pfi,pfi->pf", b, c) * la + np.einsum("pfi,pfi->pf", c, a) * lb)
        out[start:start + step] = np.arctan2(det, den).sum(axis=1) / (2.0 * np.pi)
    return out


def mesh_contains(body, points):
    """Which ``(P, 3)`` points (in the mesh's frame) lie inside the closed mesh body."""
    points = np.asarray(points, np.float64)
    lo, hi = body.mesh.bounds
    inside = np.all((points >= lo) & (points <= hi), axis=1)
    if inside.any():
        inside[inside] = winding_numbers(body.mesh.triangles, points[inside]) > INSIDE
    return inside


def _fcl_object(geometry, pose=None):
    import fcl

    if pose is None:
        return fcl.CollisionObject(geometry, fcl.Transform())
    return fcl.CollisionObject(geometry, fcl.Transform(pose[:3, :3], pose[:3, 3]))


def _unit_poses(starts, ends):
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


def _units_near(chain, lo, hi):
    """Units whose boxes overlap the box ``[lo, hi]``."""
    ub = chain.unit_bounds
    return np.flatnonzero(np.all((ub[:, 0] <= hi) & (ub[:, 1] >= lo), axis=1))


# -- yes / no ---------------------------------------------------------------------
def collide(body_a, pose_a, body_b, pose_b):
    """``(touching, decided_by)`` for two placed bodies; decided_by is
    ``"analytic"``, ``"fcl"`` or ``"containment"``."""
    if body_a.kind == "chain" and body_b.kind == "chain":
        gap = body_a.chain.moved(pose_a).gap(body_b.chain.moved(pose_b), stop_below=0.0)[0]
        return gap <= 0.0, "analytic"
    if body_a.kind == "chain":
        body_a, pose_a, body_b, pose_b = body_b, pose_b, body_a, pose_a
    rel = _relative(pose_a, pose_b)
    if body_b.kind == "mesh":
        return _mesh_mesh(body_a, body_b, rel)
    return _mesh_chain(body_a, body_b, rel)


def _mesh_mesh(body_a, body_b, rel):
    import fcl

    request = fcl.CollisionRequest(num_max_contacts=1, enable_contact=False)
    if fcl.collide(_fcl_object(body_a.fcl_geometry), _fcl_object(body_b.fcl_geometry, rel),
                   request, fcl.CollisionResult()):
        return True, "fcl"
    if mesh_contains(body_a, _apply(rel, body_b.probes)).any():
        return True, "containment"
    inv = _relative(rel, np.eye(4))
    if mesh_contains(body_b, _apply(inv, body_a.probes)).any():
        return True, "containment"
    return False, "fcl"


def _mesh_chain(mesh_body, chain_body, rel):
    import fcl

    chain = chain_body.chain.moved(rel)
    near = _units_near(chain, *mesh_body.mesh.bounds)
    if near.size:
        mesh_object = _fcl_object(mesh_body.fcl_geometry)
        request = fcl.CollisionRequest(num_max_contacts=1, enable_contact=False)
        poses = _unit_poses(chain.starts[near], chain.ends[near])
        for unit, pose in zip(near, poses):
            if fcl.collide(mesh_object, _fcl_object(chain_body.fcl_units[unit], pose), request,
                           fcl.CollisionResult()):
                return True, "fcl"
    if mesh_contains(mesh_body, chain.centers[:1]).any():
        return True, "containment"
    return False, "fcl"


# -- clearance ----------------------------------------------------------------------
def distance(body_a, pose_a, body_b, pose_b):
    """``(distance, point_a, point_b, decided_by)`` in world coordinates.

    Distance 0 (and no points) when the bodies touch or one contains the other.
    """
    if body_a.kind == "chain" and body_b.kind == "chain":
        gap, pa, pb = body_a.chain.moved(pose_a).gap(body_b.chain.moved(pose_b))
        if gap <= 0:
            return 0.0, None, None, "analytic"
        return gap, pa, pb, "analytic"
    swap = body_a.kind == "chain"
    if swap:
        body_a, pose_a, body_b, pose_b = body_b, pose_b, body_a, pose_a
    rel = _relative(pose_a, pose_b)
    if body_b.kind == "mesh":
        dist, pa, pb = _mesh_mesh_distance(body_a, body_b, rel)
    else:
        dist, pa, pb = _mesh_chain_distance(body_a, body_b, rel)
    decided = "fcl"
    if dist > 0 and collide(body_a, np.eye(4), body_b, rel)[0]:
        dist, pa, pb, decided = 0.0, None, None, "containment"
    if dist <= 0:
        return 0.0, None, None, decided
    pa, pb = _apply(pose_a, pa), _apply(pose_a, pb)
    return (dist, pb, pa, decided) if swap else (dist, pa, pb, decided)


def _fcl_distance(object_a, object_b):
    import fcl

    result = fcl.DistanceResult()
    dist = fcl.distance(object_a, object_b, fcl.DistanceRequest(enable_nearest_points=True),
                        result)
    return dist, np.array(result.nearest_points[0]), np.array(result.nearest_points[1])


def _mesh_mesh_distance(body_a, body_b, rel):
    """FCL's BVH distance; both nearest points in a's frame."""
    return _fcl_distance(_fcl_object(body_a.fcl_geometry), _fcl_object(body_b.fcl_geometry, rel))


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
    poses = _unit_poses(chain.starts, chain.ends)
    mesh_object = _fcl_object(mesh_body.fcl_geometry)
    best, best_unit = (np.inf, None, None), None
    for unit in order:
        if lower[unit] >= best[0]:
            break
        found = _fcl_distance(mesh_object, _fcl_object(chain_body.fcl_units[unit], poses[unit]))
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
