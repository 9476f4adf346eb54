"""Solids from manifold3d fit for files: convex hulls, and every boolean result made
float32-safe by one rule.

Where a tube folds onto itself its mesh is the union of its convex pieces; a splice's
pieces and an assembly's parts are united the same way. What float32 cannot tell apart
(:mod:`cadpipe.core.float32`), a file merges: a union's vertex clusters where pieces meet
at grazing angles, edges shorter than a few steps, the copies of one point that
manifold3d keeps apart by index where a solid touches itself. Any of them turns into
edges of more than two faces in an STL, 3MF, OBJ, PLY or GLB. :func:`float32_solid` is
the one repair of all three, for pipes, splices and assemblies alike: it tries the
repairs in turn and takes the first that leaves a closed, outward solid of the same
volume with no face cutting through another -- a repair that makes crossings is never
taken -- and otherwise the solid as manifold3d made it.
"""

import numpy as np

from cadpipe.core import float32
from cadpipe.errors import GeometryError
from cadpipe.core.weld import unique_points
from cadpipe.geometry.mesh import Mesh
from cadpipe.geometry.topology import connected_labels


def hull_solid(points, name="hull", original_id=None):
    """The convex hull of ``points`` (K, 3) as a manifold3d solid, triangulated by qhull.

    manifold3d's own ``hull_points`` leaves folded triangles where many points are
    coplanar (two parallel rings, two equal balls side by side: 12 crossing face pairs
    on a splice's ball joint); qhull's triangulation of a coplanar facet is flat."""
    from scipy.spatial import ConvexHull

    hull = ConvexHull(points)
    faces = hull.simplices.copy()
    tri = points[faces]
    inward = np.einsum("ij,ij->i", np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]),
                       hull.equations[:, :3]) < 0
    faces[inward] = faces[inward][:, ::-1]
    used, local = np.unique(faces, return_inverse=True)
    return Mesh.trusted(points[used], local.reshape(-1, 3)).to_manifold(name, original_id)


def float32_solid(solid, part_of_id=None, **mesh_options):
    """The :class:`Mesh` of a manifold3d ``solid`` (faces labelled by ``part_of_id`` as
    :meth:`Mesh.from_manifold` does) that float32 files can hold.

    Where no two vertices are closer than ``COLLAPSE`` float32 steps at the solid's
    largest coordinate, that is the solid as manifold3d made it. Otherwise, in turn:

    1. manifold3d's ``simplify`` and the collapse of the short edges it leaves
       (:func:`without_short_edges`), then the copies of a point moved apart
       (:func:`separated_pinches`);
    2. the vertex clusters welded (:func:`snapped`) at ``WELD``, 4 and ``CLOSE`` steps.

    The first result that keeps the volume (to :data:`WELD_VOLUME`), is closed and
    oriented, and has no face the repair moved cutting through another is taken;
    failing all, the float64 solid as manifold3d made it.

    Raises
    ------
    GeometryError
        For an empty solid.
    """
    from scipy.spatial import cKDTree

    if solid.is_empty():
        raise GeometryError("the boolean result is empty")
    step = float32.step(solid.bounding_box())
    volume = solid.volume()
    plain = Mesh.from_manifold(solid, part_of_id, **mesh_options)
    if not len(cKDTree(plain.vertices).query_pairs(float32.COLLAPSE * step,
                                                   output_type="ndarray")):
        return plain                                 # nothing a float32 file would merge
    collapse = float32.COLLAPSE * step
    simplified = Mesh.from_manifold(without_short_edges(solid.simplify(collapse), collapse),
                                    part_of_id, **mesh_options)
    candidates = [lambda: separated_pinches(simplified, collapse)]
    candidates += [lambda k=k: snapped(plain, k * step)
                   for k in (float32.WELD, 4, float32.CLOSE)]
    for make in candidates:
        candidate = make()
        if len(candidate.faces) and candidate.is_oriented and \
                abs(candidate.volume - volume) <= WELD_VOLUME * volume and \
                not _repair_crosses(candidate, _moved_faces(plain, candidate)):
            return candidate
    return plain


def _moved_faces(before, after):
    """(F,) which faces of ``after`` are no face of ``before`` (a repair made them: it
    moved a corner or joined corners that were apart), the corners compared exactly."""
    rows = np.concatenate([before.vertices, after.vertices])
    scale = float(np.abs(rows).max(initial=1.0))
    decimals = int(15 - np.ceil(np.log10(max(scale, 1e-300))))     # the last bits only
    _, inverse = unique_points(rows, decimals)
    old = np.sort(inverse[:len(before.vertices)][before.faces], axis=1)
    new = np.sort(inverse[len(before.vertices):][after.faces], axis=1)
    _, which = np.unique(np.concatenate([old, new]), axis=0, return_inverse=True)
    which = which.reshape(-1)
    return ~np.isin(which[len(old):], which[:len(old)])


def _repair_crosses(mesh, moved):
    """Whether a face of ``mesh`` that a repair ``moved`` ((F,) bool) cuts through
    another face. The rest is manifold3d's surface as it made it, which does not, so
    crossings of two unmoved faces are not the repair's."""
    from cadpipe.geometry.intersect import self_intersections

    if not moved.any():
        return False
    pairs = self_intersections(mesh)
    return bool((moved[pairs[:, 0]] | moved[pairs[:, 1]]).any())


def snapped(mesh, tolerance):
    """``mesh`` with its vertices closer than ``tolerance`` made one: the one weld by
    distance.

    Each cluster of vertices linked by pairs closer than ``tolerance`` becomes its first
    vertex; triangles that collapse go, and so do pairs of faces that now coincide facing
    both ways (sheets that touched). Parts and attributes are kept.

    Parameters
    ----------
    mesh : Mesh
    tolerance : float

    Returns
    -------
    mesh : Mesh
        ``mesh`` itself when no two vertices are that close.
    """
    from scipy.spatial import cKDTree

    vertices, faces = mesh.vertices, mesh.faces
    pairs = cKDTree(vertices).query_pairs(tolerance, output_type="ndarray") \
        if tolerance > 0 and len(vertices) > 1 else np.empty((0, 2), np.int64)
    if not len(pairs):
        return mesh
    label = connected_labels(len(vertices), pairs[:, 0], pairs[:, 1])
    _, first = np.unique(label, return_index=True)
    faces = label[faces]
    keep = (faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & \
        (faces[:, 2] != faces[:, 0])
    faces = faces[keep]
    _, index, counts = np.unique(np.sort(faces, axis=1), axis=0, return_inverse=True,
                                 return_counts=True)
    single = counts[index.reshape(-1)] == 1
    faces = faces[single]
    part = None if mesh.face_part is None else mesh.face_part[keep][single]
    return Mesh(vertices[first], faces, face_part=part,
                part_names=mesh.part_names if part is not None else (),
                attributes=mesh.attributes)


def without_short_edges(solid, step):
    """``solid`` with every edge shorter than ``step`` collapsed.

    ``simplify`` leaves some, where collapsing them would fold a triangle over (56
    of 290,000 in the union of 1,000 crossing pipes); a float32 file can give both
    ends of such an edge one position (in whichever unit it is written) and weld
    them, and the faces around them then meet at edges of more than two faces. The
    ends of each run of short edges are put on one point, which moves the surface
    less than ``step``, and manifold3d rebuilds the solid, collapsing each edge of
    zero length and its two triangles as a manifold edge collapse.
    """
    import manifold3d

    out = solid.to_mesh64()
    vertices = np.array(out.vert_properties)
    faces = np.asarray(out.tri_verts).astype(np.int64)
    a, b = faces.ravel(), faces[:, [1, 2, 0]].ravel()
    short = np.linalg.norm(vertices[a, :3] - vertices[b, :3], axis=1) < step
    if not short.any():
        return solid
    group = connected_labels(len(vertices), a[short], b[short])
    _, first = np.unique(group, return_index=True)
    vertices[:, :3] = vertices[first[group], :3]          # each run on its first vertex
    arrays = {k: np.array(getattr(out, k), np.uint64)
              for k in ("tri_verts", "merge_from_vert", "merge_to_vert", "run_index", "face_id")}
    rebuilt = manifold3d.Manifold(manifold3d.Mesh64(
        vert_properties=vertices, run_original_id=np.array(out.run_original_id, np.uint32),
        **arrays))
    return rebuilt if rebuilt.status() == manifold3d.Error.NoError else solid


def separated_pinches(mesh, step):
    """``mesh`` with vertices closer than ``step`` (copies of one point) moved apart.

    Each such vertex moves by ``2 * step`` towards the centre of its own neighbours
    (at most a quarter of its shortest edge), into the fan of triangles it belongs
    to, so the fans that touched there part and every file keeps them apart.

    Parameters
    ----------
    mesh : Mesh
        Closed, its vertices in the model's length unit.
    step : float
        The distance below which a file merges two points.

    Returns
    -------
    mesh : Mesh
        ``mesh`` itself when no vertex needs to move.
    """
    from scipy.spatial import cKDTree

    vertices, faces = mesh.vertices, mesh.faces
    if step <= 0 or len(vertices) < 2:
        return mesh
    movers = np.unique(cKDTree(vertices).query_pairs(step, output_type="ndarray"))
    if not len(movers):
        return mesh
    moving = np.zeros(len(vertices), bool)
    moving[movers] = True
    ring = np.zeros_like(vertices)
    count = np.zeros(len(vertices))
    shortest = np.full(len(vertices), np.inf)
    for k in range(3):                       # each corner's two neighbours in its triangle
        here, a, b = faces[:, k], faces[:, (k + 1) % 3], faces[:, (k + 2) % 3]
        rows = np.flatnonzero(moving[here])
        np.add.at(ring, here[rows], vertices[a[rows]] + vertices[b[rows]])
        np.add.at(count, here[rows], 2)
        for other in (a, b):
            length = np.linalg.norm(vertices[other[rows]] - vertices[here[rows]], axis=1)
            np.minimum.at(shortest, here[rows], length)
    toward = ring[movers] / np.maximum(count[movers], 1)[:, None] - vertices[movers]
    norm = np.linalg.norm(toward, axis=1, keepdims=True)
    distance = np.minimum(2 * step, 0.25 * shortest[movers])[:, None]
    moved = np.array(vertices)
    moved[movers] += np.divide(toward, norm, out=np.zeros_like(toward), where=norm > 0) * distance
    return Mesh.trusted(moved, faces, face_part=mesh.face_part, part_names=mesh.part_names,
                        attributes=mesh.attributes)


#: a weld may change the volume by this fraction at most (else the solid was too fine)
WELD_VOLUME = 1e-3


