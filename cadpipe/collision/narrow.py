"""The exact narrow phase: does a pair touch, and how far apart is it?

* mesh vs mesh: FCL's BVH traversal (the engine trimesh uses) finds crossing
  triangles. It never sees one closed mesh wholly inside another -- no triangles
  cross -- so when it reports no contact, one probe point per connected piece
  of each mesh is tested against the other with the generalized winding number
  (:meth:`~cadpipe.Mesh.contains`: a ray through the mesh's box tree, built once
  per mesh and kept with it).
* chain vs chain: :mod:`cadpipe.collision.capsules`, in closed form.
* chain vs mesh: the chain's capsule tree against a box tree of the mesh's
  triangles, one compiled walk (:mod:`cadpipe.collision.chain_mesh`; a unit
  lying inside the mesh is caught by the probe test, a mesh inside a unit by
  the walk, which treats the capsule as solid).

Every pair is evaluated in the mesh's own frame, so a BVH is built once per
body and never refitted. Touching counts as contact.
"""

from functools import cache

import numpy as np

from cadpipe.collision import chain_mesh
from cadpipe.collision.hierarchy import chain_gaps
from cadpipe.core.kernels import native
from cadpipe.core.transform import relative

#: stage codes of the exact phase (indices into ``reports.STAGES``)
FCL, CONTAINMENT, ANALYTIC = 6, 7, 8
#: what the compiled settle returns for a pair it leaves to the Python narrow phase
UNSETTLED = -1

_C = native.collision_constants()
if (_C["FCL"], _C["CONTAINMENT"], _C["ANALYTIC"], _C["UNSETTLED"]) != \
        (FCL, CONTAINMENT, ANALYTIC, UNSETTLED):
    raise ImportError("cadpipe's narrow-phase kernels were built with other stage codes "
                      "than cadpipe.collision.narrow holds")


def _apply(matrix, points):
    """Points (..., K, 3) moved by matrices (..., 4, 4)."""
    return points @ matrix[..., :3, :3].swapaxes(-1, -2) + matrix[..., None, :3, 3]


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
    touching = _mesh_mesh(body_a, body_b, rel) if body_b.kind == "mesh" else \
        _mesh_chain(body_a, body_b, rel, True)[0] <= 0.0
    contained = np.zeros(len(rel), bool)
    apart = (~touching).nonzero()[0]
    if apart.size:
        contained[apart] = _contained(body_a, body_b, rel[apart])
    return touching | contained, contained


def _contained(mesh_body, other, rel):
    """(E,) whether, at each of ``rel`` (E, 4, 4) where no boundaries cross, one solid
    lies inside the other: exactly when a probe does."""
    contained = _inside(mesh_body, other, rel)
    rest = (~contained).nonzero()[0]
    if other.kind == "mesh" and rest.size:
        contained[rest] = _inside(other, mesh_body, relative(rel[rest], _EYE))
    return contained


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
    native.could_be_inside(*(np.ascontiguousarray(v, np.float64) for v in (
        rel, other.probes, other.extremes, lo, hi, low, high)), float(slack), near)
    if not near.any():
        return near
    near = near.nonzero()[0]
    inside = np.zeros(len(rel), bool)
    points = _apply(rel[near], other.probes)                                  # (e, K, 3)
    found = mesh_body.mesh.contains(points.reshape(-1, 3))
    inside[near] = found.reshape(len(near), points.shape[1]).any(axis=1)
    return inside


@cache
def _yes_no():
    """FCL's request for a plain yes/no answer (one contact, no contact data)."""
    import fcl

    return fcl.CollisionRequest(num_max_contacts=1, enable_contact=False)


def _mesh_mesh(body_a, body_b, rel):
    return np.array([_fcl_touch(body_a, body_b, pose) for pose in rel], bool)


def _fcl_touch(body_a, body_b, rel):
    """Whether FCL finds the meshes' triangles touching, b at ``rel`` (4, 4) in a's
    frame."""
    import fcl

    mover = body_b.fcl_mover
    mover.setTransform(_transform(rel))
    return fcl.collide(body_a.fcl_anchor, mover, _yes_no(), fcl.CollisionResult()) > 0


def mesh_pair(body_a, body_b, rel):
    """:func:`collide` of two meshes at one relative pose ``rel`` (4, 4), b's pose in
    a's frame: ``(touching, contained)``, two bools. What a single state asks of the
    pairs its funnel kernel leaves, without the batch's array handling."""
    if _fcl_touch(body_a, body_b, rel):
        return True, False
    contained = bool(_contained(body_a, body_b, rel[None])[0])
    return contained, contained


def _mesh_chain(mesh_body, chain_body, rel, yes_no):
    """:func:`cadpipe.collision.chain_mesh.walk` of the chain at each of ``rel``
    (E, 4, 4) in the mesh's frame: ``(gap, unit, point on the unit's axis, point on
    the mesh)``, the points in the mesh's frame."""
    mesh, chain = mesh_body.triangle_tree, chain_body.chain.tree
    count = len(rel)
    gap, unit = np.empty(count), np.empty(count, np.int64)
    near, far = np.full((count, 3), np.nan), np.full((count, 3), np.nan)
    chain_mesh.walk(mesh.boxes, mesh.frames, mesh.triangles, mesh.depth, chain.table,
                    chain.index, chain.points, chain.depth, np.ascontiguousarray(rel), yes_no,
                    gap, unit, near, far)
    return gap, unit, near, far


# -- yes / no, one pose, compiled ------------------------------------------------------
# ``settle`` (csrc/narrow.c) is :func:`collide` of one pair of a packed world at one pose,
# inside the kernels a state or a pose calls (``native.refresh``, ``native.collide_pose``):
# the code ANALYTIC (two chains), FCL (a chain and a mesh) or UNSETTLED for what is left to
# :func:`collide`: two meshes (FCL), a chain that may lie inside a mesh (the probe test),
# tapered unit pairs the walk does not settle (the exact round-cone gap), a mesh whose
# triangle tree is not packed. The same walks on the same relative pose as :func:`collide`,
# so the same answers.


def packed_arrays(bodies, near_chain):
    """The arrays of the compiled settle for every body (fields of
    :data:`cadpipe.collision.packed.FIELDS`), concatenated: each chain's capsule
    tree, probes and extremes; each closed mesh marked in ``near_chain`` (N,)
    (paired with a chain) its triangle tree and containment prefilter."""
    n = len(bodies)
    trees = [b.chain.tree if b.kind == "chain" else None for b in bodies]
    meshes = [b.triangle_tree if b.kind == "mesh" and near else None
              for b, near in zip(bodies, near_chain)]
    empty = np.zeros((0, 3))
    probes = [b.probes if b.kind == "chain" else empty for b in bodies]
    extremes, lo, hi = np.zeros((n, 18, 3)), np.zeros((n, 3)), np.zeros((n, 3))
    low, high, slack = np.zeros((n, 9)), np.zeros((n, 9)), np.zeros(n)
    for k, body in enumerate(bodies):
        if body.kind == "chain":
            extremes[k] = body.extremes
        elif meshes[k] is not None and body.closed:
            lo[k], hi[k], low[k], high[k], slack[k] = body.inside_filter

    def joined(parts, width, dtype=np.float64):
        rows = [np.zeros((0, width)) if p is None else p for p in parts]
        return np.ascontiguousarray(np.concatenate(rows).reshape(-1, width), dtype), \
            np.r_[0, np.cumsum([len(p) for p in rows])].astype(np.int64)

    tree_table, tree_at = joined([t and t.table for t in trees], 10)
    tree_index, _ = joined([t and t.index for t in trees], 3, np.int64)
    tree_points, tree_points_at = joined([t and t.points for t in trees], 3)
    mesh_boxes, boxes_at = joined([m and m.boxes for m in meshes], 7)
    mesh_frames, frames_at = joined([m and m.frames for m in meshes], 15)
    mesh_triangles, triangles_at = joined([m and m.triangles for m in meshes], 9)
    probes, probes_at = joined(probes, 3)
    return {"tree_table": tree_table, "tree_index": tree_index, "tree_points": tree_points,
            "tree_at": tree_at, "tree_points_at": tree_points_at,
            "tree_depth": np.array([t.depth if t else 0 for t in trees], np.int64),
            "mesh_boxes": mesh_boxes, "mesh_frames": mesh_frames, "frames_at": frames_at,
            "mesh_triangles": mesh_triangles, "boxes_at": boxes_at,
            "triangles_at": triangles_at,
            "mesh_depth": np.array([m.depth if m else 0 for m in meshes], np.int64),
            "probes": probes, "probes_at": probes_at, "extremes": extremes, "inside_lo": lo,
            "inside_hi": hi, "inside_low": low, "inside_high": high, "inside_slack": slack}


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
    if containment and dist > 0 and _contained(body_a, body_b, rel[None])[0]:
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
    """Exact distance from the mesh to the chain's capsules at ``rel`` (4, 4) (one
    walk), the mesh's nearest point and the capsule surface point facing it, in
    the mesh's frame."""
    gap, _, axis_point, mesh_point = (v[0] for v in _mesh_chain(mesh_body, chain_body,
                                                                 rel[None], False))
    if gap <= 0:
        return float(gap), None, None
    towards = mesh_point - axis_point
    return float(gap), mesh_point, mesh_point - gap * towards / np.linalg.norm(towards)
