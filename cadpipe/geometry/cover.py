"""Round cones that hold convex pieces: the collision model of a pipe's mesh.

A pipe's mesh is a union of convex pieces (:meth:`cadpipe.Pipe.convex_pieces`): the
hull of two rings along a segment, a run of nearly straight segments as one hull, a
ball joint, a cap. The collision model (:meth:`cadpipe.Pipe.collision_units`) holds
each piece in round cones ``conv(B(a, ra), B(b, rb))`` (see
:mod:`cadpipe.collision.capsules`), so it contains the mesh by construction.

A piece is given with its spine ``a -> b`` (the centres of its end rings) and the
radii its rings nominally have there. With ``x`` a point's position along the spine
and ``rho`` its distance from the spine's line, the set ``rho <= R(x)`` for a linear
``R`` is convex, so the piece lies in it as soon as its points do: both radii grow by
the most any point sticks out (a taper into a mitred ring, a tongue, a hull of several
segments). Between the planes square to the spine at ``a`` and ``b`` that set is the
frustum of the two end discs, inside the round cone. Past ``b`` (a mitred ring leans
out beyond its corner) the piece is the hull of its points there and of its section in
``b``'s plane, a disc of radius ``R(L)``: a capsule from ``b`` towards the corner's
miter tip holds both; likewise before ``a``.
"""

import numpy as np

from cadpipe.geometry.pieces import cap_piece, miter_tips
from cadpipe.geometry.surfaces import ball_joint, cap_axes, joint_rows_of


def round_cone_covers(points, a, b, ra, rb, tip_a, tip_b):
    """Round cones whose union holds the convex hull of each piece's points.

    Parameters
    ----------
    points : (P, K, 3) float
        Each piece's points (its hull is the piece).
    a, b : (P, 3) float
        Each piece's spine; ``a == b`` makes its cover one ball about ``a``.
    ra, rb : (P,) float
        Nominal radii at ``a`` and ``b`` (the rings' own).
    tip_a, tip_b : (P, 3) float
        Where a capsule for points before ``a`` (past ``b``) runs from ``a`` (``b``):
        towards the miter tip of the corner there, or the point itself.

    Returns
    -------
    cones : tuple of (P, 3), (P, 3), (P,), (P,)
        The main round cone of each piece: starts, ends and their radii.
    before, past : tuple of (P, 3), (P,), (P,) bool
        The capsule from ``a`` towards ``tip_a`` (from ``b`` towards ``tip_b``): its
        other end, its radius, and whether the piece needs it (has points there).
    """
    axis = b - a
    length = np.linalg.norm(axis, axis=1)
    safe = np.where(length > 0, length, 1.0)
    d = axis / safe[:, None]
    rel = points - a[:, None]
    x = np.einsum("pkc,pc->pk", rel, d)
    rho = np.sqrt(np.maximum(np.einsum("pkc,pkc->pk", rel, rel) - x * x, 0.0))
    line = length > 0
    # a ball (no spine): the farthest point
    reach = np.sqrt(np.einsum("pkc,pkc->pk", rel, rel)).max(axis=1)
    nominal = ra[:, None] + (rb - ra)[:, None] * x / safe[:, None]
    grow = np.maximum((rho - nominal).max(axis=1), 0.0)
    start_r = np.where(line, ra + grow, reach)
    end_r = np.where(line, rb + grow, reach)
    covers = [(a, b, start_r, end_r)]
    for centre, tip, beyond, radius in ((a, tip_a, line[:, None] & (x < 0), start_r),
                                        (b, tip_b, line[:, None] & (x > length[:, None]),
                                         end_r)):
        gap = _to_segments(points, centre, tip - centre)
        need = np.where(beyond, gap, 0.0).max(axis=1)
        covers.append((tip, np.maximum(radius, need), beyond.any(axis=1)))
    return covers[0], covers[1], covers[2]


def _to_segments(points, start, vector):
    """(P, K) distance of each piece's points to its segment ``start + s vector``."""
    rel = points - start[:, None]
    size = np.einsum("pc,pc->p", vector, vector)
    s = np.einsum("pkc,pc->pk", rel, vector) / np.where(size > 0, size, 1.0)[:, None]
    s = np.clip(s, 0.0, 1.0)
    off = rel - s[..., None] * vector[:, None]
    return np.sqrt(np.einsum("pkc,pkc->pk", off, off))
def segment_covers(pipe, segments):
    """The collision units (starts, ends, start radii, end radii) of the plain tube along
    ``segments`` (laid out as :meth:`Pipe.surface` lays it out): each segment's unit,
    the capsules of its mitred corners, its ball joints and the caps of its ends."""
    n = len(pipe.path)
    empty = (np.empty((0, 3)), np.empty((0, 3)), np.empty(0), np.empty(0))
    if not len(segments):
        return empty
    centres, radii = pipe.path.points, pipe.ring_radii
    start_ring, end_ring, joints = laid_rings(pipe)
    tips = miter_tips(pipe)
    joint_units = []
    for row, (outer, swept) in joints.items():
        tips[row] = centres[row]
        reach_ = float(np.linalg.norm(swept[:, outer] - centres[row], axis=2).max())
        joint_units.append((centres[row], centres[row], reach_, reach_))
    a, b = np.asarray(segments), (np.asarray(segments) + 1) % n
    wedge = np.zeros(n)
    need = np.zeros(n, bool)
    cones = []
    for rows in np.array_split(np.arange(len(a)), max(1, len(a) // COVER_BLOCK)):
        ka, kb = a[rows], b[rows]
        cone, before, past = round_cone_covers(
            np.concatenate([start_ring[ka], end_ring[kb]], axis=1), centres[ka], centres[kb],
            radii[ka], radii[kb], tips[ka], tips[kb])
        cones.append(cone)
        for at, (_, radius, needed) in ((ka, before), (kb, past)):
            np.maximum.at(wedge, at, np.where(needed, radius, 0.0))
            need[at] |= needed
    corner = np.flatnonzero(need)
    units = [tuple(np.concatenate([c[k] for c in cones]) for k in range(4)),
             (centres[corner], tips[corner], wedge[corner], wedge[corner])]
    if joint_units:
        units.append(tuple(np.array(v) for v in zip(*joint_units)))
    if not pipe.closed:
        caps = []
        for row, sign, seg, style in ((0, -1, 0, pipe.cap_styles[0]),
                                      (n - 1, 1, len(pipe.path.segments) - 1,
                                       pipe.cap_styles[1])):
            cap = cap_axes(pipe._tubes, row, sign, pipe, style)
            if cap is not None and seg in set(np.asarray(segments).tolist()):
                caps.append(cap_piece(pipe, row, cap, [end_ring[row]]))
        if caps:
            units.append(piece_covers(caps))
    return tuple(np.concatenate([u[k] for u in units]) for k in range(4))


def laid_rings(pipe):
    """The rings the plain tube's side is laid out on, as :meth:`Pipe.surface` lays it
    out: ``(starts, ends, joints)``, (N, sides, 3) the ring each segment leaves from
    and the one it arrives at (the ring itself, or at a ball joint the joint's last and
    first ring), and ``{row: (outer, rings)}`` each ball joint (:func:`ball_joint`)."""
    with np.errstate(invalid="ignore"):             # a reversal's ring: not used (a joint)
        rings = pipe.rings()
    starts, ends = rings.copy(), rings
    joints = {}
    for row in np.flatnonzero(joint_rows_of(pipe._tubes, 0, len(pipe.path) - 1, pipe)).tolist():
        joints[row] = ball_joint(pipe._tubes, row, pipe)
        ends[row], starts[row] = joints[row][1][0], joints[row][1][-1]
    return starts, ends, joints


def piece_covers(pieces):
    """The collision units of convex pieces (:class:`Piece`): their round cone covers
    (:func:`~cadpipe.geometry.cover.round_cone_covers`), one piece at a time."""
    units = []
    for piece in pieces:
        cone, before, past = round_cone_covers(
            piece.points[None], piece.a[None], piece.b[None], np.array([piece.ra]),
            np.array([piece.rb]), piece.tip_a[None], piece.tip_b[None])
        units.append(cone)
        for centre, (tip, radius, needed) in ((piece.a, before), (piece.b, past)):
            if needed[0]:
                units.append((centre[None], tip, radius, radius))
    return tuple(np.concatenate([u[k] for u in units]) for k in range(4))


#: segments whose covers are computed at once (bounds the memory of their points)
COVER_BLOCK = 4096


