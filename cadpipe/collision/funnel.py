"""The bounding-volume funnel as two compiled loops: place objects, then test pairs.

A robot state has a handful of links and obstacles; in numpy each of the
funnel's steps is a call on arrays of a few dozen numbers, and a state costs
~200 such calls (about 40 us of call overhead before any arithmetic). These
two kernels, compiled by numba, do the same work in one call each, for one
state or for thousands (``check()`` is ``check_path``'s batch of one):

* :func:`place` puts objects at poses: the world 18-DOP from the object's
  support points (padded balls for chains), widened by the rounding slack, and
  the OBB moved with the object;
* :func:`decide` takes (slot, slot) entries and says which stage proves each
  apart: the AABB (the 18-DOP's first three slabs), the whole 18-DOP, the OBB
  by the separating-axis theorem (15 axes, Gottschalk et al. 1996), the convex
  pieces by GJK (:mod:`cadpipe.collision.convex`: a mesh's hull against the
  other's hull or a pipe's units; two chains skip it, their exact test is
  analytic anyway), or none (the entry goes on to the exact narrow phase).

The arithmetic is the one :mod:`cadpipe.collision.bounds` documents; each
test errs towards "overlap" (slack relative to the boxes' size), so a pair a
stage calls apart is apart.
"""

import numba
import numpy as np

from cadpipe.collision.bounds import KDOP_DIRECTIONS
from cadpipe.collision.convex import FUNNEL_ITERATIONS, body_gap

#: stage codes :func:`decide` writes (indices into ``world.STAGES``)
AABB, KDOP, OBB, HULL = 1, 2, 3, 4
#: written for entries no bounding volume separates
NARROW = -1
#: a numpy-level 64 ulp of rounding per placed coordinate
_EPS64 = 64 * np.finfo(float).eps

_jit = numba.njit(cache=True, nogil=True, fastmath=False)


@_jit
def place(points, pads, starts, slack, obb_centre, obb_axes, ids, poses, kdop, centre, axes,
          rows):
    """Place objects ``ids`` (E,) at ``poses`` (E, 4, 4) into rows ``rows`` (E,) of
    ``kdop`` (R, 2, 9), ``centre`` (R, 3) and ``axes`` (R, 3, 3).

    ``points`` (S, 3) and ``pads`` (S,) are every object's support points, object
    ``i``'s at ``starts[i]:starts[i + 1]``; ``slack`` (N,) their rounding slack;
    ``obb_centre`` (N, 3), ``obb_axes`` (N, 3, 3) the local OBBs.
    """
    for e in range(len(ids)):
        _place_one(points, pads, starts, slack, obb_centre, obb_axes, ids[e], poses[e],
                   kdop[rows[e]], centre[rows[e]], axes[rows[e]])


@_jit
def _place_one(points, pads, starts, slack, obb_centre, obb_axes, i, m, kdop, centre, axes):
    """Object ``i`` at pose ``m``: its (2, 9) 18-DOP, (3,) OBB centre, (3, 3) axes."""
    margin = slack[i] + _EPS64 * max(abs(m[0, 3]), abs(m[1, 3]), abs(m[2, 3]))
    for d in range(9):
        # the world direction turned into the object's frame
        u0 = KDOP_DIRECTIONS[d, 0] * m[0, 0] + KDOP_DIRECTIONS[d, 1] * m[1, 0] \
            + KDOP_DIRECTIONS[d, 2] * m[2, 0]
        u1 = KDOP_DIRECTIONS[d, 0] * m[0, 1] + KDOP_DIRECTIONS[d, 1] * m[1, 1] \
            + KDOP_DIRECTIONS[d, 2] * m[2, 1]
        u2 = KDOP_DIRECTIONS[d, 0] * m[0, 2] + KDOP_DIRECTIONS[d, 1] * m[1, 2] \
            + KDOP_DIRECTIONS[d, 2] * m[2, 2]
        low, high = np.inf, -np.inf
        for s in range(starts[i], starts[i + 1]):
            p = u0 * points[s, 0] + u1 * points[s, 1] + u2 * points[s, 2]
            low = min(low, p - pads[s])
            high = max(high, p + pads[s])
        offset = KDOP_DIRECTIONS[d, 0] * m[0, 3] + KDOP_DIRECTIONS[d, 1] * m[1, 3] \
            + KDOP_DIRECTIONS[d, 2] * m[2, 3]
        kdop[0, d] = low + offset - margin
        kdop[1, d] = high + offset + margin
    for r in range(3):
        centre[r] = m[r, 3] + m[r, 0] * obb_centre[i, 0] + m[r, 1] * obb_centre[i, 1] \
            + m[r, 2] * obb_centre[i, 2]
        for c in range(3):
            axes[r, c] = m[r, 0] * obb_axes[i, 0, c] + m[r, 1] * obb_axes[i, 1, c] \
                + m[r, 2] * obb_axes[i, 2, c]


@_jit
def _apart_on(axis, offset, axes_a, half_a, axes_b, half_b, slack):
    """Whether ``axis`` (3,) separates the two boxes (their centres ``offset`` apart)."""
    gap = abs(axis[0] * offset[0] + axis[1] * offset[1] + axis[2] * offset[2])
    reach = 0.0
    for c in range(3):
        reach += half_a[c] * abs(axis[0] * axes_a[0, c] + axis[1] * axes_a[1, c]
                                 + axis[2] * axes_a[2, c])
        reach += half_b[c] * abs(axis[0] * axes_b[0, c] + axis[1] * axes_b[1, c]
                                 + axis[2] * axes_b[2, c])
    return gap > reach + slack


@_jit
def _obb_apart(ca, xa, ha, cb, xb, hb):
    """The separating-axis test of two placed OBBs (centre, axes as columns, half)."""
    offset = cb - ca
    size = 0.0
    for r in range(3):
        size += abs(offset[r]) + ha[r] + hb[r]
    slack = 1e-12 * size
    axis = np.empty(3)
    for c in range(3):
        if _apart_on(xa[:, c], offset, xa, ha, xb, hb, slack) or \
                _apart_on(xb[:, c], offset, xa, ha, xb, hb, slack):
            return True
    for i in range(3):
        for j in range(3):
            a, b = xa[:, i], xb[:, j]
            axis[0] = a[1] * b[2] - a[2] * b[1]
            axis[1] = a[2] * b[0] - a[0] * b[2]
            axis[2] = a[0] * b[1] - a[1] * b[0]
            if _apart_on(axis, offset, xa, ha, xb, hb, slack):
                return True
    return False


@_jit
def _decide_pair(kdop, centre, axes, half_a, half_b, a, b, pieces, chain, i, m_i, j, m_j):
    """The first stage that proves slots ``a`` and ``b`` (objects ``i`` and ``j`` at
    poses ``m_i``, ``m_j``) apart, or :data:`NARROW`. ``pieces`` are the arguments
    of :func:`~cadpipe.collision.convex.body_gap` before the objects, or None to
    skip the hull stage (``certify=True`` leaves those pairs to the certificate);
    ``chain`` (N,) marks the chains."""
    for d in range(9):
        if kdop[a, 0, d] > kdop[b, 1, d] or kdop[b, 0, d] > kdop[a, 1, d]:
            return AABB if d < 3 else KDOP
    if _obb_apart(centre[a], axes[a], half_a, centre[b], axes[b], half_b):
        return OBB
    if pieces is not None and not (chain[i] and chain[j]):
        points, pads, starts, ball_centre, ball_radius, owned = pieces
        if body_gap(points, pads, starts, ball_centre, ball_radius, owned, i, m_i, j, m_j,
                    0.0, FUNNEL_ITERATIONS) > 0.0:
            return HULL
    return NARROW


@_jit
def decide(kdop, centre, axes, half_of, slot_a, slot_b, pieces, chain, object_of, slot_poses,
           codes):
    """For each entry ``(slot_a[k], slot_b[k])`` write into ``codes[k]`` the first
    stage that proves it apart (:data:`AABB`, :data:`KDOP`, :data:`OBB`,
    :data:`HULL`) or :data:`NARROW`. ``half_of`` (R, 3) is each slot's OBB half
    extents, ``object_of`` (R,) its object and ``slot_poses`` (R, 4, 4) its pose."""
    for k in range(len(slot_a)):
        a, b = slot_a[k], slot_b[k]
        codes[k] = _decide_pair(kdop, centre, axes, half_of[a], half_of[b], a, b, pieces,
                                chain, object_of[a], slot_poses[a], object_of[b],
                                slot_poses[b])


@_jit
def refresh(points, pads, starts, slack, obb_centre, obb_axes, half, poses, versions,
            placed_at, kdop, centre, axes, first, second, same, chosen, at_a, at_b, code,
            colliding, exact, hits, pieces, chain):
    """One state where the objects stand, brought up to date in one call.

    Objects whose pose version (``versions`` (N,)) differs from the one their
    bounds were placed at (``placed_at``) are placed again; every ``chosen`` pair
    whose answer is older than its objects' versions (``at_a``, ``at_b``) is
    tried by the bounding volumes, and the answer stored (``code``,
    ``colliding``) where one proves it apart. The pairs left for the exact
    phase are written to ``exact``, self pairs (``same``) first, each group in
    pair order; returns how many. ``pieces`` and ``chain`` are as for
    :func:`decide`. ``hits`` (2,) is set to whether a chosen pair
    whose answer holds collides: a self pair, another pair.
    """
    for i in range(len(versions)):
        if placed_at[i] != versions[i]:
            _place_one(points, pads, starts, slack, obb_centre, obb_axes, i, poses[i],
                       kdop[i], centre[i], axes[i])
            placed_at[i] = versions[i]
    count = 0
    for own in (True, False):
        for k in range(len(first)):
            if not chosen[k] or same[k] != own:
                continue
            a, b = first[k], second[k]
            if at_a[k] == versions[a] and at_b[k] == versions[b]:
                if colliding[k]:
                    hits[0 if own else 1] = True
                continue
            found = _decide_pair(kdop, centre, axes, half[a], half[b], a, b, pieces, chain,
                                 a, poses[a], b, poses[b])
            if found == NARROW:
                exact[count] = k
                count += 1
            else:
                code[k], colliding[k] = found, False
                at_a[k], at_b[k] = versions[a], versions[b]
    return count


@_jit
def summarize(chosen, same, allowed, stopped, first, second, versions, at_a, at_b, code,
              colliding, out_code, out_colliding, allowed_code, unchecked_code):
    """A report's (P,) stage codes and collisions from the stored answers: a chosen
    pair whose answer holds keeps it (world pairs only when not ``stopped``),
    allowed pairs get ``allowed_code``, every other pair ``unchecked_code``."""
    for k in range(len(first)):
        holds = chosen[k] and at_a[k] == versions[first[k]] and at_b[k] == versions[second[k]]
        holds = holds and (same[k] or not stopped)
        out_code[k] = allowed_code if allowed[k] else code[k] if holds else unchecked_code
        out_colliding[k] = holds and colliding[k]
