"""The bounding-volume funnel as compiled loops: place objects, then test pairs.

A robot state has a handful of links and obstacles; in numpy each of the
funnel's steps is a call on arrays of a few dozen numbers, and a state costs
~200 such calls (about 40 us of call overhead before any arithmetic). These
kernels, compiled by numba, do the same work in one call each:

* :func:`place` puts objects at poses: the world 18-DOP from the object's
  support points (padded balls for chains), widened by the rounding slack, and
  the OBB moved with the object;
* :func:`decide` takes (slot, slot) entries and says which stage proves each
  apart: the AABB (the 18-DOP's first three slabs), the whole 18-DOP, the OBB
  by the separating-axis theorem (15 axes, Gottschalk et al. 1996), the convex
  pieces by GJK (:mod:`cadpipe.collision.convex`: a mesh's hull against the
  other's hull or a pipe's units; two chains skip it, their exact test is
  analytic anyway), or none (the entry goes on to the exact narrow phase);
* :func:`refresh` is one state where the objects stand (``check()``): it
  places what moved, takes every pair whose answer is older than its objects'
  poses down the same stages, settles pairs with a chain exactly
  (:func:`cadpipe.collision.narrow.settle`) and writes the report, all in one
  call on the world's :class:`~cadpipe.collision.packed.Packed` record.

``place`` + ``decide`` serve many configurations at once (``check_path``,
``check_many``), ``refresh`` one; they share every stage function and the exact
walks, so a batch and its states one by one get the same answers.

The arithmetic is the one :mod:`cadpipe.collision.bounds` documents; each
test errs towards "overlap" (slack relative to the boxes' size), so a pair a
stage calls apart is apart.
"""

import numba
import numpy as np

from cadpipe.collision.bounds import KDOP_DIRECTIONS
from cadpipe.collision.convex import FUNNEL_ITERATIONS, body_gap
from cadpipe.collision.narrow import UNSETTLED, relative_into, settle

#: stage codes :func:`decide` writes (indices into ``world.STAGES``)
AABB, KDOP, OBB, HULL = 1, 2, 3, 4
#: the codes :func:`refresh`'s report gives allowed pairs and pairs it did not decide
ALLOWED, NOT_CHECKED = 0, 9
#: written for entries no bounding volume separates (left to the exact phase)
NARROW = UNSETTLED
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
    # each world direction turned into the object's frame; the support points are
    # the outer loop, so the 18 running extremes are independent of each other (the
    # same values as a loop per direction, about 1.3x sooner)
    u = np.empty((9, 3))
    for d in range(9):
        for c in range(3):
            u[d, c] = KDOP_DIRECTIONS[d, 0] * m[0, c] + KDOP_DIRECTIONS[d, 1] * m[1, c] \
                + KDOP_DIRECTIONS[d, 2] * m[2, c]
        kdop[0, d], kdop[1, d] = np.inf, -np.inf
    for s in range(starts[i], starts[i + 1]):
        x, y, z, pad = points[s, 0], points[s, 1], points[s, 2], pads[s]
        for d in range(9):
            p = u[d, 0] * x + u[d, 1] * y + u[d, 2] * z
            kdop[0, d] = min(kdop[0, d], p - pad)
            kdop[1, d] = max(kdop[1, d], p + pad)
    for d in range(9):
        offset = KDOP_DIRECTIONS[d, 0] * m[0, 3] + KDOP_DIRECTIONS[d, 1] * m[1, 3] \
            + KDOP_DIRECTIONS[d, 2] * m[2, 3]
        kdop[0, d] = kdop[0, d] + offset - margin
        kdop[1, d] = kdop[1, d] + offset + margin
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
def _bounds_apart(kdop, centre, axes, half_a, half_b, a, b):
    """The first bounding volume that proves slots ``a`` and ``b`` apart
    (:data:`AABB`, :data:`KDOP`, :data:`OBB`), or :data:`NARROW`."""
    for d in range(9):
        if kdop[a, 0, d] > kdop[b, 1, d] or kdop[b, 0, d] > kdop[a, 1, d]:
            return AABB if d < 3 else KDOP
    if _obb_apart(centre[a], axes[a], half_a, centre[b], axes[b], half_b):
        return OBB
    return NARROW


@_jit
def _decide_pair(kdop, centre, axes, half_a, half_b, a, b, pieces, chain, i, m_i, j, m_j):
    """The first stage that proves slots ``a`` and ``b`` (objects ``i`` and ``j`` at
    poses ``m_i``, ``m_j``) apart, or :data:`NARROW`. ``pieces`` are the arguments
    of :func:`~cadpipe.collision.convex.body_gap` before the objects, or None to
    skip the hull stage (``certify=True`` leaves those pairs to the certificate);
    ``chain`` (N,) marks the chains (two chains skip it, their exact test is
    analytic anyway)."""
    found = _bounds_apart(kdop, centre, axes, half_a, half_b, a, b)
    if found == NARROW and pieces is not None and not (chain[i] or chain[j]):
        points, pads, starts, ball_centre, ball_radius, owned = pieces
        if body_gap(points, pads, starts, ball_centre, ball_radius, owned, i, m_i, j, m_j,
                    0.0, FUNNEL_ITERATIONS) > 0.0:
            return HULL
    return found


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
def _holds(w, k):
    """Whether pair ``k``'s stored answer is as new as its objects' poses."""
    return w.at_a[k] == w.versions[w.first[k]] and w.at_b[k] == w.versions[w.second[k]]


# numba keys a cached kernel by its own file only: a kernel compiled with the walks it
# calls (narrow.settle, chain_mesh.walk) keeps the old ones until this file changes too
@_jit
def refresh(w, chosen, first_hit, stop_after_self, out_code, out_colliding):
    """One state where the objects stand, decided in one call: ``w`` is the world's
    :class:`~cadpipe.collision.packed.Packed` record.

    Objects whose pose version differs from the one their bounds were placed
    at are placed again. Every ``chosen`` (P,) pair whose answer is older than
    its objects' poses goes down the funnel, self pairs (``w.same``) first, each
    group in pair order; a pair no bounding volume separates is settled
    exactly here when both objects are chains or one is (the capsule walks of
    :func:`cadpipe.collision.narrow.settle`), and otherwise left to the Python
    narrow phase (meshes through FCL, probes inside meshes, ``w.certify``):
    listed in ``w.left`` with the second object's pose in the first's frame in
    ``w.left_poses``. Every answer found is stored in ``w``. ``w.hits`` (2,)
    says whether a chosen pair whose answer holds collides: a self pair,
    another pair. With ``first_hit`` the pairs stop at the first collision,
    with ``stop_after_self`` the other pairs are skipped after a self-collision.

    The report's (P,) stage codes and collisions go to ``out_code`` and
    ``out_colliding``: a pair's answer where it holds (other pairs only when no
    self-collision stopped the check), :data:`ALLOWED` for allowed pairs,
    :data:`NOT_CHECKED` for the rest (the pairs left among them). Returns how
    many pairs were left.
    """
    versions, hits = w.versions, w.hits
    for i in range(len(versions)):
        if w.placed_at[i] != versions[i]:
            _place_one(w.points, w.pads, w.starts, w.slack, w.obb_centre, w.obb_axes, i,
                       w.poses[i], w.kdop[i], w.centre[i], w.axes[i])
            w.placed_at[i] = versions[i]
    hits[0], hits[1] = False, False
    if first_hit:                        # a collision already known answers at once
        for k in range(len(w.first)):
            if chosen[k] and w.colliding[k] and _holds(w, k):
                hits[0 if w.same[k] else 1] = True
    count = 0
    rel = np.empty((1, 4, 4))
    for own in (True, False):
        for k in range(len(w.first)):
            if (first_hit and (hits[0] or hits[1])) or (stop_after_self and not own
                                                         and hits[0]):
                break
            if not chosen[k] or w.same[k] != own:
                continue
            a, b = w.first[k], w.second[k]
            if _holds(w, k):
                if w.colliding[k]:
                    hits[0 if own else 1] = True
                continue
            found = _bounds_apart(w.kdop, w.centre, w.axes, w.half[a], w.half[b], a, b)
            touching = False
            if found == NARROW and not w.certify:
                if not (w.chain[a] or w.chain[b]) and body_gap(
                        w.piece_points, w.piece_pads, w.piece_starts, w.piece_centre,
                        w.piece_radius, w.pieces, a, w.poses[a], b, w.poses[b], 0.0,
                        FUNNEL_ITERATIONS) > 0.0:
                    found = HULL
                else:
                    found, touching = settle(w, a, w.poses[a:a + 1], b, w.poses[b:b + 1],
                                             rel)
            if found == NARROW:
                w.left[count] = k
                relative_into(w.poses[a:a + 1], w.poses[b:b + 1], w.left_poses[count:count + 1])
                count += 1
                continue
            w.code[k], w.colliding[k] = found, touching
            w.at_a[k], w.at_b[k] = versions[a], versions[b]
            if touching:
                hits[0 if own else 1] = True
    stopped = stop_after_self and hits[0]
    for k in range(len(w.first)):
        holds = chosen[k] and _holds(w, k) and (w.same[k] or not stopped)
        out_code[k] = ALLOWED if w.allowed[k] else w.code[k] if holds else NOT_CHECKED
        out_colliding[k] = holds and w.colliding[k]
    return count
