"""Booleans through manifold3d: validated solids in, one solid out.

manifold3d is robust but trusting: it accepts an inside-out mesh (negative
volume) and welds only nearly identical vertices. So every input goes through
:func:`as_solid`, which builds the manifold3d solid tagged with its own original
id (so each output triangle still knows its part) and checks what manifold3d
does not: a status, a positive volume, and shells that are either bodies or
voids inside a body. Shells of one mesh that overlap (an STL of two crossing
boxes) are unioned, as a slicer reads them. Meshes from files are welded first
with :func:`snap`.

:func:`combine` computes ``(union of adds - union of cuts) & every clip`` with
manifold3d's batch operations, and only where bounding boxes meet
(:func:`clusters`): parts that overlap nothing are never sent through a boolean.
:func:`~cadpipe.geometry.swept.float32_solid` makes a boolean result survive files
of float32 coordinates.
"""

import numpy as np

from cadpipe.errors import GeometryError, MeshError
from cadpipe.geometry.ragged import Groups
from cadpipe.geometry.mesh import Mesh, reserve_ids
from cadpipe.geometry.swept import snapped
from cadpipe.geometry.topology import connected_labels

#: :func:`snap` welds vertices closer than this fraction of the mesh's bounding-box diagonal
SNAP_TOLERANCE = 1e-6


def snap(mesh, tolerance=None):
    """Weld vertices closer than ``tolerance`` and drop the triangles that collapse
    (:func:`~cadpipe.geometry.swept.snapped`, the one weld by distance).

    Imported meshes often repeat a vertex with slightly different coordinates on
    each side of a seam (OBJ with six decimals, per-triangle STL corners); manifold3d
    would then see an open surface. Vertices within ``tolerance`` of each other
    (default :data:`SNAP_TOLERANCE` times the bounding-box diagonal) become one.
    """
    vertices = mesh.vertices
    if tolerance is None:
        tolerance = SNAP_TOLERANCE * float(np.linalg.norm(np.ptp(vertices, axis=0))) \
            if len(vertices) else 0.0
    return snapped(mesh, tolerance)


def as_solid(mesh, name, original_id):
    """A validated :class:`manifold3d.Manifold` of ``mesh`` whose triangles carry ``original_id``.

    Shells of ``mesh`` that overlap are unioned (their voids cut from the union).
    Raises :class:`MeshError` naming ``name`` when manifold3d rejects the mesh, when
    it encloses no volume or is inside out, or when one of its shells is inside out
    without being a void inside another shell.
    """
    solid = mesh.to_manifold(name, original_id)
    if solid.is_empty():
        raise MeshError("encloses no volume (every triangle is degenerate)", part=name)
    volume = solid.volume()
    if volume <= 0:
        raise MeshError(f"inside out (volume {volume:.6g}); flip its faces", part=name)
    return _united_shells(solid, name, original_id)


def _united_shells(solid, name, original_id):
    """``solid`` with overlapping shells unioned; every inside-out shell must be a void,
    wholly inside the outward shells, and is cut from them."""
    import manifold3d

    Manifold, Op = manifold3d.Manifold, manifold3d.OpType
    shells = solid.decompose()
    if len(shells) == 1:
        return solid
    volumes = np.array([s.volume() for s in shells])
    boxes = bounding_boxes(shells)
    i, j = overlap_pairs(boxes, boxes)
    if not np.any(i != j) and (volumes > 0).all():
        return solid                        # apart: bodies side by side
    body = Manifold.batch_boolean([shells[k] for k in np.flatnonzero(volumes > 0)], Op.Add)
    cavities = []
    for k in np.flatnonzero(volumes < 0):
        shell = Mesh.from_manifold(shells[k])
        cavity = Mesh.trusted(shell.vertices, shell.faces[:, ::-1]).to_manifold(
            f"{name} shell {k}", original_id)
        if (cavity - body).volume() > 1e-9 * cavity.volume():
            raise MeshError(f"shell {k} of {len(shells)} is inside out and not a void "
                            "inside another shell; flip its faces", part=name)
        cavities.append(cavity)
    return Manifold.batch_boolean([body, *cavities], Op.Subtract) if cavities else body


def bounding_boxes(solids):
    """(N, 2, 3) array of each solid's minimum and maximum corner."""
    return np.array([s.bounding_box() for s in solids], np.float64).reshape(-1, 2, 3)


def overlap_pairs(a, b):
    """Index pairs ``(i, j)`` where box ``a[i]`` meets box ``b[j]`` (touching counts).

    A sweep along x: boxes of ``b`` sorted by their lower x, so each box of ``a``
    only tests the ``b`` boxes whose x-range can reach it, all in numpy.
    """
    if not len(a) or not len(b):
        return np.empty(0, np.int64), np.empty(0, np.int64)
    order = np.argsort(b[:, 0, 0], kind="stable")
    lower = b[order, 0, 0]
    widest = float((b[:, 1, 0] - b[:, 0, 0]).max())
    start = np.searchsorted(lower, a[:, 0, 0] - widest, side="left")
    stop = np.searchsorted(lower, a[:, 1, 0], side="right")
    runs = Groups(stop - start)
    i = runs.index
    j = order[runs.local() + runs.spread(start)]
    hit = np.all((a[i, 0] <= b[j, 1]) & (b[j, 0] <= a[i, 1]), axis=1)
    return i[hit], j[hit]


def _groups(boxes):
    """Label of each box's cluster: boxes are linked when they overlap, transitively."""
    return connected_labels(len(boxes), *overlap_pairs(boxes, boxes))


def clusters(adds, cuts=None, clips=None):
    """The boolean work that bounding boxes leave: ``[(members, reach), ...]``.

    Parameters
    ----------
    adds, cuts, clips : (N, 2, 3) float
        Minimum and maximum corners of the added, cut and clipping solids.

    Returns
    -------
    clusters : list of ((K,) int, (L,) int)
        Per cluster of added solids linked by overlapping boxes, its members and the
        cuts whose boxes reach one of them. Clusters outside some clip's box (nothing
        of them is kept) are left out.
    """
    empty = np.empty((0, 2, 3))
    cuts = empty if cuts is None else cuts
    clips = empty if clips is None else clips
    if not len(adds):
        return []
    group = _groups(adds)
    add_i, cut_j = overlap_pairs(adds, cuts)
    members = np.split(np.argsort(group, kind="stable"), np.cumsum(np.bincount(group))[:-1])
    cuts_of = np.split(cut_j[np.argsort(group[add_i], kind="stable")],
                       np.cumsum(np.bincount(group[add_i], minlength=len(members)))[:-1])
    work = []
    for index, reach in zip(members, cuts_of):
        box = np.array([adds[index, 0].min(axis=0), adds[index, 1].max(axis=0)])
        if len(clips) and not np.all((box[0] <= clips[:, 1]) & (clips[:, 0] <= box[1])):
            continue
        work.append((index, np.unique(reach)))
    return work


#: a union of at least this many solids runs in batches, so that its progress can move
BATCHED_UNION = 64


def united(solids, progress=None):
    """The union of ``solids`` (manifold3d).

    One ``batch_boolean`` for a few (lazy, as manifold3d's operations are). For
    :data:`BATCHED_UNION` or more, about sqrt(n) batches of neighbours (slabs along
    the longest side of their boxes) are united one after the other, then joined
    in pairs, level by level, each call computed at once, and ``progress(done,
    total)`` is called after each of the ``2 * batches - 1`` calls: one manifold3d
    call that runs for a minute shows no progress, and it holds the interpreter.
    It costs no more than one call, and less for long crossing pipes (measured in
    ``benchmarks/bench_build.py``, figures in ``docs/performance.md``).
    """
    import manifold3d

    Manifold, Op = manifold3d.Manifold, manifold3d.OpType
    solids = list(solids)
    if len(solids) < BATCHED_UNION:
        return solids[0] if len(solids) == 1 else Manifold.batch_boolean(solids, Op.Add)
    centres = bounding_boxes(solids).mean(axis=1)
    axis = int(np.argmax(np.ptp(centres, axis=0)))
    level = [[solids[k] for k in batch] for batch in
             np.array_split(np.argsort(centres[:, axis], kind="stable"),
                            round(np.sqrt(len(solids))))]
    total, done = 2 * len(level) - 1, 0
    while True:
        pieces = []
        for members in level:
            piece = members[0] if len(members) == 1 else \
                Manifold.batch_boolean(members, Op.Add)
            if len(members) > 1:
                piece.num_tri()                  # manifold3d is lazy: work now
                done += 1
                if progress is not None:
                    progress(done, total)
            pieces.append(piece)
        if len(pieces) == 1:
            return pieces[0]
        level = [pieces[k:k + 2] for k in range(0, len(pieces), 2)]


def combine_cluster(adds, cuts=(), clips=(), progress=None):
    """``(union of adds - union of cuts) & every clip``, one ``batch_boolean`` per operation
    (the union of many adds in batches: :func:`united`, with its ``progress``)."""
    import manifold3d

    Manifold, Op = manifold3d.Manifold, manifold3d.OpType
    piece = united(adds, progress)
    if len(cuts):
        piece = Manifold.batch_boolean([piece, *cuts], Op.Subtract)
    if len(clips):
        piece = Manifold.batch_boolean([piece, *clips], Op.Intersect)
    return piece


def combine(adds, cuts=(), clips=()):
    """``(union of adds - union of cuts) & every clip`` as one :class:`manifold3d.Manifold`.

    Adds are clustered by bounding-box overlap (:func:`clusters`). A cluster of one
    needs no union, a cluster no cut reaches needs no difference, and the clusters,
    being disjoint, are composed at the end without boolean work.
    """
    import manifold3d

    work = clusters(bounding_boxes(adds), bounding_boxes(cuts), bounding_boxes(clips))
    pieces = [combine_cluster([adds[k] for k in index], [cuts[k] for k in reach], clips)
              for index, reach in work]
    if len(pieces) == 1:
        return pieces[0]
    return manifold3d.Manifold.batch_boolean(pieces, manifold3d.OpType.Add)


def is_void(solid, adds):
    """Whether a boolean result is empty or only zero-volume slivers: manifold3d can
    leave a degenerate shell where equal solids cancel."""
    reference = sum(m.volume() for m in adds)
    return solid.is_empty() or solid.volume() <= 1e-9 * reference


def carve(bodies, bores=(), name="solid", **mesh_options):
    """The :class:`Mesh` of ``union(bodies) - union(bores)``: a hollow part on its own.

    ``bodies`` and ``bores`` are closed :class:`Mesh` objects; the result is
    checked to be non-empty. ``mesh_options`` go to :meth:`Mesh.from_manifold`.
    """
    ids = iter(reserve_ids(len(bodies) + len(bores)))
    adds = [as_solid(m, f"{name} body {i}", next(ids)) for i, m in enumerate(bodies)]
    cuts = [as_solid(m, f"{name} bore {i}", next(ids)) for i, m in enumerate(bores)]
    solid = combine(adds, cuts)
    if is_void(solid, adds):
        raise GeometryError("nothing is left after cutting the bores", part=name)
    return Mesh.from_manifold(solid, **mesh_options)
