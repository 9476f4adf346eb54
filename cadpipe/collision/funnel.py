"""The bounding-volume funnel as compiled loops: place objects, then test pairs.

A robot state has a handful of links and obstacles; in numpy each of the
funnel's steps is a call on arrays of a few dozen numbers, and a state costs
~200 such calls (about 40 us of call overhead before any arithmetic). These
kernels (C, ``csrc/funnel.c``) do the same work in one call each:

* :func:`place` puts objects at poses: the world 18-DOP from the object's
  support points (padded balls for chains), widened by the rounding slack, and
  the OBB moved with the object;
* :func:`decide` takes (slot, slot) entries and says which stage proves each
  apart: the AABB (the 18-DOP's first three slabs), the whole 18-DOP, the OBB
  by the separating-axis theorem (15 axes, Gottschalk et al. 1996), the convex
  pieces by GJK (:mod:`cadpipe.collision.convex`: a mesh's hull against the
  other's hull or a pipe's units; two chains skip it, their exact test is
  analytic anyway), or none (the entry goes on to the exact narrow phase);
* ``native.refresh(record, chosen, first_hit, stop_after_self, out_code,
  out_colliding)`` is one state where the objects stand (``check()``), on the
  world's :class:`~cadpipe.collision.packed.Packed` record. It places the
  objects whose pose version differs from the one their bounds were placed
  at; takes every ``chosen`` (P,) pair whose answer is older than its objects'
  poses down the same stages, self pairs first, each group in pair order;
  settles a pair with a chain exactly (the capsule walks of
  :mod:`cadpipe.collision.narrow`'s compiled ``settle``) and leaves the others
  to the Python narrow phase (meshes through FCL, probes inside meshes,
  ``certify``), listed in the record's ``left`` with the second object's pose
  in the first's frame in ``left_poses``. Every answer found is stored in the
  record; its ``hits`` (2,) says whether a chosen pair whose answer holds
  collides (a self pair, another pair). With ``first_hit`` the pairs stop at
  the first collision, with ``stop_after_self`` the other pairs are skipped
  after a self-collision. The report's (P,) stage codes and collisions go to
  ``out_code`` and ``out_colliding``: a pair's answer where it holds (other
  pairs only when no self-collision stopped the check), :data:`ALLOWED` for
  allowed pairs, :data:`NOT_CHECKED` for the rest (the pairs left among them).
  It returns how many pairs were left.

``place`` + ``decide`` serve many configurations at once (``check_path``,
``check_many``), ``refresh`` one; they share every stage function and the exact
walks, so a batch and its states one by one get the same answers.

The arithmetic is the one :mod:`cadpipe.collision.bounds` documents; each
test errs towards "overlap" (slack relative to the boxes' size), so a pair a
stage calls apart is apart.
"""

import numpy as np

from cadpipe.collision.bounds import KDOP_DIRECTIONS
from cadpipe.collision.convex import FUNNEL_ITERATIONS
from cadpipe.collision.narrow import UNSETTLED
from cadpipe.core.kernels import native

#: stage codes :func:`decide` writes (indices into ``reports.STAGES``)
AABB, KDOP, OBB, HULL = 1, 2, 3, 4
#: the codes ``native.refresh``'s report gives allowed pairs and pairs it did not decide
ALLOWED, NOT_CHECKED = 0, 9
#: written for entries no bounding volume separates (left to the exact phase)
NARROW = UNSETTLED

_C = native.collision_constants()
if (_C["AABB"], _C["KDOP"], _C["OBB"], _C["HULL"], _C["ALLOWED"], _C["NOT_CHECKED"],
        _C["NARROW"], _C["FUNNEL_ITERATIONS"]) != (AABB, KDOP, OBB, HULL, ALLOWED,
                                                    NOT_CHECKED, NARROW, FUNNEL_ITERATIONS) \
        or not np.array_equal(np.reshape(_C["KDOP_DIRECTIONS"], (9, 3)), KDOP_DIRECTIONS):
    raise ImportError("cadpipe's funnel kernels were built with other stage codes or "
                      "directions than cadpipe.collision.funnel and bounds hold")


def _f64(value):
    return np.ascontiguousarray(value, np.float64)


def _i64(value):
    return np.ascontiguousarray(value, np.int64)


def place(points, pads, starts, slack, obb_centre, obb_axes, ids, poses, kdop, centre, axes,
          rows):
    """Place objects ``ids`` (E,) at ``poses`` (E, 4, 4) into rows ``rows`` (E,) of
    ``kdop`` (R, 2, 9), ``centre`` (R, 3) and ``axes`` (R, 3, 3) (C-ordered float64,
    written in place).

    ``points`` (S, 3) and ``pads`` (S,) are every object's support points, object
    ``i``'s at ``starts[i]:starts[i + 1]``; ``slack`` (N,) their rounding slack;
    ``obb_centre`` (N, 3), ``obb_axes`` (N, 3, 3) the local OBBs.
    """
    native.place_bounds(_f64(points), _f64(pads), _i64(starts), _f64(slack), _f64(obb_centre),
                        _f64(obb_axes), _i64(ids), _f64(poses), kdop, centre, axes, _i64(rows))


def decide(kdop, centre, axes, half_of, slot_a, slot_b, pieces, chain, object_of, slot_poses,
           codes):
    """For each entry ``(slot_a[k], slot_b[k])`` write into ``codes[k]`` (int8) the first
    stage that proves it apart (:data:`AABB`, :data:`KDOP`, :data:`OBB`,
    :data:`HULL`) or :data:`NARROW`. ``half_of`` (R, 3) is each slot's OBB half
    extents, ``object_of`` (R,) its object and ``slot_poses`` (R, 4, 4) its pose;
    ``pieces`` the arrays of :meth:`cadpipe.collision.convex.Pieces.arrays`, or None
    to skip the hull stage (``certify=True`` leaves those pairs to the certificate);
    ``chain`` (N,) marks the chains (two chains skip it, their exact test is
    analytic anyway)."""
    if pieces is not None:
        pieces = tuple(pieces)
    native.decide_pairs(_f64(kdop), _f64(centre), _f64(axes), _f64(half_of), _i64(slot_a),
                        _i64(slot_b), pieces, np.ascontiguousarray(chain, np.bool_),
                        _i64(object_of), _f64(slot_poses), codes)
