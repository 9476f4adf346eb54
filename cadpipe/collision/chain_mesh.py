"""Chains against meshes: a pipe's capsule tree walked against a box tree of a mesh's
triangles, one compiled call for one pose or for thousands.

Each chain unit is taken as the capsule of its larger end radius (exact for the
untapered units of a pipe of one radius, a little larger for a tapered one: the
model FCL's capsules gave this pair before). The mesh's triangles, split at
medians of their centroids, are the leaves of a perfect binary tree
(:class:`TriangleTree`, built once per mesh) whose nodes carry an axis-aligned
box and, above the leaves, an oriented one along the principal axes of their
triangles' corners (thin across a patch of a curved surface, where the
axis-aligned box of a tilted patch is not; a leaf's is its triangle's plane).
The chain's nodes are :class:`~cadpipe.collision.hierarchy.CapsuleTree`'s, whose
chords move with the pose; each is placed (its chord's ends moved, their box
widened by the outer radius) the first time a pose's walk reaches it.

Both trees are walked in lockstep, depth first, splitting the larger node. A
node pair is dropped when a lower bound of its gap exceeds the best gap found (a
yes/no query: 0): the gap of the axis-aligned boxes, then the capsule's against
the oriented box along its three axes (a leaf's plane); a yes/no query takes
first the pair whose chord crosses the mesh node's middle plane across its
thinnest axis (a contact is likelier there), any other the pair of nearer boxes.
A leaf pair is a capsule against a triangle: dropped when both ends of the axis
lie on one side of the triangle's plane, farther than the bound; else the exact
distance from the unit's axis to the triangle (0 where the axis pierces it;
otherwise the least of the axis' ends to the triangle and the axis to the
triangle's edges) less the radius. Every bound is a true lower bound widened by
rounding slack, so the walk drops no pair the exact test would find nearer: its
answers are those of the exact test on every pair. On the pipe against a
1,536-triangle torus of ``benchmarks/bench_poses.py`` the oriented boxes, the
plane test and the order cut the node pairs a yes/no pose takes from 97 to 32
where it finds a contact (exact leaf tests from 21 to 3) and from 147 to 50
where it proves none (27 to 2), and placing the chain's nodes when reached saves
the 2 us a pose spent moving all of them first (``docs/performance.md``).

Containment (a unit wholly inside the mesh, or the mesh inside a unit) is not
seen by the walk; :func:`cadpipe.collision.narrow.collide` adds it.
"""

import numba
import numpy as np

from cadpipe.collision.bounds import box_levels, rounding_slack
from cadpipe.collision.convex import nearest_on_triangle

_jit = numba.njit(cache=True, nogil=True)
#: a helper of the walk inlined into it (numba's own inlining: as a called function
#: each node pair cost about twice as much)
_inline = numba.njit(cache=True, nogil=True, inline="always")
#: relative rounding slack of the walk's bounds (of the coordinates they are
#: computed from): far above the rounding of a few products, far below any gap
_SLACK = 1e-12


class TriangleTree:
    """Boxes over a mesh's triangles, in the mesh's frame.

    Parameters
    ----------
    vertices : (V, 3) float
    faces : (F, 3) int

    A perfect binary tree in heap order: leaf ``k`` (at depth ``depth``) holds
    triangle ``order[k]`` or none (-1), the triangles in the first leaves, and
    each node's triangles are split between its children along the longest
    extent of their centroids (:func:`_median_order`). ``boxes`` (nodes, 7)
    holds each node's ``lo``, ``hi`` and size (the sum of its extents);
    ``frames`` (nodes above the leaves, 15) each one's oriented box: centre
    (3), axes (3, 3, as rows, the thinnest first) and half extents (3);
    ``triangles`` (leaves, 9) the leaves' corners, row by row. A node without
    triangles has ``lo = inf``, ``hi = -inf`` (its frame is never read).
    """

    def __init__(self, vertices, faces):
        vertices = np.asarray(vertices, np.float64)
        corners = vertices[np.asarray(faces)]                               # (F, 3, 3)
        count = len(corners)
        self.depth = int(np.ceil(np.log2(count))) if count > 1 else 0
        order = _median_order(np.ascontiguousarray(corners.mean(axis=1)), self.depth)
        leaves = 2 ** self.depth
        self.order = np.full(leaves, -1, np.int64)
        self.order[:count] = order
        self.triangles = np.zeros((leaves, 9))
        self.triangles[:count] = corners[order].reshape(count, 9)
        low, high = np.full((leaves, 3), np.inf), np.full((leaves, 3), -np.inf)
        low[:count], high[:count] = corners[order].min(axis=1), corners[order].max(axis=1)
        lo, hi = box_levels(low, high)
        # per node lo, hi and its size (the sum of its extents, for the walk's split rule)
        size = hi[:, 0] - lo[:, 0] + hi[:, 1] - lo[:, 1] + hi[:, 2] - lo[:, 2]
        self.boxes = np.ascontiguousarray(np.concatenate([lo, hi, size[:, None]], axis=1))
        self.frames = _frames(self.triangles, count, self.depth,
                              rounding_slack(corners.reshape(-1, 3)))


@_jit
def _frames(triangles, count, depth, slack):
    """Per node above the leaves of the tree (heap order) over the leaves
    ``triangles`` (L, 9) (the first ``count`` hold a triangle): an oriented box
    holding the corners of its triangles, as a row (15) of centre, axes (3, 3,
    as rows) and half extents, the axes the principal axes of those corners
    (the least spread first, :func:`_principal_axes`), each half extent widened
    by ``slack``; zeros for a node without a triangle. One compiled pass: for a
    327,680-triangle sphere 0.6 s, where numpy's batched eigh and a temporary
    per level took 0.9."""
    inner = (1 << depth) - 1
    frames = np.zeros((inner, 15))
    if inner == 0:
        return frames
    # moments about the corners' middle (no cancellation far from the origin)
    low, high = np.full(3, np.inf), np.full(3, -np.inf)
    for k in range(count):
        for r in range(9):
            low[r % 3] = min(low[r % 3], triangles[k, r])
            high[r % 3] = max(high[r % 3], triangles[k, r])
    origin = 0.5 * (low + high)
    # per node: corner count, sums (3), second moments (xx, xy, xz, yy, yz, zz)
    moments = np.zeros((inner, 10))
    for k in range(count):
        node = (inner + k - 1) // 2
        for c in range(3):
            x, y, z = (triangles[k, 3 * c] - origin[0], triangles[k, 3 * c + 1] - origin[1],
                       triangles[k, 3 * c + 2] - origin[2])
            for q, v in enumerate((1.0, x, y, z, x * x, x * y, x * z, y * y, y * z, z * z)):
                moments[node, q] += v
    for node in range(inner - 1, 0, -1):
        moments[(node - 1) // 2] += moments[node]
    spread = np.empty((3, 3))
    for node in range(inner):
        n = moments[node, 0]
        if n == 0.0:
            continue
        mean = moments[node, 1:4] / n
        q = 4
        for i in range(3):
            for j in range(i, 3):
                spread[i, j] = spread[j, i] = moments[node, q] / n - mean[i] * mean[j]
                q += 1
        axes = _principal_axes(spread)
        level = 0
        while (2 << level) - 1 <= node:
            level += 1
        width = 1 << (depth - level)
        first = (node - ((1 << level) - 1)) * width
        lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
        for k in range(first, min(first + width, count)):
            for c in range(3):
                x, y, z = (triangles[k, 3 * c] - origin[0], triangles[k, 3 * c + 1] - origin[1],
                           triangles[k, 3 * c + 2] - origin[2])
                for r in range(3):
                    v = axes[r, 0] * x + axes[r, 1] * y + axes[r, 2] * z
                    lo[r], hi[r] = min(lo[r], v), max(hi[r], v)
        for c in range(3):
            frames[node, c] = origin[c]
            for r in range(3):
                frames[node, c] += axes[r, c] * 0.5 * (lo[r] + hi[r])
                frames[node, 3 + 3 * r + c] = axes[r, c]
            frames[node, 12 + c] = 0.5 * (hi[c] - lo[c]) + slack
    return frames


@_jit
def _principal_axes(a):
    """The eigenvectors of the symmetric (3, 3) ``a`` as rows, by ascending
    eigenvalue (LAPACK's, through numba: orthonormal to rounding, all an
    oriented box needs; its extents are measured along them)."""
    return np.ascontiguousarray(np.linalg.eigh(a)[1].T)


@_jit
def _median_order(centroid, depth):
    """The leaf order of triangles with centroids ``centroid`` (F, 3) in a perfect
    tree of ``depth``: level by level, each node's triangles are split at its
    second child's first leaf along the longest extent of their centroids. On a
    pipe against a 1,536-triangle torus a walk tests about 30% fewer node pairs
    than over a Morton order of the centroids (whose boxes straddle the curve's
    jumps). A quickselect per node: O(F) per level."""
    count = len(centroid)
    order = np.arange(count)
    keys = np.empty(count)
    for d in range(depth):
        slots = 1 << (depth - d)
        for a in range(0, count, slots):
            b, m = min(a + slots, count), a + slots // 2
            if m >= b:
                continue
            lo, hi = centroid[order[a]].copy(), centroid[order[a]].copy()
            for k in range(a + 1, b):
                for r in range(3):
                    lo[r] = min(lo[r], centroid[order[k], r])
                    hi[r] = max(hi[r], centroid[order[k], r])
            axis = np.argmax(hi - lo)
            for k in range(a, b):
                keys[k] = centroid[order[k], axis]
            _split_at(keys, order, a, b - 1, m)
    return order


@_jit
def _split_at(keys, order, low, high, k):
    """Reorder ``keys[low:high + 1]`` and ``order`` alike so that no key before ``k``
    is larger than one from ``k`` on: quickselect (median of three), or a sort
    once it has taken more rounds than a balanced one would (a bounded worst
    case for any input)."""
    rounds, limit = 0, 2 * int(np.log2(high - low + 1)) + 4
    while low < high:
        if rounds > limit:
            part = np.argsort(keys[low:high + 1], kind="mergesort") + low
            keys[low:high + 1], order[low:high + 1] = keys[part], order[part]
            return
        rounds += 1
        i = _partition(keys, order, low, high)
        if i == k:
            return
        if i < k:
            low = i + 1
        else:
            high = i - 1


@_jit
def _partition(keys, order, low, high):
    """Hoare's partition of ``keys[low:high + 1]`` (and ``order`` alike) about the
    median of its first, middle and last key; returns the pivot's place."""
    mid = (low + high) >> 1
    for x, y in ((mid, low), (high, mid), (mid, low)):
        if keys[x] < keys[y]:
            keys[x], keys[y] = keys[y], keys[x]
            order[x], order[y] = order[y], order[x]
    pivot = keys[mid]
    keys[high], keys[mid] = keys[mid], keys[high]
    order[high], order[mid] = order[mid], order[high]
    i, j = low, high - 1
    while True:
        while i < high and keys[i] < pivot:
            i += 1
        while j >= low and pivot < keys[j]:
            j -= 1
        if i >= j:
            break
        keys[i], keys[j] = keys[j], keys[i]
        order[i], order[j] = order[j], order[i]
        i += 1
        j -= 1
    keys[i], keys[high] = keys[high], keys[i]
    order[i], order[high] = order[high], order[i]
    return i


@_jit
def _closest_on_triangle(px, py, pz, t):
    """The point of triangle ``t`` (9,) nearest to ``(px, py, pz)``, as three
    coordinates (:func:`cadpipe.collision.convex.nearest_on_triangle`, about the point)."""
    x, y, z, _ = nearest_on_triangle(t[0] - px, t[1] - py, t[2] - pz, t[3] - px, t[4] - py,
                                     t[5] - pz, t[6] - px, t[7] - py, t[8] - pz)
    return x + px, y + py, z + pz


@_jit
def _segments_closest(px, py, pz, ux, uy, uz, qx, qy, qz, vx, vy, vz):
    """Parameters ``(s, t)`` of the closest points of ``p + s u`` and ``q + t v``
    (as :func:`cadpipe.collision.capsules.segment_params`)."""
    rx, ry, rz = px - qx, py - qy, pz - qz
    uu = ux * ux + uy * uy + uz * uz
    vv = vx * vx + vy * vy + vz * vz
    uv = ux * vx + uy * vy + uz * vz
    ur = ux * rx + uy * ry + uz * rz
    vr = vx * rx + vy * ry + vz * rz
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
    triangle). 0 where the segment pierces the triangle. In scalars: a walk
    calls it at every leaf, where a small array each step cost more than the
    arithmetic."""
    ax, ay, az = a[0], a[1], a[2]
    ux, uy, uz = b[0] - ax, b[1] - ay, b[2] - az
    # pierced: the segment crosses the triangle's plane inside the triangle
    e1x, e1y, e1z = t[3] - t[0], t[4] - t[1], t[5] - t[2]
    e2x, e2y, e2z = t[6] - t[0], t[7] - t[1], t[8] - t[2]
    nx, ny, nz = e1y * e2z - e1z * e2y, e1z * e2x - e1x * e2z, e1x * e2y - e1y * e2x
    da = nx * (ax - t[0]) + ny * (ay - t[1]) + nz * (az - t[2])
    db = nx * (b[0] - t[0]) + ny * (b[1] - t[1]) + nz * (b[2] - t[2])
    if (da <= 0 <= db or db <= 0 <= da) and da != db:
        f = da / (da - db)
        xx, xy, xz = ax + f * ux, ay + f * uy, az + f * uz
        cx, cy, cz = _closest_on_triangle(xx, xy, xz, t)
        if (cx - xx) ** 2 + (cy - xy) ** 2 + (cz - xz) ** 2 <= 1e-30 * (
                1.0 + xx * xx + xy * xy + xz * xz):
            near[0], near[1], near[2] = xx, xy, xz
            far[0], far[1], far[2] = cx, cy, cz
            return 0.0
    best = np.inf
    for k in range(2):                           # the segment's ends against the triangle
        p = a if k == 0 else b
        cx, cy, cz = _closest_on_triangle(p[0], p[1], p[2], t)
        d = np.sqrt((cx - p[0]) ** 2 + (cy - p[1]) ** 2 + (cz - p[2]) ** 2)
        if d < best:
            best = d
            near[0], near[1], near[2] = p[0], p[1], p[2]
            far[0], far[1], far[2] = cx, cy, cz
    for k in range(3):                           # the segment against each edge
        q, r = 3 * k, 3 * ((k + 1) % 3)
        qx, qy, qz = t[q], t[q + 1], t[q + 2]
        vx, vy, vz = t[r] - qx, t[r + 1] - qy, t[r + 2] - qz
        s, w = _segments_closest(ax, ay, az, ux, uy, uz, qx, qy, qz, vx, vy, vz)
        px, py, pz = ax + s * ux, ay + s * uy, az + s * uz
        qx, qy, qz = qx + w * vx, qy + w * vy, qz + w * vz
        d = np.sqrt((px - qx) ** 2 + (py - qy) ** 2 + (pz - qz) ** 2)
        if d < best:
            best = d
            near[0], near[1], near[2] = px, py, pz
            far[0], far[1], far[2] = qx, qy, qz
    return best


@_inline
def _box_gap_sq(boxes, m, lo, hi):
    """Squared distance between mesh node ``m``'s box and the box ``lo``, ``hi``."""
    total = 0.0
    for r in range(3):
        out = max(boxes[m, r] - hi[r], lo[r] - boxes[m, 3 + r], 0.0)
        total += out * out
    return total


@_inline
def _place_node(c, m, points, table, index, placed):
    """Chain node ``c`` at pose ``m``: its chord's ends, moved, into ``placed[c,
    :6]``, their box widened by the outer radius into ``placed[c, 6:12]`` (lo,
    hi) and its size (the sum of its extents) into ``placed[c, 12]``."""
    outer = table[c, 9]
    for e in range(2):
        k = index[c, e]
        for r in range(3):
            placed[c, 3 * e + r] = m[r, 0] * points[k, 0] + m[r, 1] * points[k, 1] \
                + m[r, 2] * points[k, 2] + m[r, 3]
    for r in range(3):
        x, y = placed[c, r], placed[c, 3 + r]
        placed[c, 6 + r] = min(x, y) - outer
        placed[c, 9 + r] = max(x, y) + outer
    placed[c, 12] = placed[c, 9] - placed[c, 6] + placed[c, 10] - placed[c, 7] \
        + placed[c, 11] - placed[c, 8]


@_inline
def _oriented_gap(frames, m, chord, radius):
    """A lower bound of the gap between mesh node ``m``'s oriented box (a row of
    ``frames``) and the capsule of ``chord`` (its ends' coordinates, 6) and
    ``radius``: the largest gap of their projections on the box's three axes,
    less rounding slack."""
    px, py, pz = chord[0] - frames[m, 0], chord[1] - frames[m, 1], chord[2] - frames[m, 2]
    qx, qy, qz = chord[3] - frames[m, 0], chord[4] - frames[m, 1], chord[5] - frames[m, 2]
    slack = _SLACK * (abs(px) + abs(py) + abs(pz) + abs(qx) + abs(qy) + abs(qz))
    bound = -np.inf
    for r in range(3):
        a = frames[m, 3 + 3 * r] * px + frames[m, 4 + 3 * r] * py + frames[m, 5 + 3 * r] * pz
        b = frames[m, 3 + 3 * r] * qx + frames[m, 4 + 3 * r] * qy + frames[m, 5 + 3 * r] * qz
        half = frames[m, 12 + r]
        bound = max(bound, min(a, b) - half, -half - max(a, b))
    return bound - radius - slack


@_inline
def _crossing(frames, m, chord):
    """How far the chord (6) stays from mesh node ``m``'s oriented box's middle
    plane across its thinnest axis, -1 where it crosses it: a yes/no walk
    takes the pair of the smaller first."""
    a = frames[m, 3] * (chord[0] - frames[m, 0]) + frames[m, 4] * (chord[1] - frames[m, 1]) \
        + frames[m, 5] * (chord[2] - frames[m, 2])
    b = frames[m, 3] * (chord[3] - frames[m, 0]) + frames[m, 4] * (chord[4] - frames[m, 1]) \
        + frames[m, 5] * (chord[5] - frames[m, 2])
    return -1.0 if a * b <= 0.0 else min(abs(a), abs(b))


@_inline
def _plane_gap(t, chord, radius):
    """A lower bound of the gap between triangle ``t`` (9,) and the capsule of
    ``chord`` (6) and ``radius``: how far both ends lie on one side of the
    triangle's plane (-inf where they do not), less the radius and rounding
    slack (of the plane's and the ends' coordinates: a sliver's normal is
    rounded the most)."""
    e1x, e1y, e1z = t[3] - t[0], t[4] - t[1], t[5] - t[2]
    e2x, e2y, e2z = t[6] - t[0], t[7] - t[1], t[8] - t[2]
    nx, ny, nz = e1y * e2z - e1z * e2y, e1z * e2x - e1x * e2z, e1x * e2y - e1y * e2x
    ax, ay, az = chord[0] - t[0], chord[1] - t[1], chord[2] - t[2]
    bx, by, bz = chord[3] - t[0], chord[4] - t[1], chord[5] - t[2]
    da = nx * ax + ny * ay + nz * az
    db = nx * bx + ny * by + nz * bz
    if not (da > 0.0 and db > 0.0 or da < 0.0 and db < 0.0):
        return -np.inf
    length = np.sqrt(nx * nx + ny * ny + nz * nz)
    slack = _SLACK * (abs(e1x) + abs(e1y) + abs(e1z)) * (abs(e2x) + abs(e2y) + abs(e2z)) * (
        abs(ax) + abs(ay) + abs(az) + abs(bx) + abs(by) + abs(bz))
    return (min(abs(da), abs(db)) - slack) / length - radius


@_jit
def walk(boxes, frames, triangles, depth_m, table, index, points, depth_c, poses, yes_no, gap,
         unit, near, far):
    """For each pose ``poses[p]`` (the chain in the mesh's frame): the least
    capsule-triangle gap into ``gap[p]``, its unit into ``unit[p]`` and the
    closest points (on the unit's axis, on the triangle; mesh frame) into
    ``near[p]``, ``far[p]``. With ``yes_no`` a pose stops at its first gap <= 0
    (``gap`` is then that gap; where none is, a positive number that need not
    be the least). ``table``, ``index``, ``points``, ``depth_c``: the chain's
    :class:`~cadpipe.collision.hierarchy.CapsuleTree` packed; ``boxes``,
    ``frames``, ``triangles``, ``depth_m``: the :class:`TriangleTree`."""
    leaves_m, leaves_c = 2 ** depth_m - 1, 2 ** depth_c - 1
    nodes_c = len(table)
    # each chain node's chord ends, box and size (_place_node), at the pose it was placed at
    placed, placed_at = np.empty((nodes_c, 13)), np.full(nodes_c, -1, np.int64)
    stack_m = np.empty(4 * (depth_m + depth_c + 2), np.int64)
    stack_c = np.empty(len(stack_m), np.int64)
    stack_gap = np.empty(len(stack_m))
    on_axis, on_triangle = np.empty(3), np.empty(3)
    for p in range(len(poses)):
        m = poses[p]
        _place_node(0, m, points, table, index, placed)
        placed_at[0] = p
        best = np.inf
        unit[p] = -1
        stack_m[0], stack_c[0] = 0, 0
        stack_gap[0] = np.sqrt(_box_gap_sq(boxes, 0, placed[0, 6:9], placed[0, 9:12]))
        top = 1
        while top:
            top -= 1
            nm, nc, bound = stack_m[top], stack_c[top], stack_gap[top]
            radius = table[nc, 9]
            limit = 0.0 if yes_no else best
            if bound > limit or radius == -np.inf:
                continue
            chord = placed[nc, :6]
            leaf_m, leaf_c = nm >= leaves_m, nc >= leaves_c
            if leaf_m and leaf_c:
                if index[nc, 2] < 0:
                    continue
                tri = triangles[nm - leaves_m]
                if _plane_gap(tri, chord, radius) > limit:
                    continue
                d = segment_triangle(chord[:3], chord[3:], tri, on_axis, on_triangle) - radius
                if d < best:
                    best = d
                    unit[p] = index[nc, 2]
                    near[p, :] = on_axis
                    far[p, :] = on_triangle
                if yes_no and best <= 0:
                    break
                continue
            if (_plane_gap(triangles[nm - leaves_m], chord, radius) if leaf_m else
                    _oriented_gap(frames, nm, chord, radius)) > limit:
                continue
            # split the chain node when the mesh node is a leaf or the smaller box
            if not leaf_c and (leaf_m or placed[nc, 12] >= boxes[nm, 6]):
                m0, m1, c0, c1 = nm, nm, 2 * nc + 1, 2 * nc + 2
                for c in (c0, c1):
                    if placed_at[c] != p:
                        _place_node(c, m, points, table, index, placed)
                        placed_at[c] = p
            else:
                m0, m1, c0, c1 = 2 * nm + 1, 2 * nm + 2, nc, nc
            g0 = _box_gap_sq(boxes, m0, placed[c0, 6:9], placed[c0, 9:12])
            g1 = _box_gap_sq(boxes, m1, placed[c1, 6:9], placed[c1, 9:12])
            if yes_no:
                # only touching boxes can lead to a contact: the others would be dropped
                # when taken, so they are not stacked (the same visits, fewer steps)
                if g0 == 0.0 and g1 == 0.0 and (
                        _plane_gap(triangles[m1 - leaves_m], placed[c1, :6], 0.0) <
                        _plane_gap(triangles[m0 - leaves_m], placed[c0, :6], 0.0)
                        if m0 >= leaves_m else _crossing(frames, m1, placed[c1, :6]) <
                        _crossing(frames, m0, placed[c0, :6])):
                    m0, m1, c0, c1, g0, g1 = m1, m0, c1, c0, g1, g0
                if g1 == 0.0:
                    stack_m[top], stack_c[top], stack_gap[top] = m1, c1, 0.0
                    top += 1
                if g0 == 0.0:
                    stack_m[top], stack_c[top], stack_gap[top] = m0, c0, 0.0
                    top += 1
                continue
            g0, g1 = np.sqrt(g0), np.sqrt(g1)
            if g1 < g0:
                m0, m1, c0, c1, g0, g1 = m1, m0, c1, c0, g1, g0
            stack_m[top], stack_c[top], stack_gap[top] = m1, c1, g1
            stack_m[top + 1], stack_c[top + 1], stack_gap[top + 1] = m0, c0, g0
            top += 2
        gap[p] = best
