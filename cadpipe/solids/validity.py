"""Is a mesh a valid closed solid? The report behind ``cadpipe check``.

A mesh is a valid solid, fit to print, boolean or collide, when it is closed
(``watertight``: every edge has exactly two faces, trimesh's meaning), its faces
agree on orientation (``winding_consistent``; both together are
:attr:`~cadpipe.Mesh.is_oriented`), they point outward (positive volume) and no two
faces cut through each other.
"""

from typing import Any

from cadpipe.geometry.mesh import Mesh
from cadpipe.solids.intersect import self_intersections


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
    ``bodies`` (connected pieces) and ``intersecting_face_pairs`` (how many pairs of
    faces cut through each other: :func:`~cadpipe.solids.intersect.self_intersections`).
    """
    boundary = int((mesh.edge_face_counts == 1).sum())
    nonmanifold = int((mesh.edge_face_counts > 2).sum())
    crossing = len(self_intersections(mesh))
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
    report["problems"] = problems
    report["valid"] = not problems
    return report
