"""The manifold3d layer: input validation, bounding-box grouping, batch booleans."""

import manifold3d
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import cadpipe
from cadpipe.solids import primitives
from cadpipe.geometry.mesh import reserve_ids
from cadpipe.solids.booleans import as_solid, combine, overlap_pairs


def solids(*meshes):
    ids = reserve_ids(len(meshes))
    return [as_solid(m, f"m{i}", k) for i, (m, k) in enumerate(zip(meshes, ids))]


def boxes_strategy(n):
    corners = arrays(np.float64, (n, 2, 3), elements=st.floats(-10, 10, width=32))
    return corners.map(lambda c: np.stack([c.min(axis=1), c.max(axis=1)], axis=1))


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 25).flatmap(boxes_strategy), st.integers(0, 25).flatmap(boxes_strategy))
def test_overlap_pairs_match_a_brute_force_check(a, b):
    i, j = overlap_pairs(a, b)
    found = set(zip(i.tolist(), j.tolist()))
    brute = {(p, q) for p in range(len(a)) for q in range(len(b))
             if np.all(a[p, 0] <= b[q, 1]) and np.all(b[q, 0] <= a[p, 1])}
    assert found == brute and len(found) == len(i)


def test_inside_out_mesh_is_rejected_by_name():
    box = primitives.box(1.0)
    flipped = cadpipe.Mesh(box.vertices, box.faces[:, ::-1])
    with pytest.raises(cadpipe.MeshError, match="lid: inside out"):
        as_solid(flipped, "lid", reserve_ids(1)[0])


def test_open_mesh_is_rejected_with_manifold3d_status():
    box = primitives.box(1.0)
    with pytest.raises(cadpipe.MeshError, match=r"lid: not a closed solid \(manifold3d: NotMan"):
        as_solid(cadpipe.Mesh(box.vertices, box.faces[1:]), "lid", reserve_ids(1)[0])


def test_a_void_shell_is_accepted_but_a_stray_inside_out_shell_is_not():
    big, small = primitives.box(3.0), primitives.box(1.0)
    inverted = cadpipe.Mesh(small.vertices, small.faces[:, ::-1])
    hollow = cadpipe.Mesh.concatenate([big, inverted])              # a box with a cubic void
    assert as_solid(hollow, "hollow", reserve_ids(1)[0]).volume() == pytest.approx(26.0)
    stray = cadpipe.Mesh.concatenate([big, cadpipe.Mesh(inverted.vertices + [5, 0, 0],
                                                        inverted.faces)])
    assert stray.volume > 0                                          # the total hides it
    with pytest.raises(cadpipe.MeshError, match="inside out and not a void"):
        as_solid(stray, "stray", reserve_ids(1)[0])


def test_disjoint_solids_are_composed_without_boolean_work():
    unit = primitives.box(1.0)
    cubes = [cadpipe.Mesh(unit.vertices + [2.0 * k, 0, 0], unit.faces) for k in range(4)]
    result = combine(solids(*cubes))
    assert result.volume() == pytest.approx(4.0)
    assert len(result.decompose()) == 4
    # the same cubes untouched: their triangle count is exactly the inputs'
    assert result.num_tri() == sum(len(c.faces) for c in cubes)


def test_combine_matches_manifold3d_on_the_same_operands():
    a, b, c, d = (primitives.box(1.0), primitives.sphere(0.6, 32),
                  primitives.cylinder(0.2, 3.0, 24), primitives.box(0.9))
    sa, sb, sc, sd = solids(a, b, c, d)
    ours = combine([sa, sb], [sc], [sd])
    direct = ((sa + sb) - sc) ^ sd
    assert ours.volume() == pytest.approx(direct.volume(), rel=1e-12)
    assert ours.surface_area() == pytest.approx(direct.surface_area(), rel=1e-12)
    assert ours.status() == manifold3d.Error.NoError
