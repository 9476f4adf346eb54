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

import numba
import numpy as np

from cadpipe.collision import chain_mesh
from cadpipe.collision.bounds import KDOP_DIRECTIONS
from cadpipe.collision.hierarchy import chain_gaps, walk_trees

#: stage codes of the exact phase (indices into ``world.STAGES``)
FCL, CONTAINMENT, ANALYTIC = 6, 7, 8
#: what :func:`settle` returns for a pair it leaves to the Python narrow phase
UNSETTLED = -1
#: room for tapered unit pairs in :func:`settle`'s chain walk (more: left to Python)
_LEFT = 64

# One pose of one pair costs a few of these compiled loops instead of ~40 numpy calls
# on (1, 4, 4) arrays (per-state figures in docs/performance.md).
_jit = numba.njit(cache=True, nogil=True)


def relative(pose_a, pose_b):
    """Poses of b in a's frame, ``inv(pose_a) @ pose_b``, vectorized over leading axes
    (rigid poses: the inverse is the transposed rotation)."""
    pose_a, pose_b = np.asarray(pose_a, np.float64), np.asarray(pose_b, np.float64)
    if pose_a.shape != pose_b.shape:          # own copies: numba warns on broadcast views
        shape = np.broadcast_shapes(pose_a.shape, pose_b.shape)
        pose_a, pose_b = (np.broadcast_to(p, shape).copy() for p in (pose_a, pose_b))
    out = np.empty(pose_a.shape)
    relative_into(pose_a.reshape(-1, 4, 4), pose_b.reshape(-1, 4, 4), out.reshape(-1, 4, 4))
    return out


@_jit
def relative_into(pose_a, pose_b, out):
    """:func:`relative` of (E, 4, 4) poses into ``out`` (E, 4, 4), compiled."""
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
    _could_be_inside(rel, other.probes, other.extremes, lo, hi, low, high, slack, near)
    if not near.any():
        return near
    near = near.nonzero()[0]
    inside = np.zeros(len(rel), bool)
    points = _apply(rel[near], other.probes)                                  # (e, K, 3)
    found = mesh_body.mesh.contains(points.reshape(-1, 3))
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
            e0, e1, e2 = extremes[k, 0], extremes[k, 1], extremes[k, 2]
            x0 = m[0, 0] * e0 + m[0, 1] * e1 + m[0, 2] * e2 + m[0, 3]
            x1 = m[1, 0] * e0 + m[1, 1] * e1 + m[1, 2] * e2 + m[1, 3]
            x2 = m[2, 0] * e0 + m[2, 1] * e1 + m[2, 2] * e2 + m[2, 3]
            for d in range(9):
                v = KDOP_DIRECTIONS[d, 0] * x0 + KDOP_DIRECTIONS[d, 1] * x1 \
                    + KDOP_DIRECTIONS[d, 2] * x2
                fits = fits and low[d] - slack <= v <= high[d] + slack
        out[e] = fits


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
@_jit
def settle(w, i, pose_i, j, pose_j, rel):
    """:func:`collide` of objects ``i`` and ``j`` of the packed world ``w``
    (:class:`~cadpipe.collision.packed.Packed`) at poses ``pose_i``, ``pose_j``
    (1, 4, 4), compiled: ``(code, touching)``, the code :data:`ANALYTIC` (two
    chains), :data:`FCL` (a chain and a mesh) or :data:`UNSETTLED` for what is
    left to :func:`collide`: two meshes (FCL), a chain that may lie inside a
    mesh (the probe test), tapered unit pairs the walk does not settle (the
    exact round-cone gap), a mesh whose triangle tree is not packed. ``rel``
    (1, 4, 4) is scratch. The same walks on the same relative pose as
    :func:`collide`, so the same answers.
    """
    if w.chain[i] and w.chain[j]:
        relative_into(pose_i, pose_j, rel)
        gap, units, params = np.empty(1), np.empty((1, 2), np.int64), np.empty((1, 2))
        left = np.empty((_LEFT, 3), np.int64)
        count = walk_trees(w.tree_table[w.tree_at[i]:w.tree_at[i + 1]],
                           w.tree_index[w.tree_at[i]:w.tree_at[i + 1]], w.tree_depth[i],
                           w.tree_points[w.tree_points_at[j]:w.tree_points_at[j + 1]],
                           w.tree_table[w.tree_at[j]:w.tree_at[j + 1]],
                           w.tree_index[w.tree_at[j]:w.tree_at[j + 1]], w.tree_depth[j], rel,
                           0.0, True, gap, units, params, left)
        if count < 0 or (count > 0 and gap[0] > 0.0):   # the round cones decide: Python
            return UNSETTLED, False
        return ANALYTIC, gap[0] <= 0.0
    if not (w.chain[i] or w.chain[j]):
        return UNSETTLED, False
    mesh, other = (j, i) if w.chain[i] else (i, j)
    if w.boxes_at[mesh] == w.boxes_at[mesh + 1]:         # no triangle tree packed
        return UNSETTLED, False
    if w.chain[i]:
        relative_into(pose_j, pose_i, rel)
    else:
        relative_into(pose_i, pose_j, rel)
    gap, unit, near, far = np.empty(1), np.empty(1, np.int64), np.empty((1, 3)), \
        np.empty((1, 3))
    chain_mesh.walk(w.mesh_boxes[w.boxes_at[mesh]:w.boxes_at[mesh + 1]],
                    w.mesh_frames[w.frames_at[mesh]:w.frames_at[mesh + 1]],
                    w.mesh_triangles[w.triangles_at[mesh]:w.triangles_at[mesh + 1]],
                    w.mesh_depth[mesh], w.tree_table[w.tree_at[other]:w.tree_at[other + 1]],
                    w.tree_index[w.tree_at[other]:w.tree_at[other + 1]],
                    w.tree_points[w.tree_points_at[other]:w.tree_points_at[other + 1]],
                    w.tree_depth[other], rel, True, gap, unit, near, far)
    if gap[0] <= 0.0:
        return FCL, True
    if not w.closed[mesh]:
        return FCL, False
    inside = np.empty(1, np.bool_)
    _could_be_inside(rel, w.probes[w.probes_at[other]:w.probes_at[other + 1]],
                     w.extremes[other], w.inside_lo[mesh], w.inside_hi[mesh],
                     w.inside_low[mesh], w.inside_high[mesh], w.inside_slack[mesh], inside)
    return (UNSETTLED, False) if inside[0] else (FCL, False)


def packed_arrays(bodies, near_chain):
    """The arrays of :func:`settle` for every body (fields of
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
