"""``cadpipe check`` and :func:`cadpipe.check_mesh`: the right verdict on good and broken solids."""

import json
import subprocess
import sys

import fcl
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import cadpipe
from cadpipe.cli import main
from cadpipe.core.formats import export, load_mesh
from cadpipe.io.text import float32_decimal
from cadpipe.core.float32 import coordinates as float32_coordinates
from cadpipe.geometry.intersect import box_pairs, self_intersections


def straight_pipe(length=2.0, radius=0.25, sides=12):
    return cadpipe.Pipe([[0, 0, 0], [length, 0, 0]], radius, sides=sides).mesh()


def prism_volume(length, radius, sides):
    return 0.5 * sides * radius**2 * np.sin(2 * np.pi / sides) * length


def test_watertight_pipe_is_a_valid_solid():
    report = cadpipe.check_mesh(straight_pipe())
    assert report["valid"] and report["problems"] == []
    assert report["watertight"] and report["winding_consistent"] and report["outward"]
    assert report["bodies"] == 1 and report["intersecting_face_pairs"] == 0
    assert report["volume"] == pytest.approx(prism_volume(2.0, 0.25, 12), rel=1e-12)
    np.testing.assert_allclose(report["bounds"], [[0, -0.25, -0.25], [2, 0.25, 0.25]],
                               atol=1e-12)


def test_a_hole_is_reported():
    mesh = straight_pipe()
    report = cadpipe.check_mesh(cadpipe.Mesh(mesh.vertices, mesh.faces[1:]))
    assert not report["valid"] and not report["watertight"]
    assert report["boundary_edges"] == 3
    assert any("holes" in p for p in report["problems"])


def test_inward_faces_are_reported():
    mesh = straight_pipe()
    report = cadpipe.check_mesh(cadpipe.Mesh(mesh.vertices, mesh.faces[:, ::-1]))
    assert not report["valid"] and report["watertight"] and not report["outward"]
    assert any("inward" in p for p in report["problems"])


def test_one_flipped_face_breaks_the_winding():
    faces = straight_pipe().faces.copy()
    faces[0] = faces[0, ::-1]
    report = cadpipe.check_mesh(cadpipe.Mesh(straight_pipe().vertices, faces))
    assert not report["valid"] and not report["winding_consistent"]


def crossing_pipes(offset):
    """A bent pipe and a straight one through it (not unioned), ``offset`` along z."""
    bent = cadpipe.Pipe(cadpipe.Path.spline([[0, 0, 0], [1, 0, 0], [1, 1, 0.5], [0, 1, 1]],
                                            step=0.05), 0.1, sides=12).mesh()
    rod = cadpipe.Pipe([[0.5, -1, offset], [0.5, 1, offset + 0.01]], 0.05, sides=8).mesh()
    return bent, rod


def _fcl_object(mesh):
    model = fcl.BVHModel()
    model.beginModel(len(mesh.vertices), len(mesh.faces))
    model.addSubModel(mesh.vertices, mesh.faces)
    model.endModel()
    return fcl.CollisionObject(model, fcl.Transform())


@settings(max_examples=15, deadline=None)
@given(offset=st.floats(-0.2, 0.2))
def test_self_intersections_agree_with_fcl(offset):
    bent, rod = crossing_pipes(offset)
    both = cadpipe.Mesh.concatenate([bent, rod])
    request = fcl.CollisionRequest(num_max_contacts=100_000, enable_contact=True)
    result = fcl.CollisionResult()
    fcl.collide(_fcl_object(bent), _fcl_object(rod), request, result)
    reference = {(c.b1, c.b2 + len(bent.faces)) for c in result.contacts}
    assert {tuple(p) for p in self_intersections(both).tolist()} == reference


def test_crossing_parts_are_reported():
    report = cadpipe.check_mesh(cadpipe.Mesh.concatenate(crossing_pipes(0.0)))
    assert not report["valid"] and report["watertight"] and report["bodies"] == 2
    assert report["intersecting_face_pairs"] > 0
    assert any("cut through" in p for p in report["problems"])


@settings(max_examples=20, deadline=None)
@given(boxes=st.integers(1, 300), seed=st.integers(0, 2**32 - 1))
def test_box_pairs_match_brute_force(boxes, seed):
    rng = np.random.default_rng(seed)
    lo = rng.uniform(0, 10, (boxes, 3))
    hi = lo + rng.uniform(0, 2, (boxes, 3))
    found = [tuple(sorted(p)) for p in box_pairs(lo, hi).tolist()]
    overlap = ((lo[:, None] <= hi[None]) & (lo[None] <= hi[:, None])).all(axis=2)
    expected = {(i, j) for i, j in zip(*np.nonzero(np.triu(overlap, 1)))}
    assert len(found) == len(set(found)) and set(found) == expected


# -- contacts within a file's coordinate precision ---------------------------------------
def test_float32_values_and_their_nine_digit_decimals_are_float32_coordinates():
    rng = np.random.default_rng(1)
    computed = rng.uniform(-1, 1, (1000, 3))               # float64 work: between steps
    assert not float32_coordinates(computed)
    as_float32 = computed.astype(np.float32).astype(np.float64)
    assert float32_coordinates(as_float32)
    mantissa, exponent = float32_decimal(computed)          # the 3MF / OBJ writers' text
    text = " ".join(f"{m}e{e}" for m, e in zip(mantissa.ravel(), exponent.ravel()))
    assert float32_coordinates(np.array(text.split(), float).reshape(-1, 3))
    # six digits (C's %g) are coarser than float32: not taken for float32 coordinates
    assert not float32_coordinates(np.array([f"{x:g}" for x in computed.ravel()],
                                            float).reshape(-1, 3))


def edge_on_box(depth, seed):
    """A bar lying on a box along one of its edges (turned 45 degrees about x), that edge
    ``depth`` below the box's top face (a line contact for 0, a crossing below it), the
    two turned at random so that no coordinate of the contact is a round number."""
    from scipy.spatial.transform import Rotation

    down = np.eye(4)
    down[2, 3] = -0.5                                    # top face at z = 0
    turn = np.eye(4)
    turn[1:3, 1:3] = [[np.cos(np.pi / 4), -np.sin(np.pi / 4)],
                      [np.sin(np.pi / 4), np.cos(np.pi / 4)]]
    turn[2, 3] = 0.1 * np.sqrt(2) - depth                # its lowest edge at z = -depth
    both = cadpipe.Mesh.concatenate([cadpipe.primitives.box(1.0).transformed(down),
                                     cadpipe.primitives.box([0.6, 0.2, 0.2]).transformed(turn)])
    tilt = np.eye(4)
    tilt[:3, :3] = Rotation.random(random_state=seed).as_matrix()
    tilt[:3, 3] = [0.3, 0.2, 0.1]
    return both.transformed(tilt)


@pytest.mark.parametrize("suffix", ["stl", "3mf", "obj", "ply", "glb"])
def test_a_contact_rounded_by_the_file_is_not_a_crossing_but_a_real_one_is(tmp_path, suffix):
    # 3MF and OBJ hold decimals of float32 values: they moved the contact of 4 of these 8
    # by 1e-9 m and their faces were counted as crossing (the demo cell's two arm links)
    for seed in range(8):
        touching, crossing = edge_on_box(0.0, seed), edge_on_box(1e-5, seed)
        assert len(self_intersections(touching)) == 0
        expected = self_intersections(crossing)
        assert len(expected) > 0                 # 10 micrometres deep at 1 m: a real crossing
        for mesh, pairs in ((touching, 0), (crossing, len(expected))):
            back = load_mesh(export(mesh, tmp_path / f"bar.{suffix}", units="m"))
            assert len(self_intersections(back)) == pairs, (suffix, seed)


@pytest.mark.parametrize("suffix", ["3mf", "obj"])
def test_decimal_files_flag_the_same_crossing_faces_as_pymeshlab(tmp_path, suffix):
    import pymeshlab

    both = cadpipe.Mesh.concatenate(crossing_pipes(0.0))
    back = load_mesh(export(both, tmp_path / f"crossing.{suffix}", units="m"))
    ms = pymeshlab.MeshSet()
    ms.load_new_mesh(str(export(both, tmp_path / "crossing.stl", units="m")))
    ms.compute_selection_by_self_intersections_per_face()
    theirs = np.flatnonzero(ms.current_mesh().face_selection_array())
    assert len(theirs) > 0
    np.testing.assert_array_equal(np.unique(self_intersections(back)), theirs)


# -- the command -----------------------------------------------------------------
@pytest.mark.parametrize("suffix", ["stl", "3mf", "obj", "ply", "glb"])
def test_check_accepts_a_watertight_pipe_in_any_format(tmp_path, capsys, suffix):
    target = straight_pipe().export(tmp_path / f"pipe.{suffix}")
    assert main(["check", str(target)]) == 0
    out = capsys.readouterr().out
    assert "valid closed solid" in out and "NOT" not in out


def test_check_rejects_a_mesh_with_a_hole(tmp_path, capsys):
    mesh = straight_pipe()
    target = cadpipe.Mesh(mesh.vertices, mesh.faces[1:]).export(tmp_path / "holed.stl")
    assert main(["check", str(target), "--json"]) == 1
    report = json.loads(capsys.readouterr().out)
    assert report["valid"] is False and report["boundary_edges"] == 3
    assert report["file"] == str(target)


def test_check_of_a_missing_file_is_one_line(tmp_path, capsys):
    assert main(["check", str(tmp_path / "nowhere.stl")]) == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith("cadpipe check: error:") and "no such file" in err
    assert "\n" not in err


def test_check_exit_codes_from_a_real_process(tmp_path):
    good = straight_pipe().export(tmp_path / "good.stl")
    mesh = straight_pipe()
    bad = cadpipe.Mesh(mesh.vertices, mesh.faces[1:]).export(tmp_path / "bad.stl")
    command = [sys.executable, "-m", "cadpipe", "check", "--json"]
    ok = subprocess.run(command + [str(good)], capture_output=True, text=True)
    broken = subprocess.run(command + [str(bad)], capture_output=True, text=True)
    assert (ok.returncode, broken.returncode) == (0, 1)
    assert json.loads(ok.stdout)["valid"] and not json.loads(broken.stdout)["valid"]
