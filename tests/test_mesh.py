"""The Mesh every stage shares: immutable, checks that can say no, clear errors."""

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

import cadpipe
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
    with pytest.raises(MeshError, match="not a closed solid"):
        Mesh(tube.vertices, tube.faces[2:]).to_manifold("open part")


def test_from_manifold_labels_only_the_parts_present(tube):
    solid = tube.to_manifold().as_original()
    mesh = Mesh.from_manifold(solid, part_of_id={solid.original_id(): "tube", 10 ** 6: "gone"})
    assert mesh.part_names == ("tube",)
    assert (mesh.face_part == 0).all()


def test_watertight_means_closed_as_in_trimesh(tube):
    """A closed tube with one face flipped: closed (trimesh agrees) but not oriented."""
    faces = np.array(tube.faces)
    faces[0] = faces[0, ::-1]
    flipped_one = Mesh(tube.vertices, faces)
    reference = flipped_one.to_trimesh()
    assert flipped_one.is_watertight == reference.is_watertight == True  # noqa: E712
    assert flipped_one.is_winding_consistent == reference.is_winding_consistent == False  # noqa: E712
    assert not flipped_one.is_oriented and not flipped_one.is_outward
    assert tube.is_oriented and tube.is_outward
    with pytest.raises(MeshError, match="orientation"):
        flipped_one.require_solid()


def test_edges_agree_with_trimesh(tube):
    reference = tube.to_trimesh()
    assert np.array_equal(tube.edges, reference.edges)
    assert np.array_equal(tube.edges_unique, np.unique(reference.edges_sorted, axis=0))
    assert (tube.edge_face_counts == 2).all()
    rows = tube.edge_index(tube.edges[:, 1], tube.edges[:, 0])
    assert np.array_equal(rows, tube.edges_unique_inverse)


def test_part_labels_and_attributes_are_read_only_values(tube):
    solid = tube.to_manifold().as_original()
    labelled = Mesh.from_manifold(solid, part_of_id={solid.original_id(): "tube"})
    assert labelled.part_names == ("tube",)
    pipe = Pipe([[0, 0, 0], [1, 0, 0]], 0.2, sides=6)
    assert pipe.attributes["sides"] == 6
    with pytest.raises(TypeError):
        pipe.attributes["sides"] = 7
    assert pipe.self_intersection_findings() == []


@pytest.mark.parametrize("corner", ["{v}/{t}/{n}", "{v}//{n}", "{v}/{t}", "{v}"])
def test_obj_faces_with_texture_and_normal_indices_load_as_written(tmp_path, corner):
    """``f 12/7/3 ...`` lines (as CAD exporters and robot packages write them): only the
    vertex index counts, however many digits the others have on each line."""
    import trimesh

    box = trimesh.creation.box((1, 2, 3))
    lines = [f"v {x} {y} {z}" for x, y, z in box.vertices] + ["vt 0 0", "vn 0 0 1"]
    lines += ["f " + " ".join(corner.format(v=i + 1, t=1 + 10 ** (k % 5), n=1) for i in face)
              for k, face in enumerate(box.faces)]
    path = tmp_path / "box.obj"
    path.write_text("\n".join(lines) + "\n")
    mesh = Mesh.load(path)
    assert np.array_equal(mesh.faces, box.faces)
    assert np.isclose(mesh.volume, 6.0)


def test_a_mesh_pickles_to_another_process_as_it_is():
    """Arrays, parts, attributes and ring runs survive a trip through a worker process
    (as a Dask or multiprocessing user sends meshes); the copy is read-only too."""
    import multiprocessing
    import pickle

    from cadpipe import splice

    a = Pipe([[0, 0, 0], [1, 0, 0], [1, 1, 0]], 0.1, sides=8)
    b = Pipe([[1, 1, 0], [1, 2, 0], [2, 2, 1]], 0.1, sides=12)
    for mesh in (a.mesh(), splice(a, b)):
        with multiprocessing.get_context("spawn").Pool(1) as pool:
            back = pickle.loads(pool.apply(pickle.dumps, (mesh,)))
        np.testing.assert_array_equal(back.vertices, mesh.vertices)
        np.testing.assert_array_equal(back.faces, mesh.faces)
        assert back.part_names == mesh.part_names
        assert (back.face_part is None) == (mesh.face_part is None)
        if mesh.face_part is not None:
            np.testing.assert_array_equal(back.face_part, mesh.face_part)
        assert dict(back.attributes) == dict(mesh.attributes)
        assert (back.ring_runs is None) == (mesh.ring_runs is None)
        assert back.volume == pytest.approx(mesh.volume) and back.is_watertight
        assert not back.vertices.flags.writeable


@settings(max_examples=40, deadline=None)
@given(points=st.integers(1, 300).flatmap(lambda n: st.lists(
    st.tuples(*[st.floats(-1e6, 1e6, allow_nan=False)] * 3), min_size=n, max_size=n)),
       single=st.booleans())
def test_bounds_are_the_least_and_greatest_coordinates(points, single):
    # one compiled pass (Mesh.bounds, the USD extent, the GLB accessors' min/max) against
    # numpy's reductions, exactly, in the points' own dtype
    from cadpipe.core.vec import bounds

    array = np.array(points, np.float32 if single else np.float64)
    found = bounds(array)
    assert found.dtype == array.dtype
    np.testing.assert_array_equal(found, [array.min(axis=0), array.max(axis=0)])
    np.testing.assert_array_equal(bounds(np.empty((0, 3))), np.zeros((2, 3)))


def test_mesh_bounds_match_trimesh():
    mesh = cadpipe.Pipe(cadpipe.Path.spline([[0, 0, 0], [1, 2, 0], [3, 1, 2]], step=0.05),
                        0.1, sides=12).mesh()
    np.testing.assert_array_equal(
        mesh.bounds, trimesh.Trimesh(mesh.vertices, mesh.faces, process=False).bounds)


def _edited_solids(pieces, edits, seed):
    """Faces of a few closed bodies (tubes and boxes), some faces then removed, doubled,
    flipped or rewired: closed and open meshes, several bodies, non-manifold edges."""
    rng = np.random.default_rng(seed)
    meshes = [cadpipe.Pipe([[k, 0, 0], [k, 1, 0.5 * k]], 0.3, sides=int(rng.integers(3, 9))
                           ).mesh() if k % 2 else cadpipe.primitives.box([1, 1, 1])
              for k in range(pieces)]
    mesh = Mesh.concatenate(meshes)
    faces = np.array(mesh.faces)
    for kind in edits:
        f = int(rng.integers(len(faces)))
        if kind == "drop":
            faces = np.delete(faces, f, axis=0)
        elif kind == "double":
            faces = np.vstack([faces, faces[f:f + 1]])
        elif kind == "flip":
            faces[f] = faces[f, ::-1]
        else:                                           # a corner moved to any vertex
            faces[f, int(rng.integers(3))] = int(rng.integers(len(mesh.vertices)))
    return len(mesh.vertices), faces


@settings(max_examples=80, deadline=None)
@given(pieces=st.integers(1, 4), seed=st.integers(0, 2**31),
       edits=st.lists(st.sampled_from(["drop", "double", "flip", "rewire"]), max_size=3))
def test_edge_table_pieces_and_closedness_agree_with_numpy_scipy_and_trimesh(pieces, edits,
                                                                             seed):
    # compiled passes (geometry.topology) against the sort and the sparse graph they
    # replaced, and trimesh's watertightness
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    from cadpipe.geometry.topology import closed, connected_labels, edge_table

    count, faces = _edited_solids(pieces, edits, seed)
    edges = faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    keys = edges.min(axis=1) * count + edges.max(axis=1)
    for found, expected in zip(edge_table(faces, count),
                               np.unique(keys, return_inverse=True, return_counts=True)):
        np.testing.assert_array_equal(found, expected.reshape(-1))
    graph = coo_matrix((np.ones(len(edges), np.int8), (edges[:, 0], edges[:, 1])),
                       shape=(count, count))
    np.testing.assert_array_equal(connected_labels(count, edges[:, 0], edges[:, 1]),
                                  connected_components(graph, directed=False)[1])
    watertight = trimesh.Trimesh(np.zeros((count, 3)), faces, process=False).is_watertight
    assert closed(faces, count) == watertight
    assert Mesh.trusted(np.zeros((count, 3)), faces).is_watertight == watertight
