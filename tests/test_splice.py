"""Step S5: spliced pipes are one seamless, watertight, outward solid."""

import math

import numpy as np
import pytest
import trimesh

import cadpipe
from cadpipe import InputError, Pipe, splice

PAIRS = [(3, 4), (4, 6), (5, 7), (6, 8), (12, 16), (8, 8), (3, 24), (7, 9)]


def straight(x0, x1, radius, sides, **kw):
    return Pipe([[x0, 0, 0], [x1, 0, 0]], radius, sides=sides, **kw)


def corners(polygon_2d):
    """Vertices of a closed 2D polygon where the boundary really turns."""
    p = np.asarray(polygon_2d)
    a, b = np.roll(p, 1, axis=0) - p, np.roll(p, -1, axis=0) - p
    cross = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    scale = np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1)
    return int((np.abs(cross) > 1e-7 * scale).sum())


def assert_solid(mesh, genus=0):
    assert mesh.is_watertight and mesh.is_winding_consistent
    assert mesh.volume > 0
    assert mesh.n_bodies == 1
    assert mesh.genus == genus
    assert mesh.face_areas.min() > 0
    assert mesh.to_manifold().volume() == pytest.approx(mesh.volume, rel=1e-9)


@pytest.mark.parametrize("n1, n2", PAIRS)
def test_lcm_transition_is_seamless(n1, n2):
    r1, r2 = 0.1, 0.14
    mesh = splice(straight(0, 1, r1, n1), straight(1.6, 2.6, r2, n2))
    assert_solid(mesh)
    section = mesh.to_trimesh().section(plane_origin=[1.3, 0, 0], plane_normal=[1, 0, 0])
    polygon, _ = section.to_2D()
    assert len(polygon.polygons_closed) == 1
    assert corners(polygon.polygons_closed[0].exterior.coords[:-1]) == math.lcm(n1, n2)
    # the transition lies between the smaller mouth's prism and the larger mouth's cylinder
    ends = straight(0, 1, r1, n1).mesh().volume + straight(1.6, 2.6, r2, n2).mesh().volume
    transition = mesh.volume - ends
    area_min = 0.5 * n1 * r1 ** 2 * np.sin(2 * np.pi / n1)
    assert area_min * 0.6 < transition < np.pi * r2 ** 2 * 0.6


@pytest.mark.parametrize("n1, n2", [(16, 17), (31, 32)])
def test_merge_transition_is_watertight_and_small(n1, n2):
    lcm = splice(straight(0, 1, 0.1, n1), straight(1.5, 2.5, 0.1, n2))
    merge = splice(straight(0, 1, 0.1, n1), straight(1.5, 2.5, 0.1, n2), transition="merge")
    assert_solid(merge)
    # the merge's rings have n1 or n2 vertices, far fewer than lcm(n1, n2)
    assert len(merge.vertices) < len(lcm.vertices) / 4


def test_touching_pipes_are_stitched_over_a_short_stretch():
    mesh = splice(straight(0, 1, 0.1, 4), straight(1, 2, 0.1, 6))
    assert_solid(mesh)
    assert mesh.bounds[0, 0] == pytest.approx(0) and mesh.bounds[1, 0] == pytest.approx(2)


def test_bent_chain_with_round_end_caps_and_envelopes():
    p1 = Pipe(cadpipe.Path.spline([[0, 0, 0], [1, 0.3, 0], [2, 0, 0.2]], step=0.05), 0.08,
              sides=5, caps="round", envelope=True)
    p2 = Pipe([[2.5, 0.3, 0.3], [3, 1, 0.3], [3, 2, 0]], [0.1, 0.12, 0.1], sides=8,
              caps="round")
    mesh = splice(p1, p2)
    assert_solid(mesh)
    assert set(mesh.part_names) == {"pipe0", "pipe1", "transition0"}
    # caps only at the chain's two ends: the joint's vertices are all in the side surface
    assert mesh.bounds[0, 0] < -0.07 and mesh.bounds[1, 1] > 2.05


def test_twisted_mouth_is_met_without_twist():
    a = straight(0, 1, 0.1, 6)
    b = straight(1.5, 2.5, 0.1, 6, normal=[0, np.sin(0.4), np.cos(0.4)])
    mesh = splice(a, b)
    assert_solid(mesh)
    # stitch edges stay short: no edge in the transition is longer than its rings' spacing
    # plus the chord the 0.4 rad rotation (less one 60-degree step) needs
    faces = mesh.faces[mesh.face_part == mesh.part_names.index("transition0")]
    edges = mesh.vertices[faces] - mesh.vertices[np.roll(faces, 1, axis=1)]
    assert np.linalg.norm(edges, axis=2).max() < 0.5 / 3 + 0.1 * 0.4 + 0.1 * 2 * np.sin(np.pi / 6)


def test_chain_of_fifty_random_pipes_is_watertight():
    rng = np.random.default_rng(7)
    pipes = []
    for i in range(50):
        a0 = i * 2 * np.pi / 52
        a1 = a0 + 2 * np.pi / 52 * 0.6
        arc = np.linspace(a0, a1, 5)
        pts = np.c_[5 * np.cos(arc), 5 * np.sin(arc), 0.1 * np.sin(3 * arc)]
        pipes.append(Pipe(pts, rng.uniform(0.03, 0.08), sides=int(rng.integers(3, 25))))
    mesh = splice(*pipes, transition="merge")
    assert_solid(mesh)
    assert mesh.to_trimesh().is_watertight


def test_closed_chain_is_a_torus():
    s = np.linspace(0, 2 * np.pi, 4)[:-1]
    corners_xy = np.c_[np.cos(s), np.sin(s), 0 * s]
    pipes = [Pipe([corners_xy[i] * 1.0 + (corners_xy[(i + 1) % 3] - corners_xy[i]) * 0.2,
                   corners_xy[i] + (corners_xy[(i + 1) % 3] - corners_xy[i]) * 0.8],
                  0.05, sides=n) for i, n in enumerate([3, 4, 5])]
    mesh = splice(*pipes, closed=True)
    assert_solid(mesh, genus=1)
    assert len(mesh.part_names) == 6


def test_bad_splice_input():
    with pytest.raises(InputError, match="at least one"):
        splice()
    with pytest.raises(InputError, match="argument 1"):
        splice(straight(0, 1, 0.1, 4), trimesh.creation.box())
    with pytest.raises(InputError, match="transition"):
        splice(straight(0, 1, 0.1, 4), straight(2, 3, 0.1, 4), transition="gcd")
    loop = Pipe(cadpipe.Path([[0, 0, 0], [1, 0, 0], [0, 1, 0]], closed=True), 0.05)
    with pytest.raises(InputError, match="closed loop"):
        splice(loop, straight(2, 3, 0.1, 4))
    # the second pipe starts just behind the first one's end, pointing back at it: no
    # transition fits, so a ball joint joins them (tests/test_chain_pieces.py)
    backwards = Pipe([[0.95, 0.05, 0], [0.0, 0.05, 0]], 0.1, sides=4)
    assert "joint0" in splice(straight(0, 1, 0.1, 4), backwards).part_names
