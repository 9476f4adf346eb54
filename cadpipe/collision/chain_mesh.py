"""Chains against meshes: a pipe's capsule tree walked against a box tree of a mesh's
triangles, one compiled call for one pose or for thousands.

Each chain unit is taken as the capsule of its larger end radius (exact for the
untapered units of a pipe of one radius, a little larger for a tapered one: the
model FCL's capsules gave this pair before). The mesh's triangles, ordered along
a Morton curve of their centroids, are the leaves of a perfect binary tree of
axis-aligned boxes (:class:`TriangleTree`, built once per mesh); the chain's
nodes are :class:`~cadpipe.collision.hierarchy.CapsuleTree`'s, whose chords move
with the pose and whose boxes are the chords' boxes widened by the outer radius.
Both trees are walked in lockstep, depth first, the nearer pair of children
first; a node pair is dropped when its boxes are farther apart than the best gap
found (a yes/no query: than 0). A leaf pair is a capsule against a triangle: the
exact distance from the unit's axis to the triangle (0 where the axis pierces
it; otherwise the least of the axis' ends to the triangle and the axis to the
triangle's edges) less the radius.

Containment (a unit wholly inside the mesh, or the mesh inside a unit) is not
seen by the walk; :func:`cadpipe.collision.narrow.collide` adds it.
"""

import numba
import numpy as np

from cadpipe.collision.bounds import box_levels
from cadpipe.collision.convex import nearest_on_triangle
from cadpipe.collision.hierarchy import move_points

_jit = numba.njit(cache=True, nogil=True)


class TriangleTree:
    """Boxes over a mesh's triangles, in the mesh's frame.

    Parameters
    ----------
    vertices : (V, 3) float
    faces : (F, 3) int

    A perfect binary tree in heap order over the triangles sorted along a Morton
    curve: ``boxes`` (nodes, 6) holds each node's ``lo``, ``hi``; leaf ``k`` (at
    depth ``depth``) holds triangle ``order[k]`` or none (-1); ``triangles``
    (leaves, 9) the leaves' corners, row by row.
    """

    def __init__(self, vertices, faces):
        corners = np.asarray(vertices, np.float64)[np.asarray(faces)]        # (F, 3, 3)
        count = len(corners)
        centroid = corners.mean(axis=1)
        lo, hi = centroid.min(axis=0), centroid.max(axis=0)
        cell = np.floor((centroid - lo) / np.maximum(hi - lo, 1e-300) * 1023.0).astype(np.int64)
        code = np.zeros(count, np.int64)
        for bit in range(10):                   # interleave the 10 bits of each axis
            for axis in range(3):
                code |= ((cell[:, axis] >> bit) & 1) << (3 * bit + axis)
        order = np.argsort(code, kind="stable")
        self.depth = int(np.ceil(np.log2(count))) if count > 1 else 0
        leaves = 2 ** self.depth
        self.order = np.full(leaves, -1, np.int64)
        self.order[:count] = order
        self.triangles = np.zeros((leaves, 9))
        self.triangles[:count] = corners[order].reshape(count, 9)
        low, high = np.full((leaves, 3), np.inf), np.full((leaves, 3), -np.inf)
        low[:count], high[:count] = corners[order].min(axis=1), corners[order].max(axis=1)
        lo, hi = box_levels(low, high)
        self.boxes = np.ascontiguousarray(np.concatenate([lo, hi], axis=1))


@_jit
def _closest_on_triangle(p, t):
    """The point of triangle ``t`` (9,) nearest to ``p``, as three coordinates
    (:func:`cadpipe.collision.convex.nearest_on_triangle`, about ``p``)."""
    x, y, z, _ = nearest_on_triangle(t[0] - p[0], t[1] - p[1], t[2] - p[2], t[3] - p[0],
                                     t[4] - p[1], t[5] - p[2], t[6] - p[0], t[7] - p[1],
                                     t[8] - p[2])
    return x + p[0], y + p[1], z + p[2]


@_jit
def _segments_closest(p, u, q, v):
    """Parameters ``(s, t)`` of the closest points of ``p + s u`` and ``q + t v``
    (as :func:`cadpipe.collision.capsules.segment_params`)."""
    rx, ry, rz = p[0] - q[0], p[1] - q[1], p[2] - q[2]
    uu = u[0] * u[0] + u[1] * u[1] + u[2] * u[2]
    vv = v[0] * v[0] + v[1] * v[1] + v[2] * v[2]
    uv = u[0] * v[0] + u[1] * v[1] + u[2] * v[2]
    ur = u[0] * rx + u[1] * ry + u[2] * rz
    vr = v[0] * rx + v[1] * ry + v[2] * rz
    tiny = np.finfo(np.float64).tiny
    inv_uu = 1.0 / uu if uu > tiny else 0.0
    inv_vv = 1.0 / vv if vv > tiny else 0.0
    square = uu * vv
    den = square - uv * uv
    s = 0.0
    if den > 1e-14 * square:
        s = min(max((uv * vr - ur * vv) / max(den, 1e-300), 0.0), 1.0)
    t = min(max((uv * s + vr) * inv_vv, 0.0), 1.0)
    s = min(max((uv * t - ur) * inv_uu, 0.0), 1.0)
    return s, t


@_jit
def segment_triangle(a, b, t, near, far):
    """Distance from segment ``a``-``b`` (3,) to triangle ``t`` (9,), with the
    closest points written to ``near`` (on the segment) and ``far`` (on the
    triangle). 0 where the segment pierces the triangle."""
    u = b - a
    # pierced: the segment crosses the triangle's plane inside the triangle
    e1 = np.array([t[3] - t[0], t[4] - t[1], t[5] - t[2]])
    e2 = np.array([t[6] - t[0], t[7] - t[1], t[8] - t[2]])
    n = np.cross(e1, e2)
    da = n[0] * (a[0] - t[0]) + n[1] * (a[1] - t[1]) + n[2] * (a[2] - t[2])
    db = n[0] * (b[0] - t[0]) + n[1] * (b[1] - t[1]) + n[2] * (b[2] - t[2])
    if (da <= 0 <= db or db <= 0 <= da) and da != db:
        x = a + (da / (da - db)) * u
        cx, cy, cz = _closest_on_triangle(x, t)
        if (cx - x[0]) ** 2 + (cy - x[1]) ** 2 + (cz - x[2]) ** 2 <= 1e-30 * (
                1.0 + x[0] * x[0] + x[1] * x[1] + x[2] * x[2]):
            near[:] = x
            far[0], far[1], far[2] = cx, cy, cz
            return 0.0
    best = np.inf
    for k in range(2):                           # the segment's ends against the triangle
        p = a if k == 0 else b
        cx, cy, cz = _closest_on_triangle(p, t)
        d = np.sqrt((cx - p[0]) ** 2 + (cy - p[1]) ** 2 + (cz - p[2]) ** 2)
        if d < best:
            best = d
            near[:] = p
            far[0], far[1], far[2] = cx, cy, cz
    for k in range(3):                           # the segment against each edge
        q = t[3 * k:3 * k + 3]
        r = t[3 * ((k + 1) % 3):3 * ((k + 1) % 3) + 3]
        v = r - q
        s, w = _segments_closest(a, u, q, v)
        px, py, pz = a[0] + s * u[0], a[1] + s * u[1], a[2] + s * u[2]
        qx, qy, qz = q[0] + w * v[0], q[1] + w * v[1], q[2] + w * v[2]
        d = np.sqrt((px - qx) ** 2 + (py - qy) ** 2 + (pz - qz) ** 2)
        if d < best:
            best = d
            near[0], near[1], near[2] = px, py, pz
            far[0], far[1], far[2] = qx, qy, qz
    return best


@_jit
def _box_gap(boxes, m, lo, hi):
    """Distance between mesh node ``m``'s box and the box ``lo``, ``hi``."""
    total = 0.0
    for r in range(3):
        out = max(boxes[m, r] - hi[r], lo[r] - boxes[m, 3 + r], 0.0)
        total += out * out
    return np.sqrt(total)


@_jit
def walk(boxes, triangles, depth_m, table, index, points, depth_c, poses, yes_no, gap, unit,
         near, far):
    """For each pose ``poses[p]`` (the chain in the mesh's frame): the least
    capsule-triangle gap into ``gap[p]``, its unit into ``unit[p]`` and the
    closest points (on the unit's axis, on the triangle; mesh frame) into
    ``near[p]``, ``far[p]``. With ``yes_no`` a pose stops at its first gap <= 0
    (``gap`` is then that gap, not the least). ``table``, ``index``, ``points``,
    ``depth_c``: the chain's :class:`~cadpipe.collision.hierarchy.CapsuleTree`
    packed; ``boxes``, ``triangles``, ``depth_m``: the :class:`TriangleTree`."""
    leaves_m, leaves_c = 2 ** depth_m - 1, 2 ** depth_c - 1
    nodes_c = len(table)
    moved = np.empty((len(points), 3))
    lo, hi = np.empty((nodes_c, 3)), np.empty((nodes_c, 3))
    stack_m = np.empty(4 * (depth_m + depth_c + 2), np.int64)
    stack_c = np.empty(len(stack_m), np.int64)
    stack_gap = np.empty(len(stack_m))
    ends = np.empty((2, 3))
    on_axis, on_triangle = np.empty(3), np.empty(3)
    for p in range(len(poses)):
        m = poses[p]
        move_points(m, points, moved)
        for c in range(nodes_c):                 # each chain node's box, moved
            outer = table[c, 9]
            for r in range(3):
                x, y = moved[index[c, 0], r], moved[index[c, 1], r]
                lo[c, r] = min(x, y) - outer
                hi[c, r] = max(x, y) + outer
        best = np.inf
        unit[p] = -1
        stack_m[0], stack_c[0], stack_gap[0] = 0, 0, _box_gap(boxes, 0, lo[0], hi[0])
        top = 1
        while top:
            top -= 1
            nm, nc, bound = stack_m[top], stack_c[top], stack_gap[top]
            if bound > (0.0 if yes_no else best) or table[nc, 9] == -np.inf:
                continue
            leaf_m, leaf_c = nm >= leaves_m, nc >= leaves_c
            if leaf_m and leaf_c:
                if index[nc, 2] < 0:
                    continue
                tri = nm - leaves_m
                ends[0], ends[1] = moved[index[nc, 0]], moved[index[nc, 1]]
                d = segment_triangle(ends[0], ends[1], triangles[tri], on_axis, on_triangle) \
                    - table[nc, 9]
                if d < best:
                    best = d
                    unit[p] = index[nc, 2]
                    near[p, :] = on_axis
                    far[p, :] = on_triangle
                if yes_no and best <= 0:
                    break
                continue
            # split the chain node when the mesh node is a leaf or the smaller box
            size_c = hi[nc, 0] - lo[nc, 0] + hi[nc, 1] - lo[nc, 1] + hi[nc, 2] - lo[nc, 2]
            size_m = boxes[nm, 3] - boxes[nm, 0] + boxes[nm, 4] - boxes[nm, 1] \
                + boxes[nm, 5] - boxes[nm, 2]
            split_c = not leaf_c and (leaf_m or size_c >= size_m)
            if split_c:
                m0, m1, c0, c1 = nm, nm, 2 * nc + 1, 2 * nc + 2
            else:
                m0, m1, c0, c1 = 2 * nm + 1, 2 * nm + 2, nc, nc
            g0, g1 = _box_gap(boxes, m0, lo[c0], hi[c0]), _box_gap(boxes, m1, lo[c1], hi[c1])
            if g1 < g0:
                m0, m1, c0, c1, g0, g1 = m1, m0, c1, c0, g1, g0
            stack_m[top], stack_c[top], stack_gap[top] = m1, c1, g1
            stack_m[top + 1], stack_c[top + 1], stack_gap[top + 1] = m0, c0, g0
            top += 2
        gap[p] = best
