"""Primitives and imported meshes: closed, outward solids of the right size."""

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

import cadpipe
from cadpipe.solids import primitives
from cadpipe.solids.booleans import snap


def polygon_area(radius, sides):
    return 0.5 * sides * radius ** 2 * np.sin(2 * np.pi / sides)


@settings(max_examples=25, deadline=None)
@given(st.tuples(*[st.floats(0.01, 10.0)] * 3), st.booleans())
def test_box_is_a_closed_outward_solid_of_its_size(size, center):
    box = primitives.box(size, center=center)
    assert box.is_watertight and box.is_outward
    assert box.volume == pytest.approx(np.prod(size), rel=1e-9)
    low = -np.array(size) / 2 if center else np.zeros(3)
    np.testing.assert_allclose(box.bounds, [low, low + size], atol=1e-12)


@settings(max_examples=25, deadline=None)
@given(st.floats(0.01, 5.0), st.floats(0.01, 5.0), st.integers(3, 96))
def test_cylinder_volume_is_its_prism_volume(radius, height, sides):
    cyl = primitives.cylinder(radius, height, sides)
    assert cyl.is_watertight and cyl.is_outward
    assert cyl.volume == pytest.approx(polygon_area(radius, sides) * height, rel=1e-9)
    assert cyl.bounds[0, 2] == pytest.approx(-height / 2) and cyl.bounds[1, 2] == pytest.approx(
        height / 2)


def test_sphere_is_closed_with_vertices_on_the_sphere_and_near_its_volume():
    ball = primitives.sphere(0.5, segments=64)
    assert ball.is_watertight and ball.is_outward and ball.genus == 0
    np.testing.assert_allclose(np.linalg.norm(ball.vertices, axis=1), 0.5, rtol=1e-9)
    assert ball.volume == pytest.approx(4 / 3 * np.pi * 0.5 ** 3, rel=0.01)
    assert ball.volume < 4 / 3 * np.pi * 0.5 ** 3              # inscribed


@pytest.mark.parametrize("call", [lambda: primitives.box(-1), lambda: primitives.box([1, 2]),
                                  lambda: primitives.cylinder(0.1, 0),
                                  lambda: primitives.cylinder(0.1, 1, sides=2),
                                  lambda: primitives.sphere(float("nan"))])
def test_bad_primitive_arguments_raise_input_errors(call):
    with pytest.raises(cadpipe.InputError):
        call()


@pytest.mark.parametrize("suffix", ["stl", "obj", "ply", "glb"])
def test_imported_mesh_round_trips_through_each_format(tmp_path, suffix):
    box = primitives.box([1, 2, 3])
    file = tmp_path / f"box.{suffix}"
    box.to_trimesh().export(file)
    mesh = primitives.imported(file)
    assert mesh.is_watertight and mesh.volume == pytest.approx(6.0, rel=1e-6)
    assert mesh.attributes["kind"] == "mesh"


def test_snap_welds_vertices_a_file_repeated_with_rounding_noise():
    box = primitives.box(1.0).to_trimesh()
    corners = box.triangles.reshape(-1, 3)                 # every triangle's own corners
    noisy = corners + np.random.default_rng(0).uniform(-1e-8, 1e-8, corners.shape)
    split = cadpipe.Mesh(noisy, np.arange(len(corners)).reshape(-1, 3))
    assert not split.is_watertight
    welded = snap(split)
    assert welded.is_watertight and len(welded.vertices) == 8
    assert welded.volume == pytest.approx(1.0, rel=1e-6)


def test_importing_an_open_mesh_names_the_file(tmp_path):
    open_box = trimesh.creation.box()
    open_box.update_faces(np.arange(len(open_box.faces)) > 1)     # drop one side
    file = tmp_path / "open.stl"
    open_box.export(file)
    with pytest.raises(cadpipe.MeshError, match="open.stl: not a closed solid"):
        primitives.imported(file)


def test_importing_an_inside_out_mesh_says_to_flip_it(tmp_path):
    box = trimesh.creation.box()
    file = tmp_path / "flipped.stl"
    trimesh.Trimesh(box.vertices, box.faces[:, ::-1], process=False).export(file)
    with pytest.raises(cadpipe.MeshError, match="flip its faces"):
        primitives.imported(file)
