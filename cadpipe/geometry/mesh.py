"""The triangle mesh every stage hands to the next.

:class:`Mesh` is small and immutable: vertices, faces and, after a boolean, the
name of the part each face came from. Checks (watertight, volume, bodies) are
computed on first use from numpy arrays and cached, so building a mesh costs
nothing beyond its arrays.
"""

from __future__ import annotations

import os
from collections.abc import Hashable, Iterable, Mapping, Sequence
from functools import cached_property
from typing import Any
from types import MappingProxyType

import numpy as np
from numpy.typing import ArrayLike

from cadpipe._validate import as_points
from cadpipe.core.vec import bounds, cross
from cadpipe.core.weld import renumbered, unique_points
from cadpipe.errors import InputError, MeshError
from cadpipe.geometry.topology import closed, connected_labels, edge_table
from cadpipe.geometry.winding import WindingTree
from cadpipe.core import formats
from cadpipe.core.transform import as_matrix, placed_points


def winding_numbers(triangles: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Generalized winding number of a triangle soup at each point.

    Parameters
    ----------
    triangles : (F, 3, 3) float
        Corners; corners with equal coordinates are taken as one vertex.
    points : (P, 3) float

    Returns
    -------
    winding : (P,) float
        The signed solid angles of the triangles seen from each point (Van Oosterom
        and Strackee) summed over 4 pi: 1 inside a closed outward mesh, 0 outside,
        fractions near the surface and around open meshes. See
        :class:`~cadpipe.geometry.winding.WindingTree` for how, and its accuracy;
        :meth:`Mesh.winding_numbers` keeps the tree between calls.
    """
    return WindingTree.of_triangles(triangles)(points)


def merge_tables(tables: Iterable[Sequence[Hashable]]) -> tuple[tuple, list[np.ndarray]]:
    """The distinct entries of several label tables as one, in first-seen order.

    Parameters
    ----------
    tables : sequence of sequences of hashable
        Each mesh's (or part's) own labels: part names, ``(name, colour)`` pairs.

    Returns
    -------
    merged : tuple
        Every distinct entry once.
    rows : list of (len(table),) int32 arrays
        For each table, the row of ``merged`` each of its entries went to: relabel
        faces with ``rows[k][labels]``.
    """
    index = {}
    rows = [np.array([index.setdefault(k, len(index)) for k in t], np.int32).reshape(-1)
            for t in tables]
    return tuple(index), rows


#: faces per step of :attr:`Mesh.volume`: 64M-face meshes summed in 72 MB pieces
_VOLUME_CHUNK = 1 << 20


def reserve_ids(count):
    """``count`` fresh manifold3d original ids, to tag each input solid's triangles."""
    import manifold3d

    first = manifold3d.Manifold.reserve_ids(count)
    return range(first, first + count)


def _frozen(arr, dtype):
    arr = np.ascontiguousarray(arr, dtype=dtype)
    arr.flags.writeable = False
    return arr


def _unpickled(vertices, faces, face_part, part_names, attributes, ring_runs):
    """The :class:`Mesh` that :meth:`Mesh.__reduce__` pickled (its arrays are the
    unpickler's own, so nobody else can write to them)."""
    return Mesh.trusted(vertices, faces, face_part=face_part, part_names=part_names,
                        attributes=attributes, ring_runs=ring_runs)


def _private(arr, given):
    """``arr`` (made from the argument ``given``), copied where the caller could still
    write to it: a mesh must not change when its maker's array does, nor freeze that array."""
    if isinstance(given, np.ndarray) and given.flags.writeable and np.may_share_memory(arr, given):
        return arr.copy()
    return arr


class Mesh:
    """A triangle mesh: ``(V, 3)`` float64 vertices and ``(F, 3)`` int64 faces.

    Parameters
    ----------
    vertices : (V, 3) array_like
        Finite coordinates, in the model's length unit.
    faces : (F, 3) array_like of int
        Counter-clockwise seen from outside, so normals point outward.
    face_part : (F,) array_like of int, optional
        Index into ``part_names`` for each face (set by booleans and splicing).
    part_names : sequence of str, optional
        The parts' names, one per index used in ``face_part``.
    attributes : mapping, optional
        The parameters that made the mesh (radius, sides, ...); exporters
        write them as metadata.
    """

    __slots__ = ("_vertices", "_faces", "_face_part", "_part_names", "_attributes", "_ring_runs",
                 "__dict__")

    def __init__(self, vertices: ArrayLike, faces: ArrayLike, *, face_part: ArrayLike | None = None,
                 part_names: Sequence[str] = (), attributes: Mapping[str, Any] | None = None):
        given_vertices, given_faces = vertices, faces
        vertices = as_points(vertices, "vertices", min_count=0)
        faces = np.asarray(faces)
        if faces.size == 0:
            faces = faces.reshape(0, 3)
        if faces.ndim != 2 or faces.shape[1] != 3 or not np.issubdtype(faces.dtype, np.integer):
            raise InputError("expected an (F, 3) array of vertex indices, got "
                             f"shape {faces.shape} of {faces.dtype}", key="faces")
        if faces.size and (faces.min() < 0 or faces.max() >= len(vertices)):
            raise InputError(f"indices must lie in [0, {len(vertices) - 1}], "
                             f"got [{faces.min()}, {faces.max()}]", key="faces")
        self._vertices = _frozen(_private(vertices, given_vertices), np.float64)
        self._faces = _frozen(_private(faces, given_faces), np.int64)
        self._part_names = tuple(str(n) for n in part_names)
        if face_part is None:
            self._face_part = None
        else:
            given_face_part, face_part = face_part, np.asarray(face_part)
            if face_part.shape != (len(faces),):
                raise InputError(f"expected {len(faces)} part indices, "
                                 f"got shape {face_part.shape}", key="face_part")
            names = len(self._part_names)
            if face_part.size and not 0 <= face_part.min() <= face_part.max() < names:
                raise InputError("indices must point into part_names", key="face_part")
            self._face_part = _frozen(_private(face_part, given_face_part), np.int32)
        self._attributes = MappingProxyType(dict(attributes or {}))
        self._ring_runs = None

    @classmethod
    def trusted(cls, vertices: np.ndarray, faces: np.ndarray, *,
                face_part: np.ndarray | None = None, part_names: Sequence[str] = (),
                attributes: Mapping[str, Any] | None = None,
                ring_runs: np.ndarray | None = None) -> Mesh:
        """Wrap arrays a cadpipe stage just built, skipping the input checks.

        Large pipes are built faster than they can be re-checked.

        Parameters
        ----------
        vertices : (V, 3) float64
            Finite coordinates.
        faces : (F, 3) int64
            Indices into ``vertices``.
        face_part, part_names, attributes
            As for :class:`Mesh` (``face_part`` indices into ``part_names``).
        ring_runs : (G, 4) int64, optional
            The runs of rings these arrays were laid out in, as
            :attr:`Surface.ring_runs <cadpipe.geometry.loft.Surface.ring_runs>` gives them.

        Returns
        -------
        mesh : Mesh
        """
        mesh = cls.__new__(cls)
        mesh._vertices = _frozen(vertices, np.float64)
        mesh._faces = _frozen(faces, np.int64)
        mesh._face_part = None if face_part is None else _frozen(face_part, np.int32)
        mesh._part_names = tuple(str(n) for n in part_names)
        mesh._attributes = MappingProxyType(dict(attributes or {}))
        mesh._ring_runs = None if ring_runs is None else _frozen(ring_runs, np.int64)
        return mesh

    def __reduce__(self):
        """Pickle the arrays, labels and attributes only (caches are made again where the
        mesh lands), so a mesh goes to worker processes (multiprocessing, Dask) as a
        trimesh one does."""
        return (_unpickled, (self._vertices, self._faces, self._face_part, self._part_names,
                             dict(self._attributes), self._ring_runs))

    # -- data -----------------------------------------------------------------
    @property
    def vertices(self) -> np.ndarray:
        """(V, 3) float64, read-only."""
        return self._vertices

    @property
    def faces(self) -> np.ndarray:
        """(F, 3) int64, read-only."""
        return self._faces

    @property
    def face_part(self) -> np.ndarray | None:
        """(F,) int32 index into :attr:`part_names`, or None for a single-part mesh."""
        return self._face_part

    @property
    def part_names(self) -> tuple[str, ...]:
        """Name of each part that :attr:`face_part` indexes (empty for a single part)."""
        return self._part_names

    @property
    def attributes(self) -> Mapping[str, Any]:
        """Read-only mapping of the parameters that made this mesh."""
        return self._attributes

    @property
    def ring_runs(self) -> np.ndarray | None:
        """(G, 4) int64 runs of rings the mesh was laid out in (first vertex, ring count,
        sides, first side face; see :class:`~cadpipe.geometry.loft.Surface`), or None
        when not known. Shading normals take smooth side normals from them."""
        return self._ring_runs

    def __repr__(self):
        return f"<cadpipe.Mesh {len(self._vertices)} vertices, {len(self._faces)} faces>"

    def with_parts(self, part_names: Sequence[str], face_part: ArrayLike | None = None) -> Mesh:
        """The same geometry labelled with part names.

        Parameters
        ----------
        part_names : sequence of str
        face_part : (F,) array_like of int, optional
            Index into ``part_names`` per face; all faces in part 0 by default.

        Returns
        -------
        mesh : Mesh
        """
        if face_part is None:
            face_part = np.zeros(len(self._faces), np.int32)
        return self._same_layout(Mesh(self._vertices, self._faces, face_part=face_part,
                                      part_names=part_names, attributes=self._attributes))

    def welded(self, decimals: int = 8) -> Mesh:
        """This mesh with its duplicate vertices (equal to ``decimals`` decimals) made one.

        Files store a vertex once per triangle (STL) or once per normal or colour
        (GLB, PLY); the solid is the same surface with shared corners. The vertices
        keep their first-seen order (:func:`cadpipe.core.weld.unique_points`).

        Parameters
        ----------
        decimals : int
            Vertices are the same point where their coordinates round alike to this
            many decimals (8, as trimesh's ``merge_vertices``: text formats round).

        Returns
        -------
        mesh : Mesh
            ``self`` when no two vertices are the same point.
        """
        rows = np.ascontiguousarray(self._vertices)
        first, inverse = unique_points(rows, decimals)
        if len(first) == len(rows):
            return self
        faces = renumbered(self._faces, inverse)
        # the first-seen points are often the leading rows (a GLB's crease copies come
        # last): then they are a view, not a copy
        kept = rows[:len(first)] if first[-1] == len(first) - 1 else rows[first]
        return Mesh.trusted(kept, faces, face_part=self._face_part,
                            part_names=self._part_names, attributes=self._attributes)

    def with_attributes(self, **attributes: Any) -> Mesh:
        """The same mesh with ``attributes`` added to (or replacing) its own.

        Parameters
        ----------
        **attributes
            Metadata values, by name.

        Returns
        -------
        mesh : Mesh
        """
        return self._same_layout(Mesh(self._vertices, self._faces, face_part=self._face_part,
                                      part_names=self._part_names,
                                      attributes={**self._attributes, **attributes}))

    def _same_layout(self, mesh):
        """``mesh`` (of this mesh's faces, in order) keeping this mesh's ring runs."""
        mesh._ring_runs = self._ring_runs
        return mesh

    # -- geometry -------------------------------------------------------------
    @cached_property
    def triangles(self) -> np.ndarray:
        """(F, 3, 3) corner coordinates."""
        return self._vertices[self._faces]

    @cached_property
    def _cross(self):
        t = self.triangles
        return cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])

    @cached_property
    def face_areas(self) -> np.ndarray:
        """(F,) area of each face, in length unit squared."""
        return 0.5 * np.linalg.norm(self._cross, axis=1)

    @cached_property
    def face_normals(self) -> np.ndarray:
        """(F, 3) unit normals by the right-hand rule (zero for degenerate faces)."""
        norm = np.linalg.norm(self._cross, axis=1, keepdims=True)
        return np.divide(self._cross, norm, out=np.zeros_like(self._cross), where=norm > 0)

    @cached_property
    def area(self) -> float:
        """Surface area, in length unit squared."""
        return float(self.face_areas.sum())

    @cached_property
    def volume(self) -> float:
        """Signed volume by the divergence theorem: positive when faces point outward.

        Summed about the vertices' mean, not the origin: far from the origin the
        tetrahedra's volumes would be huge and cancel, losing every digit.
        """
        if len(self._faces) == 0:
            return 0.0
        centre, total = self._vertices.mean(axis=0), 0.0
        for start in range(0, len(self._faces), _VOLUME_CHUNK):   # no (F, 3, 3) copy
            t = self._vertices[self._faces[start:start + _VOLUME_CHUNK]] - centre
            total += float(np.einsum("ij,ij->", t[:, 0], cross(t[:, 1], t[:, 2])))
        return total / 6.0

    @cached_property
    def bounds(self) -> np.ndarray:
        """(2, 3) array: minimum and maximum corner."""
        return bounds(self._vertices)

    # -- topology -------------------------------------------------------------
    @cached_property
    def edges(self) -> np.ndarray:
        """(3F, 2) int64 directed edges: row ``3f + k`` runs from corner k of face f to
        corner k + 1, as trimesh's ``edges``."""
        return self._faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)

    def edge_keys(self, a: ArrayLike, b: ArrayLike) -> np.ndarray:
        """One int64 key per undirected edge ``(a, b)``, the same whichever way round.

        Parameters
        ----------
        a, b : (E,) int array_like
            Vertex indices of each edge's ends.

        Returns
        -------
        keys : (E,) int64
            ``min * V + max``: equal keys are the same edge; sorted keys sort the
            edges as :attr:`edges_unique` does.
        """
        a, b = np.asarray(a, np.int64), np.asarray(b, np.int64)
        return np.minimum(a, b) * max(len(self._vertices), 1) + np.maximum(a, b)

    @cached_property
    def _unique_edges(self):
        """Sorted undirected edge keys, each directed edge's row among them, and counts
        (``np.unique`` of :meth:`edge_keys` of :attr:`edges`, in compiled passes)."""
        return edge_table(self._faces, len(self._vertices))

    @property
    def edges_unique(self) -> np.ndarray:
        """(E, 2) int64 undirected edges ``(low, high)``, sorted, each once."""
        return np.stack(np.divmod(self._unique_edges[0], max(len(self._vertices), 1)), axis=1)

    @property
    def edges_unique_inverse(self) -> np.ndarray:
        """(3F,) int64 row of :attr:`edges_unique` for each row of :attr:`edges`."""
        return self._unique_edges[1].reshape(-1)

    @property
    def edge_face_counts(self) -> np.ndarray:
        """(E,) int64 faces on each of :attr:`edges_unique` (1: a hole's rim, > 2:
        non-manifold)."""
        return self._unique_edges[2]

    def edge_index(self, a: ArrayLike, b: ArrayLike) -> np.ndarray:
        """Where undirected edges of the mesh are in :attr:`edges_unique`.

        Parameters
        ----------
        a, b : (E,) int array_like
            Vertex indices of each edge's ends, either way round.

        Returns
        -------
        rows : (E,) int64
            Row of :attr:`edges_unique` per edge.
        """
        return np.searchsorted(self._unique_edges[0], self.edge_keys(a, b))

    @cached_property
    def is_watertight(self) -> bool:
        """Closed: every edge is shared by exactly two faces (trimesh's meaning; the
        faces' winding is not looked at, see :attr:`is_oriented`)."""
        return closed(self._faces, len(self._vertices))   # without the whole edge table

    @cached_property
    def is_winding_consistent(self) -> bool:
        """No edge is traversed twice in the same direction: neighbouring faces agree."""
        e, (_, row, counts) = self.edges, self._unique_edges
        forward = np.bincount(row.reshape(-1), weights=e[:, 0] < e[:, 1], minlength=len(counts))
        return bool(np.all(forward <= 1) and np.all(counts - forward <= 1))

    @cached_property
    def is_oriented(self) -> bool:
        """Closed and consistently wound: every edge is traversed once each way, so the
        surface has a well-defined inside (what manifold3d and booleans need)."""
        return self.is_watertight and self.is_winding_consistent

    @cached_property
    def is_outward(self) -> bool:
        """Oriented with positive volume: a solid whose normals point out."""
        return self.is_oriented and self.volume > 0

    @cached_property
    def body_labels(self) -> np.ndarray:
        """(V,) connected-component label of each vertex."""
        f = self._faces                       # each face's first corner with the others
        return connected_labels(len(self._vertices), np.broadcast_to(f[:, :1], (len(f), 2)),
                                f[:, 1:])

    @cached_property
    def n_bodies(self) -> int:
        """Number of connected pieces (vertices used by no face are ignored)."""
        if len(self._faces) == 0:
            return 0
        labels = self.body_labels
        used = np.zeros(int(labels.max()) + 1, np.bool_)
        used[labels[self._faces[:, 0]]] = True
        return int(np.count_nonzero(used))

    @cached_property
    def euler_characteristic(self) -> int:
        """V - E + F over the vertices that faces use (2 per sphere-like body)."""
        used = len(np.unique(self._faces))
        return int(used - len(self.edge_face_counts) + len(self._faces))

    @cached_property
    def genus(self) -> int:
        """Genus of a closed single-body mesh (0 for a sphere-like tube, 1 for a loop)."""
        return (2 * self.n_bodies - self.euler_characteristic) // 2

    @cached_property
    def _winding_tree(self) -> WindingTree:
        """The box tree of the triangles with their caps, built on the first query."""
        return WindingTree(self._vertices, self._faces)

    def winding_numbers(self, points: ArrayLike) -> np.ndarray:
        """Generalized winding number of the surface around each point.

        Parameters
        ----------
        points : (P, 3) array_like

        Returns
        -------
        winding : (P,) float
            1 inside a closed outward mesh, 0 outside (fractions near the surface and
            around open meshes). Off the surface of a closed mesh the exact integer,
            from rays; elsewhere the sum of the triangles' solid angles over 4 pi up
            to rounding (:class:`~cadpipe.geometry.winding.WindingTree`). The tree is
            built on the first call and kept with the mesh.
        """
        return self._winding_tree(as_points(points, "points", min_count=0))

    def contains(self, points: ArrayLike) -> np.ndarray:
        """Which points lie inside this mesh: winding number above 1/2.

        Parameters
        ----------
        points : (P, 3) array_like

        Returns
        -------
        inside : (P,) bool
            For a closed mesh, inside its solid (exactly, but for points within
            rounding of the surface, which may fall either way). For an open mesh,
            where the solid-angle sum exceeds 1/2, as the brute force's: the
            signed share of directions in which the point sees the surface's
            back exceeds a half: points near a small hole stay inside, a point
            in the mouth of an open tube is at about 1/2.
        """
        return self.winding_numbers(points) > 0.5

    def require_solid(self, name: str = "mesh") -> Mesh:
        """This mesh, if it is a closed, consistently wound solid of positive volume.

        Parameters
        ----------
        name : str
            What to call the mesh in the error.

        Returns
        -------
        mesh : Mesh
            ``self``.

        Raises
        ------
        MeshError
            Naming what is wrong: holes or non-manifold edges, winding, inward faces.
        """
        if not self.is_watertight:
            raise MeshError("not a closed solid (open or non-manifold edges); "
                            "close the holes or repair it before using it as a solid", part=name)
        if not self.is_winding_consistent:
            raise MeshError("neighbouring faces disagree on orientation; "
                            "make the winding consistent (e.g. trimesh's fix_normals)", part=name)
        if self.volume <= 0:
            raise MeshError(f"faces point inward (volume {self.volume:.6g}); "
                            "flip its faces", part=name)
        return self

    # -- transforms -----------------------------------------------------------
    def transformed(self, matrix: ArrayLike) -> Mesh:
        """A copy moved by a 4x4 homogeneous matrix (faces flipped if it mirrors).

        Parameters
        ----------
        matrix : (4, 4) array_like
            Affine placement (see :func:`cadpipe.core.transform.as_matrix`).

        Returns
        -------
        mesh : Mesh
            ``self`` for the identity.
        """
        matrix = as_matrix(matrix)
        if np.array_equal(matrix, np.eye(4)):
            return self
        vertices = placed_points(self._vertices, matrix)     # one compiled pass, no BLAS
        faces = self._faces if np.linalg.det(matrix[:3, :3]) >= 0 else self._faces[:, ::-1]
        vertices.flags.writeable = False          # ours alone: checked, not copied
        moved = Mesh(vertices, faces, face_part=self._face_part, part_names=self._part_names,
                     attributes=self._attributes)
        return moved if faces is not self._faces else self._same_layout(moved)

    @staticmethod
    def concatenate(meshes: Iterable[Mesh]) -> Mesh:
        """One mesh holding all the given meshes' faces.

        Parameters
        ----------
        meshes : iterable of Mesh
            At least one. A mesh without part names counts as part ``part<i>``.

        Returns
        -------
        mesh : Mesh
            Part names merged in first-seen order (equal names become one part).
        """
        meshes = list(meshes)
        if not meshes:
            raise InputError("concatenate: expected at least one mesh")
        offsets = np.cumsum([0] + [len(m.vertices) for m in meshes[:-1]])
        names, rows = merge_tables([m.part_names or (f"part{i}",) for i, m in enumerate(meshes)])
        face_parts = [r[m.face_part if m.face_part is not None else np.zeros(len(m.faces), int)]
                      for m, r in zip(meshes, rows)]
        return Mesh.trusted(np.concatenate([m.vertices for m in meshes]),
                            np.concatenate([m.faces + o for m, o in zip(meshes, offsets)]),
                            face_part=np.concatenate(face_parts), part_names=names)

    # -- other libraries --------------------------------------------------------
    def to_trimesh(self) -> Any:
        """This mesh for trimesh.

        Returns
        -------
        mesh : trimesh.Trimesh
            Sharing no state, built with ``process=False`` (vertices as they are).
        """
        import trimesh

        return trimesh.Trimesh(np.array(self._vertices), np.array(self._faces), process=False)

    @classmethod
    def from_trimesh(cls, tm: Any, **kwargs: Any) -> Mesh:
        """A mesh of a :class:`trimesh.Trimesh`'s vertices and faces.

        Parameters
        ----------
        tm : trimesh.Trimesh
        **kwargs
            Other :class:`Mesh` arguments.

        Returns
        -------
        mesh : Mesh
        """
        return cls(tm.vertices, tm.faces, **kwargs)

    def to_manifold(self, name: str = "mesh", original_id: int | None = None) -> Any:
        """This mesh as a :class:`manifold3d.Manifold`.

        Parameters
        ----------
        name : str
            What to call the mesh in the error.
        original_id : int, optional
            manifold3d original id to tag every triangle with (see
            :func:`reserve_ids`), so a boolean's output faces
            still know their part.

        Returns
        -------
        solid : manifold3d.Manifold

        Raises
        ------
        MeshError
            When manifold3d rejects the mesh (not a closed, oriented 2-manifold).
        """
        import manifold3d

        runs = {} if original_id is None else {
            "run_index": np.array([0, self._faces.size], np.uint64),
            "run_original_id": np.array([original_id], np.uint32)}
        solid = manifold3d.Manifold(manifold3d.Mesh64(
            vert_properties=np.array(self._vertices),                # a writeable copy
            tri_verts=self._faces.astype(np.uint64), **runs))
        status = solid.status()
        if status != manifold3d.Error.NoError:
            raise MeshError(f"not a closed solid (manifold3d: {status.name}); it must "
                            "be a closed, consistently oriented surface: repair or close it "
                            "first", part=name)
        return solid

    @classmethod
    def from_manifold(cls, solid: Any, part_of_id: Mapping[int, str] | None = None,
                      **kwargs: Any) -> Mesh:
        """A mesh of a manifold3d solid, its faces labelled by the part they came from.

        Parameters
        ----------
        solid : manifold3d.Manifold
        part_of_id : mapping of int to str, optional
            Part name of each manifold3d original id (as tagged by
            :meth:`to_manifold`); the result's :attr:`part_names` are the names of
            the parts that still have faces, in the mapping's order.
        **kwargs
            Other :class:`Mesh` arguments (``attributes``).

        Returns
        -------
        mesh : Mesh
            Vertices welded where manifold3d split them between triangle runs.
        """
        m = solid.to_mesh64()
        vertices = np.asarray(m.vert_properties)[:, :3]
        faces = np.asarray(m.tri_verts, dtype=np.int64)
        merge_from = np.asarray(m.merge_from_vert, dtype=np.int64)
        if len(merge_from):
            # manifold3d splits vertices between triangle runs; its merge vectors weld them
            target = np.arange(len(vertices))
            target[merge_from] = np.asarray(m.merge_to_vert, dtype=np.int64)
            used, faces = np.unique(target[faces], return_inverse=True)
            vertices, faces = vertices[used], faces.reshape(-1, 3)
        if not part_of_id:
            return cls(vertices, faces, **kwargs)
        run_ids = [int(i) for i in m.run_original_id]
        unknown = [i for i in run_ids if i not in part_of_id]
        if unknown:
            raise MeshError(f"boolean result has triangles from an unknown part (id {unknown[0]})")
        counts = np.diff(np.asarray(m.run_index, dtype=np.int64)) // 3
        run_names = [part_of_id[i] for i in run_ids]
        # only the parts that still have triangles label this mesh
        present = {n for n, c in zip(run_names, counts) if c}
        names = [n for n in dict.fromkeys(part_of_id.values()) if n in present]
        index = {n: k for k, n in enumerate(names)}
        face_part = np.repeat([index.get(n, -1) for n in run_names], counts).astype(np.int32)
        return cls(vertices, faces, face_part=face_part, part_names=names, **kwargs)

    # -- files ----------------------------------------------------------------
    def export(self, path: str | os.PathLike, **options: Any) -> Any:
        """Write the mesh to a file whose format follows the suffix.

        Parameters
        ----------
        path : str or path-like
            ``.stl``, ``.3mf``, ``.usda``/``.usdc``/``.usdz``, ``.glb``, ``.obj``, ``.ply``.
        **options
            Format options: the writer's keyword arguments (see docs/export.md).

        Returns
        -------
        path : pathlib.Path
            The file written.
        """
        return formats.export(self, path, **options)

    @classmethod
    def load(cls, path: str | os.PathLike) -> Mesh:
        """Read a mesh file in any format trimesh reads (STL, OBJ, PLY, GLB, 3MF, ...).

        Parameters
        ----------
        path : str or path-like

        Returns
        -------
        mesh : Mesh
        """
        return formats.load_mesh(path)
