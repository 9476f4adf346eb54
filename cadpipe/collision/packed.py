"""A world's arrays as one compiled record, so one state is one kernel call.

:func:`cadpipe.collision.funnel.refresh` decides one state where the objects
stand: it places the objects that moved, tries every pair whose answer is
older than its objects' poses, settles the pairs of pipes and other chains
exactly, and writes the report's arrays. It reads some fifty arrays (the
objects' bounds and convex pieces, the pair table, the capsule and triangle
trees, each pair's last answer). numba checks and converts every array
argument on every call, about 0.15 us each on a quiet machine and several
times that under load: as separate arguments they cost more than a pipe's
whole yes/no walk. A :class:`Packed` record (a numba StructRef) passes them as
one argument, converted in about a microsecond, and its type is fixed, so the
kernel is compiled once and cached like the others.

The record holds the arrays themselves, not copies: the scene's poses and
pose versions, the checker's placed bounds and stored answers are the same
memory the Python side reads, so a record stays valid for as long as the
layout it was made for (:class:`cadpipe.collision.world.Checker` makes a new
one when the layout changes). It also holds the last call's scratch (the pairs
left to Python, the hits), so one world takes one check at a time, as its
stored answers already required.
"""

import numba
import numpy as np
from numba.core import types
from numba.experimental import structref


@structref.register
class PackedType(types.StructRef):
    """numba's type of a :class:`Packed` record."""

    def preprocess_fields(self, fields):
        return tuple((name, types.unliteral(t)) for name, t in fields)


class Packed(structref.StructRefProxy):
    """A world's arrays for :func:`cadpipe.collision.funnel.refresh`; see
    :data:`FIELDS` and :func:`pack`."""


structref.define_boxing(PackedType, Packed)

_F1, _F2, _F3 = types.float64[::1], types.float64[:, ::1], types.float64[:, :, ::1]
_I1, _I2 = types.int64[::1], types.int64[:, ::1]
_B1 = types.boolean[::1]

#: the record's fields: N objects, P pairs (``np.triu_indices`` order)
FIELDS = (
    # the 18-DOPs' support points of every object (object i's at starts[i]:starts[i + 1])
    ("points", _F2), ("pads", _F1), ("starts", _I1),
    # per object: rounding slack, the local OBB, whether it is a chain, whether closed
    ("slack", _F1), ("obb_centre", _F2), ("obb_axes", _F3), ("half", _F2),
    ("chain", _B1), ("closed", _B1),
    # the pair table
    ("first", _I1), ("second", _I1), ("same", _B1), ("allowed", _B1),
    # the convex pieces (cadpipe.collision.convex.Pieces.arrays())
    ("piece_points", _F2), ("piece_pads", _F1), ("piece_starts", _I1),
    ("piece_centre", _F2), ("piece_radius", _F1), ("pieces", _I1),
    # every chain's capsule tree (hierarchy.CapsuleTree), object i's nodes at
    # tree_at[i]:tree_at[i + 1] and points at tree_points_at[i]:tree_points_at[i + 1]
    ("tree_table", _F2), ("tree_index", _I2), ("tree_points", _F2), ("tree_at", _I1),
    ("tree_points_at", _I1), ("tree_depth", _I1),
    # the triangle trees (chain_mesh.TriangleTree) of meshes paired with a chain
    ("mesh_boxes", _F2), ("mesh_frames", _F2), ("mesh_triangles", _F2), ("boxes_at", _I1),
    ("frames_at", _I1), ("triangles_at", _I1), ("mesh_depth", _I1),
    # the containment prefilter: a chain's probes and extremes, a mesh's inside_filter
    ("probes", _F2), ("probes_at", _I1), ("extremes", _F3), ("inside_lo", _F2),
    ("inside_hi", _F2), ("inside_low", _F2), ("inside_high", _F2), ("inside_slack", _F1),
    # where the objects stand: the scene's poses and pose versions
    ("poses", _F3), ("versions", _I1),
    # each object's placed bounds and the pose version they were placed at
    ("placed_at", _I1), ("kdop", _F3), ("centre", _F2), ("axes", _F3),
    # each pair's last answer and the pose versions it holds for
    ("at_a", _I1), ("at_b", _I1), ("code", types.int8[::1]), ("colliding", _B1),
    # the last call's pairs left to Python (pair indices, in order; the second object's
    # pose in the first's frame), and whether a self pair, another pair collides
    ("left", _I1), ("left_poses", _F3), ("hits", _B1),
    # certify: no hull stage, and every exact pair is left to Python (the certificate)
    ("certify", types.boolean),
)
PACKED = PackedType(list(FIELDS))


@numba.njit(cache=True)
def _new(points, pads, starts, slack, obb_centre, obb_axes, half, chain, closed,
         first, second, same, allowed,
         piece_points, piece_pads, piece_starts, piece_centre, piece_radius, pieces,
         tree_table, tree_index, tree_points, tree_at, tree_points_at, tree_depth,
         mesh_boxes, mesh_frames, mesh_triangles, boxes_at, frames_at, triangles_at, mesh_depth,
         probes, probes_at, extremes, inside_lo, inside_hi, inside_low, inside_high,
         inside_slack, poses, versions, placed_at, kdop, centre, axes,
         at_a, at_b, code, colliding, left, left_poses, hits, certify):
    # the fields one by one, in FIELDS order (numba sets no field by name at run time)
    w = structref.new(PACKED)
    w.points, w.pads, w.starts = points, pads, starts
    w.slack, w.obb_centre, w.obb_axes, w.half = slack, obb_centre, obb_axes, half
    w.chain, w.closed = chain, closed
    w.first, w.second, w.same, w.allowed = first, second, same, allowed
    w.piece_points, w.piece_pads, w.piece_starts = piece_points, piece_pads, piece_starts
    w.piece_centre, w.piece_radius, w.pieces = piece_centre, piece_radius, pieces
    w.tree_table, w.tree_index, w.tree_points = tree_table, tree_index, tree_points
    w.tree_at, w.tree_points_at, w.tree_depth = tree_at, tree_points_at, tree_depth
    w.mesh_boxes, w.mesh_frames, w.mesh_triangles = mesh_boxes, mesh_frames, mesh_triangles
    w.boxes_at, w.frames_at = boxes_at, frames_at
    w.triangles_at, w.mesh_depth = triangles_at, mesh_depth
    w.probes, w.probes_at, w.extremes = probes, probes_at, extremes
    w.inside_lo, w.inside_hi, w.inside_low, w.inside_high = inside_lo, inside_hi, inside_low, \
        inside_high
    w.inside_slack = inside_slack
    w.poses, w.versions = poses, versions
    w.placed_at, w.kdop, w.centre, w.axes = placed_at, kdop, centre, axes
    w.at_a, w.at_b, w.code, w.colliding = at_a, at_b, code, colliding
    w.left, w.left_poses, w.hits = left, left_poses, hits
    w.certify = certify
    return w


def pack(**arrays):
    """A :class:`Packed` record of ``arrays`` (one per name of :data:`FIELDS`, each
    already of the field's dtype, C-ordered and writeable: the record shares
    them, it does not copy)."""
    values = []
    for name, kind in FIELDS:
        value = arrays.pop(name)
        if isinstance(kind, types.Array):
            value = np.asarray(value)
            if value.dtype != np.dtype(str(kind.dtype)) or value.ndim != kind.ndim or \
                    not value.flags.c_contiguous or not value.flags.writeable:
                raise TypeError(f"packed field {name}: need a writeable C-ordered "
                                f"{kind.ndim}-d {kind.dtype} array, got {value.dtype} "
                                f"{value.shape} {value.flags}")
        values.append(value)
    if arrays:
        raise TypeError(f"not a packed field: {', '.join(arrays)}")
    return _new(*values)


class Direct:
    """``kernel`` called through its compiled entry point for the argument types of
    its first call (:meth:`numba.core.dispatcher.Dispatcher.compile`: from numba's
    cache, or compiled then).

    numba's dispatcher types every argument on every call: about 0.9 us for
    :func:`~cadpipe.collision.funnel.refresh`'s record and five arrays, where the
    kernel itself takes 0.4 us for a state nothing moved in. A caller that
    always passes the same types need not pay it. Only for such internal calls:
    an argument of another type would be misread, not converted.
    """

    def __init__(self, kernel):
        self.kernel, self._entry = kernel, None

    def __call__(self, *args):
        entry = self._entry
        if entry is None:
            entry = self._entry = self.kernel.compile(tuple(numba.typeof(a) for a in args))
        return entry(*args)
