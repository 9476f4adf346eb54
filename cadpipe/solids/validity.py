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

from cadpipe.geometry.mesh import Mesh, winding_numbers
from cadpipe.geometry.intersect import self_intersections

#: most vertices of a shell probed against another shell (those within its box)
_PROBES = 64


def nested_shells(mesh: Mesh) -> np.ndarray:
    """(K,) int array of the shells (bodies) of ``mesh`` that lie where they should not.

    Inside a valid solid every point is covered once: the winding number of the
    other shells at an outward shell's vertices is 0 (it is not inside
    another solid) and at a cavity's (an inward shell's) it is 1. A shell whose
    probe vertices say otherwise overlaps or sits inside another solid: two
    overlapping boxes in one file. Probes on another shell's surface (winding
    number near 1/2) decide nothing; only shells whose boxes overlap are compared.
    """
    if len(mesh.faces) == 0:
        return np.empty(0, np.int64)
    face_body = np.unique(mesh.body_labels[mesh.faces[:, 0]], return_inverse=True)[1].ravel()
    count = int(face_body.max()) + 1
    if count < 2:
        return np.empty(0, np.int64)
    tri = mesh.triangles
    order = np.argsort(face_body, kind="stable")
    starts = np.searchsorted(face_body[order], np.arange(count + 1))
    shells = [tri[order[starts[b]:starts[b + 1]]] for b in range(count)]
    lo = np.array([t.min(axis=(0, 1)) for t in shells])
    hi = np.array([t.max(axis=(0, 1)) for t in shells])
    volume = np.array([np.einsum("ij,ij->", t[:, 0], np.cross(t[:, 1], t[:, 2])) for t in shells])
    overlap = (lo[:, None] <= hi[None]).all(axis=2) & (lo[None] <= hi[:, None]).all(axis=2)
    np.fill_diagonal(overlap, False)
    wrong = []
    for b in np.flatnonzero(overlap.any(axis=1)):
        others = np.flatnonzero(overlap[b])
        own = np.unique(shells[b].reshape(-1, 3), axis=0)
        near = ((own[:, None] > lo[others]) & (own[:, None] < hi[others])).all(axis=2).any(axis=1)
        probes = own[near]
        if len(probes) == 0:
            continue
        probes = probes[np.linspace(0, len(probes) - 1, min(len(probes), _PROBES)).astype(int)]
        w = winding_numbers(np.concatenate([shells[o] for o in others]), probes)
        decided = np.abs(w - np.round(w)) < 0.25
        if (np.round(w[decided]) != (0 if volume[b] > 0 else 1)).any():
            wrong.append(b)
    return np.array(wrong, dtype=np.int64)


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
    report["problems"] = problems
    report["valid"] = not problems
    return report
