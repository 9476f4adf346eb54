"""Booleans through manifold3d: validated solids in, one solid out.

manifold3d is robust but trusting: it accepts an inside-out mesh (negative
volume) and welds only nearly identical vertices. So every input goes through
:func:`as_solid`, which builds the manifold3d solid tagged with its own original
id (so each output triangle still knows its part) and checks what manifold3d
does not: a status, a positive volume, and shells that are either bodies or
voids inside a body. Meshes from files are welded first with :func:`snap`.

:func:`combine` computes ``(union of adds - union of cuts) & every clip`` with
manifold3d's batch operations, and only where bounding boxes meet: parts that
overlap nothing are never sent through a boolean.
"""

import numpy as np

from cadpipe.errors import GeometryError, MeshError
from cadpipe.geometry.ragged import Groups
from cadpipe.geometry.mesh import Mesh, connected_labels

#: :func:`snap` welds vertices closer than this fraction of the mesh's bounding-box diagonal
SNAP_TOLERANCE = 1e-6


def snap(mesh, tolerance=None):
    """Weld vertices closer than ``tolerance`` and drop the triangles that collapse.

    Imported meshes often repeat a vertex with slightly different coordinates on
    each side of a seam (OBJ with six decimals, per-triangle STL corners); manifold3d
    would then see an open surface. Vertices within ``tolerance`` of each other
    (default :data:`SNAP_TOLERANCE` times the bounding-box diagonal) become one.
    """
    from scipy.spatial import cKDTree

    vertices = mesh.vertices
    if tolerance is None:
        tolerance = SNAP_TOLERANCE * float(np.linalg.norm(np.ptp(vertices, axis=0))) \
            if len(vertices) else 0.0
    if tolerance <= 0 or len(vertices) < 2:
        return mesh
    pairs = cKDTree(vertices).query_pairs(tolerance, output_type="ndarray")
    if not len(pairs):
        return mesh
    label = connected_labels(len(vertices), pairs[:, 0], pairs[:, 1])
    _, first = np.unique(label, return_index=True)
    faces = label[mesh.faces]
    keep = (faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & \
        (faces[:, 2] != faces[:, 0])
    face_part = None if mesh.face_part is None else mesh.face_part[keep]
    return Mesh(vertices[first], faces[keep], face_part=face_part, part_names=mesh.part_names,
                attributes=mesh.attributes)


def reserve_ids(count):
    """``count`` fresh manifold3d original ids, to tag each input solid's triangles."""
    import manifold3d

    first = manifold3d.Manifold.reserve_ids(count)
    return range(first, first + count)


def as_solid(mesh, name, original_id):
    """A validated :class:`manifold3d.Manifold` of ``mesh`` whose triangles carry ``original_id``.

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
    _check_shells(solid, name)
    return solid


def _check_shells(solid, name):
    """Every inside-out shell must be a void: wholly inside the outward shells."""
    import manifold3d

    shells = solid.decompose()
    if len(shells) == 1:
        return
    volumes = np.array([s.volume() for s in shells])
    voids = np.flatnonzero(volumes < 0)
    if not len(voids):
        return
    body = manifold3d.Manifold.batch_boolean([shells[i] for i in np.flatnonzero(volumes > 0)],
                                             manifold3d.OpType.Add)
    for i in voids:
        shell = Mesh.from_manifold(shells[i])
        cavity = Mesh.trusted(shell.vertices, shell.faces[:, ::-1]).to_manifold(
            f"{name} shell {i}")
        if (cavity - body).volume() > 1e-9 * cavity.volume():
            raise MeshError(f"shell {i} of {len(shells)} is inside out and not a void "
                            "inside another shell; flip its faces", part=name)


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


def combine(adds, cuts=(), clips=()):
    """``(union of adds - union of cuts) & every clip`` as one :class:`manifold3d.Manifold`.

    Adds are clustered by bounding-box overlap. A cluster of one needs no union, a
    cluster no cut reaches needs no difference, and the clusters, being disjoint,
    are composed at the end without boolean work. Each cluster's union, difference
    and intersection is one ``batch_boolean`` call.
    """
    import manifold3d

    Manifold, Op = manifold3d.Manifold, manifold3d.OpType
    if not adds:
        return Manifold()
    boxes = bounding_boxes(adds)
    group = _groups(boxes)
    add_i, cut_j = overlap_pairs(boxes, bounding_boxes(cuts))
    clip_boxes = bounding_boxes(clips)
    members = np.split(np.argsort(group, kind="stable"), np.cumsum(np.bincount(group))[:-1])
    cuts_of = np.split(cut_j[np.argsort(group[add_i], kind="stable")],
                       np.cumsum(np.bincount(group[add_i], minlength=len(members)))[:-1])
    pieces = []
    for index, reach in zip(members, cuts_of):
        box = np.array([boxes[index, 0].min(axis=0), boxes[index, 1].max(axis=0)])
        if len(clips) and not np.all((box[0] <= clip_boxes[:, 1]) &
                                     (clip_boxes[:, 0] <= box[1])):
            continue                     # outside some clip's box: nothing of it remains
        piece = Manifold.batch_boolean([adds[k] for k in index], Op.Add)
        if len(reach):
            piece = Manifold.batch_boolean([piece] + [cuts[k] for k in np.unique(reach)],
                                           Op.Subtract)
        if len(clips):
            piece = Manifold.batch_boolean([piece, *clips], Op.Intersect)
        pieces.append(piece)
    return Manifold.batch_boolean(pieces, Op.Add)


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
