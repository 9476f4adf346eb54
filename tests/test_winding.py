"""Winding numbers and containment from the box tree against the brute-force sum.

The reference is the numpy solid-angle sum over every triangle for every point
(``oracle.winding_numbers``), and trimesh's ray test for ``contains``.
"""

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

from cadpipe import CadpipeError, Mesh, Path, Pipe, splice
from cadpipe.geometry.mesh import winding_numbers
from cadpipe.geometry.winding import WindingTree
from oracle import winding_numbers as brute

#: agreement with the brute-force sum (its rounding over a few thousand triangles)
ATOL = 1e-9


def helix(turns=2.0, points=120, radius=0.15, **kw):
    t = np.linspace(0.0, 2 * np.pi * turns, points)
    return Pipe(Path(np.c_[np.cos(t), np.sin(t), 0.12 * t]), radius, **kw)


def probes(mesh, count, rng, spread=0.05):
    """Points near the surface (around its vertices) and anywhere in and around its box."""
    near = mesh.vertices[rng.integers(0, len(mesh.vertices), count)] \
        + rng.normal(0, spread, (count, 3))
    lo, hi = mesh.bounds
    far = rng.uniform(lo - 0.5 * (hi - lo), hi + 0.5 * (hi - lo), (count, 3))
    return np.concatenate([near, far])


def assert_matches(mesh, points):
    w = mesh.winding_numbers(points)
    expected = brute(mesh.triangles, points)
    np.testing.assert_allclose(w, expected, rtol=0, atol=ATOL)
    np.testing.assert_array_equal(mesh.contains(points), expected > 0.5)
    return w, expected


def test_pipe_points_near_and_far_match_the_brute_force_sum():
    mesh = helix(sides=16).mesh()
    w, expected = assert_matches(mesh, probes(mesh, 1500, np.random.default_rng(1)))
    assert mesh.is_outward and set(np.unique(w)) == {0.0, 1.0}    # exact integers
    assert 0.15 < (expected > 0.5).mean() < 0.6
    # the tree is built once and kept with the (immutable) mesh
    assert mesh._winding_tree is mesh._winding_tree


def test_contains_matches_trimesh_ray_test():
    mesh = helix(turns=3.0, sides=24, caps="round").mesh()
    points = probes(mesh, 4000, np.random.default_rng(2), spread=0.1)
    tm = mesh.to_trimesh()
    # trimesh's rays are unreliable within a hair of the surface: compare away from it
    away = np.abs(trimesh.proximity.signed_distance(tm, points)) > 1e-6
    np.testing.assert_array_equal(mesh.contains(points)[away], tm.contains(points[away]))


def test_rays_through_vertices_and_edges_fall_back_to_the_exact_sum():
    """Points lined up with vertices and edge midpoints along each axis: their rays pass
    through edges and vertices, where a crossing count alone could be off by one."""
    mesh = Pipe([[0, 0, 0], [1, 0, 0], [1, 1, 0]], 0.2, sides=8).mesh()
    rng = np.random.default_rng(3)
    corners = mesh.vertices[rng.integers(0, len(mesh.vertices), 200)]
    edges = mesh.edges_unique[rng.integers(0, len(mesh.edges_unique), 200)]
    mids = mesh.vertices[edges].mean(axis=1)
    on_lines = []
    for at in (corners, mids):
        for axis in range(3):
            shifted = at.copy()
            shifted[:, axis] += rng.uniform(-0.3, 0.3, len(at))
            on_lines.append(shifted)
    points = np.concatenate(on_lines)
    # those that landed on a flat cap or side are on the surface, where nothing is owed
    points = points[np.abs(trimesh.proximity.signed_distance(mesh.to_trimesh(), points)) > 1e-9]
    tree = WindingTree(mesh.vertices, mesh.faces)
    out, unsure = np.zeros(len(points)), np.zeros(len(points), np.bool_)
    from cadpipe.core.kernels import native

    native.crossings(points, tree.tree.node_lo, tree.tree.node_hi, tree.triangles,
                     tree.tree.leaf_size, out, unsure)
    assert unsure.sum() > 50                       # the fallback is exercised
    assert_matches(mesh, points)


def test_spliced_pipes_match_the_brute_force_sum():
    mesh = splice(Pipe([[0, 0, 0], [1, 0, 0]], 0.1, sides=6),
                  Pipe([[1.4, 0, 0], [2.4, 0.3, 0.2]], 0.15, sides=9))
    assert mesh.is_oriented
    assert_matches(mesh, probes(mesh, 1500, np.random.default_rng(4), spread=0.08))


def test_nested_shells_count_twice_and_cavities_none():
    outer = helix(sides=12).mesh()
    inner = helix(radius=0.07, sides=10).mesh()
    points = probes(outer, 600, np.random.default_rng(5))
    nested = Mesh.concatenate([outer, inner])
    w, _ = assert_matches(nested, points)
    assert (w == 2).sum() > 10                             # inside both
    hollow = Mesh.concatenate([outer, Mesh(inner.vertices, inner.faces[:, ::-1])])
    w, _ = assert_matches(hollow, points)
    assert (w == 1).sum() > 10 and (w == 0).sum() > 10 and (w == 2).sum() == 0
    inside_inner = inner.contains(points)
    assert not hollow.contains(points[inside_inner]).any()     # the cavity is outside


def test_open_meshes_give_the_fractional_sum():
    """A mesh with holes has no inside: the winding number is the solid-angle sum
    (what the brute force gives), and contains is where it exceeds 1/2."""
    mesh = helix(sides=12).mesh()
    keep = np.random.default_rng(6).uniform(size=len(mesh.faces)) > 0.05
    holed = Mesh(mesh.vertices, mesh.faces[keep])
    assert not holed.is_watertight and not WindingTree(holed.vertices, holed.faces).closed
    w, _ = assert_matches(holed, probes(holed, 800, np.random.default_rng(7)))
    assert ((w > 0.01) & (w < 0.99)).sum() > 100           # not integers any more
    # a tube without caps: a point on its axis sees most of it
    tube = Pipe([[0, 0, 0], [4, 0, 0]], 0.2, sides=16).mesh()
    sides = tube.face_normals[:, 0] == 0
    open_tube = Mesh(tube.vertices, tube.faces[sides])
    w, _ = assert_matches(open_tube, np.array([[2.0, 0, 0], [0.0, 0, 0], [2.0, 1, 0]]))
    assert w[0] > 0.9 and 0.45 < w[1] < 0.5 and abs(w[2]) < 0.1   # 1/2 at its rim


def test_degenerate_triangles_change_nothing():
    """Each face (a, b, c) split at a point m of edge ab into (a, m, c), (m, b, c) and
    the zero-area (a, b, m), plus the edge-folded (a, a, b): the same closed surface,
    and the same winding numbers."""
    mesh = helix(sides=10).mesh()
    f = mesh.faces
    m = 0.5 * (mesh.vertices[f[:, 0]] + mesh.vertices[f[:, 1]])
    mi = len(mesh.vertices) + np.arange(len(f))
    faces = np.concatenate([np.c_[f[:, 0], mi, f[:, 2]], np.c_[mi, f[:, 1], f[:, 2]],
                            np.c_[f[:, 0], f[:, 1], mi], np.c_[f[:, 0], f[:, 0], f[:, 1]]])
    split = Mesh(np.concatenate([mesh.vertices, m]), faces)
    assert split.face_areas.min() == 0 and WindingTree(split.vertices, split.faces).closed
    points = probes(mesh, 400, np.random.default_rng(8))
    w, _ = assert_matches(split, points)
    np.testing.assert_array_equal(w, mesh.winding_numbers(points))


def test_triangle_soups_are_welded_and_agree():
    mesh = helix(sides=8).mesh()
    points = probes(mesh, 800, np.random.default_rng(9))
    np.testing.assert_allclose(winding_numbers(mesh.triangles, points),
                               brute(mesh.triangles, points), rtol=0, atol=ATOL)
    # unwelded corners: every triangle its own piece, the same numbers
    apart = WindingTree(mesh.triangles.reshape(-1, 3), np.arange(3 * len(mesh.faces)))
    np.testing.assert_allclose(apart(points), brute(mesh.triangles, points), rtol=0, atol=ATOL)


def test_empty_inputs():
    assert Mesh(np.zeros((0, 3)), np.zeros((0, 3), int)).winding_numbers([[0, 0, 0]]) == [0]
    mesh = helix(sides=6).mesh()
    assert mesh.contains(np.zeros((0, 3))).shape == (0,)
    assert winding_numbers(np.zeros((0, 3, 3)), np.ones((2, 3))).tolist() == [0, 0]


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), bends=st.integers(1, 5),
       radius=st.floats(0.02, 0.3), sides=st.integers(3, 20), drop=st.booleans())
def test_random_pipes_match_the_brute_force_sum(seed, bends, radius, sides, drop):
    rng = np.random.default_rng(seed)
    path = np.cumsum(rng.uniform(-1, 1, (bends + 1, 3)), axis=0) * (1 + 10 * radius)
    try:
        mesh = Pipe(Path(path), radius, sides=sides).mesh()
    except CadpipeError:                  # a path no tube fits (too sharp for the radius)
        return
    if drop:                              # and with holes
        mesh = Mesh(mesh.vertices, mesh.faces[rng.uniform(size=len(mesh.faces)) > 0.1])
    assert_matches(mesh, probes(mesh, 300, rng, spread=radius))


@pytest.mark.parametrize("scale", [1e-3, 1e4])
def test_far_from_the_origin_and_at_other_scales(scale):
    mesh = helix(sides=10).mesh()
    moved = Mesh(mesh.vertices * scale + 1e3 * scale, mesh.faces)
    points = probes(mesh, 800, np.random.default_rng(10)) * scale + 1e3 * scale
    assert_matches(moved, points)
