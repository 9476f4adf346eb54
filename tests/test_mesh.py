"""The Mesh every stage shares: immutable, checks that can say no, clear errors."""

import numpy as np
import pytest

from cadpipe import InputError, Mesh, MeshError, Pipe


@pytest.fixture
def tube():
    return Pipe([[0, 0, 0], [1, 0, 0]], 0.2, sides=6).mesh()


def test_arrays_are_read_only(tube):
    with pytest.raises(ValueError):
        tube.vertices[0, 0] = 1.0
    with pytest.raises(ValueError):
        tube.faces[0, 0] = 1


def test_a_hole_is_not_watertight(tube):
    holed = Mesh(tube.vertices, tube.faces[1:])
    assert tube.is_watertight and not holed.is_watertight
    with pytest.raises(MeshError, match="not a closed solid"):
        holed.require_solid("holed")


def test_flipped_mesh_has_negative_volume(tube):
    flipped = Mesh(tube.vertices, tube.faces[:, ::-1])
    assert flipped.is_watertight
    assert flipped.volume == pytest.approx(-tube.volume)
    assert not flipped.is_outward
    with pytest.raises(MeshError, match="inward"):
        flipped.require_solid()


def test_mirror_transform_keeps_outward_faces(tube):
    mirrored = tube.transformed(np.diag([-1.0, 1, 1, 1]))
    assert mirrored.volume == pytest.approx(tube.volume)


def test_concatenate_counts_bodies_and_labels_parts(tube):
    two = Mesh.concatenate([tube.with_parts(["a"]),
                            tube.transformed(np.eye(4) + np.eye(4, k=3) * 5).with_parts(["b"])])
    assert two.n_bodies == 2
    assert two.part_names == ("a", "b")
    assert np.bincount(two.face_part).tolist() == [len(tube.faces)] * 2


def test_winding_numbers_inside_and_outside(tube):
    w = tube.winding_numbers([[0.5, 0, 0], [0.5, 0.5, 0], [-0.1, 0, 0]])
    assert np.allclose(w, [1, 0, 0], atol=1e-9)


@pytest.mark.parametrize("vertices, faces, word", [
    ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 3]], "faces"),
    ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1]], "faces"),
    ([[0, 0, 0], [1, 0, np.nan], [0, 1, 0]], [[0, 1, 2]], "vertices"),
    ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0.0, 1.0, 2.0]], "faces"),
])
def test_bad_mesh_input(vertices, faces, word):
    with pytest.raises(InputError, match=word):
        Mesh(vertices, faces)


def test_manifold_rejects_open_mesh_with_cadpipe_error(tube):
    with pytest.raises(MeshError, match="manifold3d rejected"):
        Mesh(tube.vertices, tube.faces[2:]).to_manifold("open part")


def test_from_manifold_labels_only_the_parts_present(tube):
    solid = tube.to_manifold().as_original()
    mesh = Mesh.from_manifold(solid, part_names={solid.original_id(): "tube", 10 ** 6: "gone"})
    assert mesh.part_names == ("tube",)
    assert (mesh.face_part == 0).all()
