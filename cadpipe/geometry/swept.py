"""The swept solid: convex hulls united by manifold3d, welded for float32 files.

Where a tube folds onto itself its mesh is the union of its convex pieces; a splice's
pieces are united the same way. A union leaves clusters of vertices where pieces meet
at grazing angles, which files of float32 coordinates would merge into edges of more
than two faces: :func:`welded_solid` welds them first, and takes no weld that breaks
the solid.
"""

import numpy as np

from cadpipe.core import float32
from cadpipe.errors import GeometryError
from cadpipe.geometry.mesh import Mesh


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


def welded_solid(solid, part_of_id=None, **kwargs):
    """The :class:`Mesh` of a manifold3d ``solid`` (faces labelled by ``part_of_id`` as
    :meth:`Mesh.from_manifold` does), with no two vertices closer than float32 can tell
    apart at its size.

    A union leaves clusters of vertices where its pieces meet at grazing angles; STL,
    3MF, OBJ and PLY files (float32) would merge them, into edges shared by more than
    two faces (:mod:`cadpipe.core.float32`). A solid with vertices closer than ``CLOSE``
    float32 steps at its largest coordinate has its clusters merged, ``WELD`` steps
    first; a weld that changes the volume, leaves an open or badly wound surface, or
    folds a sliver through a face is not taken, and smaller distances are tried, down to
    ``CLOSE`` steps; failing all, the float64 solid as manifold3d made it.
    """
    from scipy.spatial import cKDTree

    if solid.is_empty():
        raise GeometryError("the swept solid is empty")
    low, high = np.asarray(solid.bounding_box()).reshape(2, 3)
    ulp = max(float32.step([low, high]), float32.EPS * 1e-30)
    volume = solid.volume()
    plain = Mesh.from_manifold(solid, part_of_id, **kwargs)
    if not len(cKDTree(plain.vertices).query_pairs(float32.CLOSE * ulp,
                                                   output_type="ndarray")):
        return plain                                 # nothing a float32 file would merge
    for ulps in (float32.WELD, 4, float32.CLOSE):
        welded = _weld(plain, ulps * ulp)
        if welded is not None and abs(welded[0].volume - volume) <= WELD_VOLUME * volume \
                and not _crossings_near(*welded, ulps * ulp):
            return welded[0]
    return plain


def _crossings_near(mesh, moved, shift):
    """Whether a face of ``mesh`` that the weld ``moved`` ((F,) bool, each point by at
    most ``shift``) cuts through another face. The rest is manifold3d's surface as it
    made it, which does not, so only faces whose boxes come within ``shift`` of a moved
    face's box are tested."""
    from cadpipe.geometry.intersect import self_intersections

    if not moved.any():
        return False
    tri = mesh.triangles
    low, high = tri.min(axis=1), tri.max(axis=1)
    near = moved.copy()
    for rows in np.array_split(np.flatnonzero(moved), max(1, int(moved.sum()) // 256)):
        near |= ((low[None] <= high[rows, None] + shift)
                 & (high[None] >= low[rows, None] - shift)).all(axis=2).any(axis=0)
    return bool(len(self_intersections(Mesh.trusted(mesh.vertices, mesh.faces[near]))))


def _weld(mesh, tol):
    """``mesh`` with its vertex clusters closer than ``tol`` merged (its parts and
    attributes kept) and (F,) which of its faces moved, or None if that does not leave
    a closed, oriented surface."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    vertices, faces = mesh.vertices, mesh.faces
    pairs = cKDTree(vertices).query_pairs(tol, output_type="ndarray")
    if not len(pairs):
        return (mesh, np.zeros(len(faces), bool)) if len(faces) and mesh.is_oriented else None
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])),
                       shape=(len(vertices), len(vertices)))
    count, label = connected_components(graph, directed=False)
    faces = label[faces]
    keep = ((faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2])
            & (faces[:, 2] != faces[:, 0]))
    merged = np.empty((count, 3))
    merged[label] = vertices
    faces = faces[keep]
    # sheets that touched along faces: such a face now comes twice, facing both ways
    _, index, counts = np.unique(np.sort(faces, axis=1), axis=0, return_inverse=True,
                                 return_counts=True)
    single = counts[index.reshape(-1)] == 1
    faces = faces[single]
    moved = (np.bincount(label, minlength=count) > 1)[faces].any(axis=1)
    used, faces = np.unique(faces, return_inverse=True)
    part = None if mesh.face_part is None else mesh.face_part[keep][single]
    welded = Mesh(merged[used], faces.reshape(-1, 3), face_part=part,
                  part_names=mesh.part_names if part is not None else (),
                  attributes=mesh.attributes)
    return (welded, moved) if len(faces) and welded.is_oriented else None


#: a weld may change the volume by this fraction at most (else the solid was too fine)
WELD_VOLUME = 1e-3


