"""Is a mesh a valid closed solid? The report behind ``cadpipe check``.

A mesh is a valid solid, fit to print, boolean or collide, when it is closed
(``watertight``: every edge has exactly two faces, trimesh's meaning), its faces
agree on orientation (``winding_consistent``; both together are
:attr:`~cadpipe.Mesh.is_oriented`), they point outward (positive volume), no two
faces cut through each other and no shell lies inside another (two overlapping
boxes in one file are two solids, not one; a cavity, an inward shell inside an
outward one, is fine).
"""

from typing import Any

import numpy as np

from cadpipe.geometry.mesh import Mesh
from cadpipe.geometry.winding import WindingTree
from cadpipe.geometry.intersect import self_intersections

#: most vertices of a shell probed against another shell (those within its box)
_PROBES = 64


def nested_shells(mesh: Mesh) -> np.ndarray:
    """(K,) int array of the shells (bodies) of ``mesh`` that lie where they should not.

    Inside a valid solid every point is covered once: the winding number of the
    other shells just inside an outward shell is 0 (it is not inside another
    solid) and just inside a cavity's wall (an inward shell's) it is 1. A shell whose
    probes say otherwise overlaps or sits inside another solid: two overlapping boxes
    in one file. The probes are face centres moved a millionth of the face's size
    against its normal, into the shell's own material: a vertex of a shell that only
    touches another (a pipe lying along a box's edge) sits on that shell's surface,
    where the winding number is anything from 0 to 1. Probes that still come out near
    1/2 decide nothing; only shells whose boxes overlap are compared.
    """
    if len(mesh.faces) == 0:
        return np.empty(0, np.int64)
    face_body = np.unique(mesh.body_labels[mesh.faces[:, 0]], return_inverse=True)[1].ravel()
    count = int(face_body.max()) + 1
    if count < 2:
        return np.empty(0, np.int64)
    order = np.argsort(face_body, kind="stable")
    starts = np.searchsorted(face_body[order], np.arange(count + 1))
    shells = [mesh.faces[order[starts[b]:starts[b + 1]]] for b in range(count)]
    vertices = mesh.vertices
    lo = np.array([vertices[f].min(axis=(0, 1)) for f in shells])
    hi = np.array([vertices[f].max(axis=(0, 1)) for f in shells])
    overlap = (lo[:, None] <= hi[None]).all(axis=2) & (lo[None] <= hi[:, None]).all(axis=2)
    np.fill_diagonal(overlap, False)
    trees = {}                        # one tree a shell, built when first probed: the
                                      # shells of a union of 1,000 pipes chain in one box
    def tree(b):
        if b not in trees:
            used, local = np.unique(shells[b], return_inverse=True)
            trees[b] = WindingTree(vertices[used], local.reshape(-1, 3))
        return trees[b]

    wrong = []
    for b in np.flatnonzero(overlap.any(axis=1)):
        others = np.flatnonzero(overlap[b])
        t = vertices[shells[b]]
        normal = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])          # twice the area
        volume = np.einsum("ij,ij->", t[:, 0], np.cross(t[:, 1], t[:, 2]))
        area = np.linalg.norm(normal, axis=1)
        t, normal, area = t[area > 0], normal[area > 0], area[area > 0]
        own = t.mean(axis=1) - 1e-6 * normal / np.sqrt(area)[:, None]
        held = ((own[:, None] > lo[others]) & (own[:, None] < hi[others])).all(axis=2)
        near = np.flatnonzero(held.any(axis=1))      # probes some other shell's box holds
        if len(near) == 0:
            continue
        pick = near[np.linspace(0, len(near) - 1, min(len(near), _PROBES)).astype(int)]
        probes, reach = own[pick], held[pick]
        w = np.zeros(len(probes))
        for k, o in enumerate(others):        # only the shells whose box holds a probe
            if reach[:, k].any():
                w += tree(o)(probes)
        decided = np.abs(w - np.round(w)) < 0.25
        if (np.round(w[decided]) != (0 if volume > 0 else 1)).any():
            wrong.append(b)
    return np.array(wrong, dtype=np.int64)


def problems_of(mesh: Mesh, crossing=None, nested=None) -> list[str]:
    """One sentence per way ``mesh`` fails to be a valid solid (none: it is one): the
    test :func:`check_mesh` reports and every union and build holds its result to.

    ``crossing`` and ``nested`` are the counts of :func:`self_intersections` and
    :func:`nested_shells` when already known."""
    boundary = int((mesh.edge_face_counts == 1).sum())
    nonmanifold = int((mesh.edge_face_counts > 2).sum())
    crossing = len(self_intersections(mesh)) if crossing is None else crossing
    nested = len(nested_shells(mesh)) if nested is None else nested
    problems = []
    if len(mesh.faces) == 0:
        problems.append("the mesh has no triangles")
    if boundary:
        problems.append(f"{boundary} edges belong to one face only: the surface has holes")
    if nonmanifold:
        problems.append(f"{nonmanifold} edges are shared by more than two faces")
    if not mesh.is_winding_consistent:
        problems.append("neighbouring faces disagree on orientation (inconsistent winding)")
    if mesh.is_oriented and mesh.volume <= 0:
        problems.append(f"faces point inward (volume {mesh.volume:.6g}); flip them")
    if crossing:
        problems.append(f"{crossing} pairs of faces cut through each other")
    if nested:
        problems.append(f"{nested} shells overlap or lie inside other solids (several "
                        "solids in one mesh: union them)")
    return problems


def check_mesh(mesh: Mesh) -> dict[str, Any]:
    """A report on ``mesh`` as a dict of plain values (JSON-ready).

    Parameters
    ----------
    mesh : Mesh

    Returns
    -------
    report : dict
        The keys below.

    Keys: ``valid`` (a closed, consistently wound, outward, non-self-intersecting
    solid), ``problems`` (one sentence per failed check), ``triangles``,
    ``vertices``, ``watertight``, ``boundary_edges`` (edges of one face: holes),
    ``nonmanifold_edges`` (edges of three or more faces), ``winding_consistent``,
    ``outward``, ``volume``, ``area``, ``bounds`` (``[[min x, y, z], [max x, y, z]]``),
    ``bodies`` (connected pieces), ``intersecting_face_pairs`` (how many pairs of
    faces cut through each other: :func:`~cadpipe.geometry.intersect.self_intersections`)
    and ``nested_shells`` (shells overlapping or inside other solids, see
    :func:`nested_shells`).
    """
    boundary = int((mesh.edge_face_counts == 1).sum())
    nonmanifold = int((mesh.edge_face_counts > 2).sum())
    crossing = len(self_intersections(mesh))
    nested = len(nested_shells(mesh))
    report = {
        "triangles": len(mesh.faces),
        "vertices": len(mesh.vertices),
        "watertight": mesh.is_watertight,
        "boundary_edges": boundary,
        "nonmanifold_edges": nonmanifold,
        "winding_consistent": mesh.is_winding_consistent,
        "outward": mesh.is_outward,
        "volume": mesh.volume,
        "area": mesh.area,
        "bounds": mesh.bounds.tolist(),
        "bodies": mesh.n_bodies,
        "intersecting_face_pairs": crossing,
        "nested_shells": nested,
    }
    problems = problems_of(mesh, crossing, nested)
    report["problems"] = problems
    report["valid"] = not problems
    return report
