"""Where a tube would cut through itself.

Three ways a swept tube folds, checked cheapest first: a corner sharper than the
miter limit, rings that overlap within one segment (the radius exceeds the local
bend radius), and two stretches of the tube that are apart along the path but
closer in space than the tube reaches there (miter tips included). All three run
over a whole batch of tubes at once (:class:`~cadpipe.geometry.rings.Tubes`).

The distant search works on the path's segments themselves, not on samples, so a
long straight stretch costs as little as a short one. A binary tree of capsules
(each node: the chord of its run of segments, widened to hold them all) is walked
pairwise, level by level. A node pair is dropped when its capsules are apart, or
when the stretch of path joining them turns by less than a right angle: along such
a stretch the distance between two points grows with their separation, so the
tube cannot come back to itself there (what overlaps within it is the local
check's business). What is left are segment pairs whose capsules meet; a fold is
such a pair whose convex units overlap (no separating plane among their faces and
the line between their centres). Cost: ``O(N log N)`` in segments and memory linear
in them, whatever the radii; straight stretches are single segments however long.
"""

from dataclasses import dataclass
from functools import partial

import numpy as np

from cadpipe import limits
from cadpipe.core.kernels import native
from cadpipe.core.vec import norm

#: findings described per tube and kind of fold
MAX_FINDINGS = 10
#: stretches joined by less turning than this cannot meet (the distance grows along them)
RIGHT_ANGLE = 0.5 * np.pi - 1e-9
#: a corner beyond its miter limit becomes a ball joint: a latitude-longitude polyhedron
#: of this many sides around, its vertices this far out (in ring radii) so that every face
#: lies beyond the ball, with a margin (the units' square ends must not touch its faces)
BALL_SIDES = 16
BALL_REACH = 1.001 / (np.cos(np.pi / BALL_SIDES) * np.cos(np.pi / BALL_SIDES))


@dataclass(frozen=True)
class Folds:
    """Where one tube of a batch would cut through itself.

    Attributes
    ----------
    messages : tuple of str
        The first findings (at most :data:`MAX_FINDINGS` per kind), naming path
        points, arc lengths and what to change.
    segments : (K,) int array
        Sorted local indices of the segments whose units must be merged (a solid
        union) for the tube to be valid; empty when it is clean.
    joints : (J,) int array
        Local indices of the corners beyond the miter limit (built as ball joints).
    """

    messages: tuple
    segments: np.ndarray
    joints: np.ndarray

    def __bool__(self):
        return bool(self.messages)


def tube_folds(tubes, *, first_only=False):
    """Per tube of the batch, its :class:`Folds`.

    With ``first_only`` the checks stop at the first finding in any tube (the answer
    to "is every tube clean?"): after the first kind that finds anything, and inside
    the distant search at its first pair of meeting units (see
    :func:`distant_pairs`), so other findings may be missing.
    """
    count = len(tubes.groups)
    messages = [[] for _ in range(count)]
    merged = [[] for _ in range(count)]
    joints = [np.empty(0, np.int64)] * count
    for check in (_miter_limit, _local_overlaps, partial(_distant_overlaps,
                                                          first_only=first_only)):
        tube, describe, segments = check(tubes)
        if tube.size == 0:
            continue
        rank = np.arange(len(tube)) - np.searchsorted(tube, tube)   # hits in tube order
        for hit in np.flatnonzero(rank < MAX_FINDINGS).tolist():
            messages[tube[hit]].append(describe(hit))
        if check is _miter_limit:
            local = tube_local(tubes.groups, segments.pop("joints"))
            for g in np.unique(tube).tolist():
                joints[g] = local[tube == g]
        for g, rows in segments.items():
            merged[g].append(rows)
        if first_only:
            break
    return [Folds(tuple(m), np.unique(np.concatenate(s)) if s else np.empty(0, np.int64), j)
            for m, s, j in zip(messages, merged, joints)]


def tube_local(groups, rows):
    """Local (within their tube) indices of global ``rows``."""
    return rows - groups.first[groups.index[rows]]


def _where(lines, row):
    local = tube_local(lines.groups, row)
    return f"path point {local} at arc length {lines.arc_length[row]:.6g}"


def _segments_around(groups, rows, before, after):
    """{tube: local segment indices} of the segments ``before..after`` around each
    global row (clipped to open tubes' segments, wrapped around closed ones)."""
    out = {}
    if rows.size == 0:
        return out
    tube = groups.index[rows]
    local = tube_local(groups, rows)
    counts, closed = groups.counts[tube], groups.closed[tube]
    segs = np.where(closed, counts, counts - 1)
    k = local[:, None] + np.arange(-before, after + 1)
    valid = closed[:, None] | ((k >= 0) & (k < segs[:, None]))
    k = k % np.maximum(segs, 1)[:, None]
    t = np.broadcast_to(tube[:, None], k.shape)
    for g in np.unique(tube).tolist():
        out[g] = np.unique(k[valid & (t == g)])
    return out


def _miter_limit(tubes):
    lines = tubes.lines
    stretch = tubes.miter_stretch
    limit = tubes.miter_limit[lines.groups.index]
    bad = np.flatnonzero(tubes.over_limit)

    def describe(hit):
        i = bad[hit]
        if not np.isfinite(stretch[i]):
            return (f"{_where(lines, i)}: the path reverses there (turns by "
                    f"{np.degrees(lines.turning_angles[i]):.1f} degrees), so the tube must turn "
                    "round in a ball joint")
        return (f"{_where(lines, i)}: a {np.degrees(lines.turning_angles[i]):.1f} degree "
                f"corner needs a miter stretch of {stretch[i]:.3g} > miter_limit={limit[i]:g} "
                "(use corners='round' or a larger miter_limit)")

    return lines.groups.index[bad], describe, {**_segments_around(lines.groups, bad, 1, 0),
                                               "joints": bad}


def _local_overlaps(tubes):
    """Within a segment, the two end rings' planes must not meet inside the tube.

    Across segment j (direction d, length L), the ring plane at each end sits at an
    axial offset ``y . g`` for a lateral offset y, where g is the tangent's part
    across d divided by its part along d. The planes meet inside a tube of radius
    rho exactly when ``rho * |g_start - g_end| >= L``.
    """
    lines = tubes.lines
    groups = lines.groups
    bad, widest, spread = local_folds(tubes)
    bad = np.flatnonzero(bad)

    def describe(hit):
        i = bad[hit]
        return (f"{_where(lines, i)}: radius {widest[i]:.6g} exceeds the local bend radius "
                f"(about {lines.segment_lengths[i] / spread[i]:.6g})")

    return groups.index[bad], describe, _segments_around(groups, bad, 1, 1)


def local_folds(tubes):
    """(N,) True at segment columns whose two end rings' planes meet inside the tube
    (see :func:`_local_overlaps`), and the (N,) wider ring radius and the spread
    ``|g_start - g_end|`` of each column."""
    lines = tubes.lines
    groups = lines.groups
    # with t the bisector of the segments at a point, t.d = cos(turn / 2) = 1 / stretch
    # for both segments there, so g = d - t * stretch and the difference across segment
    # j is the change of t * stretch from point j to point j + 1
    with np.errstate(invalid="ignore"):                        # folds: found by _miter_limit
        lean = lines.tangents * lines.miter_stretch
        spread = norm(groups.following(lean) - lean, 0)
    rho = tubes.ring_radii
    widest = np.maximum(rho, groups.following(rho))
    bad = _is_segment(groups) & (widest * spread >= lines.segment_lengths * (1 - 1e-9))
    return bad, widest, spread


def _is_segment(groups):
    """(N,) True at columns that start a real segment (not an open tube's last point)."""
    out = np.ones(groups.size, bool)
    out[groups.last] = groups.closed
    return out


def reach(tubes):
    """(N,) how far each point's ring reaches from the path: its radius times the
    miter stretch, or (beyond the miter limit, a ball joint) the widened radius."""
    return tubes.ring_radii * np.where(tubes.over_limit, BALL_REACH,
                                       np.maximum(tubes.miter_stretch, 1.0))


def distant_pairs(tubes, first_only=False):
    """Segment column pairs ``(i, j)``, ``i < j``, of one tube each, where the tube
    comes back to itself: closer than their reaches (:func:`reach`) although the path
    between them turns by a right angle or more, and their convex units overlap.

    The candidates come from one compiled walk of a tree of the segments' boxes
    (widened by their reach) against itself (``csrc/clearance.c``): a node pair is
    dropped when its boxes are apart, or when the stretch of path joining it turns by
    less than a right angle; a leaf pair is kept when its segments come closer than
    their reaches. So the walk costs what the pairs within reach of each other cost,
    not what the path's length over its radius does (a coil whose turns lie within
    reach of each other: a few node pairs per segment). The candidates of each tube are
    counted against :attr:`cadpipe.limits.Limits.max_swept_segments` before their
    units are tested, the search's costly part. With ``first_only`` the units are
    tested a block at a time until a pair meets (all a yes/no needs).

    Returns ``(i, j, distance)`` as (P,) arrays sorted by ``i`` then ``j``, and the
    (K,) sorted segment columns of all of them (the stretches a union must merge).
    """
    lines = tubes.lines
    groups = lines.groups
    empty = np.empty(0, np.int64)
    total = groups.sums(lines.turning_angles)
    if groups.size < 3 or (total < RIGHT_ANGLE).all():         # no tube can come back
        return empty, empty, np.empty(0), empty
    r = reach(tubes)
    _, following = _neighbours(groups, np.arange(groups.size))
    budget = limits.current().max_swept_segments
    i, j, dist, over = native.fold_pairs(
        np.ascontiguousarray(lines.xyz.T), np.ascontiguousarray(lines.segments.T),
        np.ascontiguousarray(np.maximum(r, groups.following(r))), _is_segment(groups),
        np.ascontiguousarray(groups.index, np.int64), following,
        np.cumsum(lines.turning_angles), np.ascontiguousarray(groups.closed, bool),
        np.ascontiguousarray(total, np.float64), RIGHT_ANGLE, budget)
    order = np.lexsort((j, i))
    i, j, dist = i[order], j[order], dist[order]
    hit = _units_meet(tubes, i, j, first_only)
    if over >= 0 and not (first_only and hit.any()):
        where = {"index": int(over)} if len(groups) > 1 else {}
        limits.check("max_swept_segments", float(budget) + 1,
                     "the search for the swept solid of a tube whose path comes back "
                     "within its own reach (segment pairs to test)", at_least=True, key="path",
                     **where)
    i, j, dist = i[hit], j[hit], dist[hit]
    return i, j, dist, np.unique(np.concatenate([i, j]))


#: unit pairs tested at once by :func:`_units_meet` (bounds its memory)
UNIT_BLOCK = 2048


def _unit_points(tubes, cols, sides):
    """(P, 4 * sides, 3) points whose hull holds each segment's unit, and (P, 3) the
    segments' directions: its two end rings (each twice), or at a corner beyond the
    miter limit (a ball joint) a prism square to the segment around the ball."""
    from cadpipe.geometry.rings import ring_basis, square_rings

    lines, groups = tubes.lines, tubes.groups
    nxt = groups.following(np.arange(groups.size))[cols]
    d = np.ascontiguousarray(lines.directions[:, cols].T)
    out = []
    for at in (cols, nxt):
        ring = np.matmul(ring_basis(sides), tubes.axes[at])           # (P, sides, 3)
        over = tubes.over_limit[at]
        ring_a, ring_b = ring, ring
        if over.any():
            rho = tubes.ring_radii[at[over]]
            dd = d[over]
            flat = square_rings(lines.xyz[:, at[over]].T, dd,
                                rho * (BALL_REACH / np.cos(np.pi / sides)), sides)
            ring_a, ring_b = ring.copy(), ring.copy()
            ring_a[over] = flat - (BALL_REACH * rho)[:, None, None] * dd[:, None]
            ring_b[over] = flat + (BALL_REACH * rho)[:, None, None] * dd[:, None]
        out += [ring_a, ring_b]
    return np.concatenate(out, axis=1), d


def _units_meet(tubes, i, j, first_only=False):
    """(P,) True where the convex units of segment columns ``i`` and ``j`` overlap by
    more than a touch: no plane among both units' side faces, ring planes and the
    line between their centres separates them. With ``first_only`` the blocks after
    the first that holds such a pair are left untested (False)."""
    hit = np.zeros(len(i), bool)
    if not len(i):
        return hit
    sides = tubes.sides[tubes.groups.index[i]]
    for n in np.unique(sides).tolist():
        rows = np.flatnonzero(sides == n)
        for start in range(0, len(rows), UNIT_BLOCK):
            block = rows[start:start + UNIT_BLOCK]
            hit[block] = ~_separated(tubes, i[block], j[block], n)
            if first_only and hit[block].any():
                return hit
    return hit


def _separated(tubes, i, j, sides):
    """(P,) True where a candidate axis separates the units of columns ``i``, ``j``."""
    pi, di = _unit_points(tubes, i, sides)
    pj, dj = _unit_points(tubes, j, sides)
    return _apart(pi, pj, [_unit_axes(pi, di, sides), _unit_axes(pj, dj, sides)])


def _unit_axes(pts, d, sides):
    """(P, A, 3) the face normals of units (points as :func:`_unit_points` gives them):
    side faces, the segment direction, both end rings' planes."""
    ring = pts[:, :sides]
    edge = np.roll(ring, -1, axis=1) - ring
    axes = [np.cross(edge, d[:, None]), d[:, None]]
    for k in (0, 2):                                    # the planes of both end rings
        rk = pts[:, k * sides:(k + 1) * sides]
        axes.append(np.cross(rk[:, 1] - rk[:, 0], rk[:, sides // 2 + 1] - rk[:, 0])[:, None])
    return np.concatenate(axes, axis=1)


def _apart(pi, pj, axes):
    """(P,) True where one of ``axes`` (list of (P, A_k, 3)), or the line between the
    centres, separates the hulls of point sets ``pi`` and ``pj`` ((P, K, 3) each)."""
    axes = np.concatenate([*axes, (pi.mean(axis=1) - pj.mean(axis=1))[:, None]], axis=1)
    size = np.linalg.norm(axes, axis=2, keepdims=True)
    axes = axes / np.where(size > 0, size, 1.0)
    # about the pair's middle: a touch is judged against their size, not their distance
    # from the origin
    middle = pi.mean(axis=1, keepdims=True)
    pi, pj = pi - middle, pj - middle
    a = np.einsum("pak,pvk->pav", axes, pi)
    b = np.einsum("pak,pvk->pav", axes, pj)
    tol = 1e-9 * (np.abs(pi).max(axis=(1, 2)) + np.abs(pj).max(axis=(1, 2)))[:, None]
    apart = (a.max(axis=2) <= b.min(axis=2) + tol) | (b.max(axis=2) <= a.min(axis=2) + tol)
    # a degenerate axis (coincident centres, a zero edge) projects both to one point
    return (apart & (size[..., 0] > 0)).any(axis=1)


def piece_meets_units(tubes, points, cols):
    """(P,) True where the convex hull of ``points`` ((K, 3), e.g. an end cap) overlaps
    the unit of each segment column in ``cols`` (tested as :func:`_units_meet` does,
    with the hull's own face normals as further axes); columns of one tube."""
    from scipy.spatial import ConvexHull

    hit = np.zeros(len(cols), bool)
    if not len(cols):
        return hit
    normals = ConvexHull(points, qhull_options="QJ").equations[:, :3]
    sides = int(tubes.sides[tubes.groups.index[cols[0]]])
    for start in range(0, len(cols), UNIT_BLOCK):
        block = slice(start, start + UNIT_BLOCK)
        pj, dj = _unit_points(tubes, cols[block], sides)
        pi = np.broadcast_to(points, (len(pj), *points.shape))
        hit[block] = ~_apart(pi, pj, [np.broadcast_to(normals, (len(pj), *normals.shape)),
                                      _unit_axes(pj, dj, sides)])
    return hit


def _neighbours(groups, cols):
    """The previous and next segment column of each segment column (-1 past an open
    tube's ends)."""
    tube = groups.index[cols]
    first, last, closed = groups.first[tube], groups.last[tube], groups.closed[tube]
    end = np.where(closed, last, last - 1)                        # the last real segment
    prev = np.where(cols > first, cols - 1, np.where(closed, end, -1))
    nxt = np.where(cols < end, cols + 1, np.where(closed, first, -1))
    return prev, nxt


def _distant_overlaps(tubes, first_only=False):
    """Stretches apart along the path that come within the tube's reach of each other;
    see :func:`distant_pairs`."""
    lines = tubes.lines
    groups = lines.groups
    i, j, dist, merged = distant_pairs(tubes, first_only)
    if not len(i):
        return i, None, {}
    r = reach(tubes)
    reach_i = np.maximum(r[i], groups.following(r)[i])
    reach_j = np.maximum(r[j], groups.following(r)[j])
    radius = np.maximum(tubes.ring_radii, groups.following(tubes.ring_radii))

    def describe(hit):
        a, b = i[hit], j[hit]
        widened = reach_i[hit] > radius[a] * (1 + 1e-9) or reach_j[hit] > radius[b] * (1 + 1e-9)
        why = " (with the miter tips of its corners)" if widened else ""
        return (f"{_where(lines, a)} and {_where(lines, b)}: the tube passes within "
                f"{dist[hit]:.6g} of itself, less than its reach {reach_i[hit]:.6g} + "
                f"{reach_j[hit]:.6g} there{why}")

    return groups.index[i], describe, _segments_around(groups, merged, 0, 0)
