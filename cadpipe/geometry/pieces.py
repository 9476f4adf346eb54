"""The convex pieces of a tube: the hulls whose union is the pipe.

Each segment's unit is the hull of its two end rings (a run of nearly straight
segments one hull, see :func:`hull_groups`); a corner beyond the miter limit, a
reversal or a ball joint is a ball with the units cut square at it; an open pipe's
caps are pieces of their own. The swept solid (:mod:`cadpipe.geometry.swept`) is
the union of these pieces where a tube folds, and the collision model
(:mod:`cadpipe.geometry.cover`) holds each of them in round cones.
"""

from dataclasses import dataclass

import numpy as np

from cadpipe.geometry.clearance import BALL_REACH, BALL_SIDES
from cadpipe.geometry.rings import ring_basis, square_rings
from cadpipe.geometry.surfaces import cap_axes


def runs(mask, closed):
    """``[(first, last)]`` index ranges of the runs of True in ``mask``; around a closed
    pipe a run may wrap (``last < first``)."""
    n = len(mask)
    if mask.all():
        return [(0, n - 1)]
    shift = int(np.argmin(mask)) + 1 if closed else 0        # start just after a False
    rolled = np.roll(mask, -shift)
    edges = np.diff(np.concatenate([[0], rolled.astype(np.int8), [0]]))
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    return [((a + shift) % n, (b + shift) % n) for a, b in zip(starts.tolist(), stops.tolist())]


def unit_points(pipe, segments, joints, overlap=0.0, tongue=0.0, capped=(True, True)):
    """Point sets whose convex hulls together make the tube along ``segments``: the
    points of each :func:`unit_pieces` piece."""
    return [piece.points for piece in unit_pieces(pipe, segments, joints, overlap, tongue,
                                                   capped)]


@dataclass(frozen=True)
class Piece:
    """A convex piece of a tube: the hull of ``points`` (K, 3), along the spine ``a ->
    b`` whose rings nominally have radii ``ra``, ``rb``; past an end it leans out
    towards that end's ``tip`` (a mitred corner's; the end itself elsewhere). See
    :func:`~cadpipe.geometry.cover.round_cone_covers`."""

    points: np.ndarray
    a: np.ndarray
    b: np.ndarray
    ra: float
    rb: float
    tip_a: np.ndarray
    tip_b: np.ndarray


def unit_pieces(pipe, segments, joints, overlap=0.0, tongue=0.0, capped=(True, True)):
    """The convex pieces (:class:`Piece`) that together make the tube along ``segments``.

    Each segment's unit is its two end rings (a run of nearly straight segments one
    hull of their rings, see :func:`hull_groups`); at a corner in ``joints`` (beyond
    the miter limit, or a ball joint) the rings there are cut square to the segment
    instead and a ball (:func:`ball_points`) holds the corner. Caps of an open pipe join the
    units of its end segments (at the ends ``capped`` says keep them). Where another
    segment continues a unit, its ring there is pushed ``overlap`` along the unit's own
    segment, and a ``tongue`` (a fraction of the ring radius) adds the ring shrunk by
    that fraction and moved as far into the next segment: the hulls then cross their
    neighbours at steep angles instead of sharing a face (manifold3d may leave a shared
    face's corners doubled).
    """
    path = pipe.path
    with np.errstate(invalid="ignore"):             # a reversal's ring: not used (a joint)
        rings = pipe.rings()
    n, count = len(path), len(path.segments)
    joints = np.asarray(joints, np.int64)
    at_joint = np.zeros(n, bool)
    at_joint[joints] = True
    directions, centres, lengths = path.directions, path.points, path.segment_lengths
    radii = pipe.ring_radii
    tips = np.where(at_joint[:, None], centres, miter_tips(pipe))

    def into(p, seg, sign):
        """Ring ``p`` shrunk and moved into segment ``seg`` (``sign``: along or back)."""
        step = min(tongue * float(radii[p]), 0.25 * float(lengths[seg]))
        return centres[p] + (1 - tongue) * (rings[p] - centres[p]) + sign * step * directions[seg]

    def square(k, p):
        """Segment k's cross-section at its end ``p`` (a joint): the prism's section,
        from its other end's ring, or a fresh polygon when both ends are joints."""
        q = (k + 1) % n if p == k else k
        d = directions[k]
        if at_joint[q]:
            return square_rings(centres[p][None], d[None], radii[p:p + 1], pipe.sides)[0]
        offsets = rings[q] - centres[q]
        offsets = (offsets - (offsets @ d)[:, None] * d) * (float(radii[p]) / float(radii[q]))
        return centres[p] + offsets

    pieces = []
    for first, last in hull_groups(pipe, segments, at_joint):
        ends = []
        for k, p, sign, other in ((first, first, -1.0, first - 1),
                                  (last, (last + 1) % n, 1.0, last + 1)):
            ring = rings[p]
            inner = pipe.closed or 0 <= other < count
            if at_joint[p]:
                ring = square(k, p)
            elif inner and tongue:
                ends.append(into(p, other % count, sign))
            ends.append(ring + (sign * overlap * inner) * directions[k])
        ends.insert(len(ends) // 2, rings[first + 1:last + 1].reshape(-1, 3))
        a, b = first, (last + 1) % n
        pieces.append(Piece(np.concatenate(ends), centres[a], centres[b], float(radii[a]),
                             float(radii[b]), tips[a], tips[b]))
    # an envelope's ball circumscribes the ball of the path's radius (its rings, those
    # of the polygon circumscribing that ball's sections, are wider)
    ball_radii = pipe.envelope_radii if pipe.envelope else radii
    for k in joints.tolist():
        pieces.append(Piece(ball_points(centres[k], float(ball_radii[k])), centres[k], centres[k],
                             0.0, 0.0, centres[k], centres[k]))
    if not pipe.closed:
        for row, sign, seg, style, wanted in ((0, -1, 0, pipe.cap_styles[0], capped[0]),
                                              (n - 1, 1, count - 1, pipe.cap_styles[1], capped[1])):
            end_cap = cap_axes(pipe._tubes, row, sign, pipe, style) if wanted else None
            if end_cap is not None and seg in set(np.asarray(segments).tolist()):
                inside = into(row, seg, -sign) if tongue else rings[row] - (
                    sign * overlap) * directions[seg]
                pieces.append(cap_piece(pipe, row, end_cap, [rings[row], inside]))
    return pieces


def cap_piece(pipe, row, cap, rings):
    """The :class:`Piece` of an end cap (``cap`` as :func:`cap_axes` gives it) closing
    ``rings`` at path point ``row``: a round cap is held by a ball about the end, an
    envelope's flat cap by the capsule to its face."""
    axes, pole = cap
    end = pipe.path.points[row]
    points = np.concatenate([*rings, np.matmul(ring_basis(pipe.sides), axes).reshape(-1, 3),
                             np.empty((0, 3)) if pole is None else pole[None]])
    face = end if pole is not None else axes[0, 2]
    radius = float(pipe.ring_radii[row])
    return Piece(points, end, face, radius, radius, end, face)


def miter_tips(pipe):
    """(N, 3) how far a capsule of the ring radius must run out from each corner point
    to hold its mitred ring's outside: ``(stretch - 1) rho`` outwards in the bend plane
    (the ring reaches ``stretch * rho``), but no farther than ``stretch * rho *
    cos(pi / sides)``, which the ring's polygon always reaches, so the capsule's axis
    stays inside the tube (the corner point itself where the path runs straight,
    reverses or ends)."""
    stretch = pipe.miter_stretch
    lean = np.where(np.isfinite(stretch), np.minimum(stretch - 1.0, stretch * np.cos(
        np.pi / pipe.sides)), 0.0) * pipe.ring_radii
    return pipe.path.points - lean[:, None] * pipe.path.bend_directions


def hull_groups(pipe, segments, at_joint):
    """``[(first, last)]``: the sorted ``segments`` in runs whose units one convex hull
    may replace, because the path between them strays from its chord by at most half
    the ring polygon's own chordal deviation (the hull fills the inside of a bend by
    about that much). A joint ends a run. With a radius far larger than the bends, a
    whole stretch is one hull instead of hundreds of nearly equal ones."""
    points, radii = pipe.path.points, pipe.ring_radii
    slack = 0.5 * (1 - np.cos(np.pi / pipe.sides))
    groups = []
    for k in np.asarray(segments).tolist():
        if groups and groups[-1][1] == k - 1 and not at_joint[k] and k + 1 < len(points):
            first = groups[-1][0]
            chord = points[k + 1] - points[first]
            inner = points[first + 1:k + 1] - points[first]
            along = np.clip(inner @ chord / max(float(chord @ chord), 1e-300), 0, 1)
            stray = np.linalg.norm(inner - along[:, None] * chord, axis=1).max()
            if stray <= slack * float(radii[first:k + 2].min()):
                groups[-1] = (first, k)
                continue
        groups.append((k, k))
    return groups


def ball_points(centre, radius):
    """(P, 3) points whose convex hull contains the ball of ``radius`` about ``centre``
    with a margin (:data:`~cadpipe.geometry.clearance.BALL_REACH`): a latitude-longitude
    sphere whose faces all lie beyond the ball."""
    lon = 2 * np.pi * np.arange(BALL_SIDES) / BALL_SIDES
    lat = np.pi * (np.arange(1, BALL_SIDES // 2) / (BALL_SIDES // 2) - 0.5)
    ring = np.stack([np.cos(lat)[:, None] * np.cos(lon), np.cos(lat)[:, None] * np.sin(lon),
                     np.broadcast_to(np.sin(lat)[:, None], (len(lat), len(lon)))], -1)
    unit = np.concatenate([ring.reshape(-1, 3), [[0, 0, -1], [0, 0, 1]]])
    return centre + (BALL_REACH * radius) * unit


