"""Pipes checked analytically agree with the same queries on the pipe's mesh."""

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

from cadpipe import CollisionWorld, Path, Pipe
from cadpipe.collision.capsules import Chain, round_cone_distance, unit_pair_gap
from cadpipe.geometry.mesh import winding_numbers

RADIUS = 0.2
SIDES = 32
#: an inscribed 32-gon and 5-degree fillet steps stay within this of the round tube
BAND = 0.01 * RADIUS


def smooth_pipe():
    path = Path([[0, 0, 0], [1.5, 0, 0], [1.5, 1.5, 0.5], [0, 1.5, 1.0]])
    return Pipe(path.filleted(0.5), RADIUS, sides=SIDES, caps="round", corners="round")


def test_point_queries_agree_with_the_mesh():
    pipe = smooth_pipe()
    world = CollisionWorld()
    world.add("p", pipe)
    mesh = pipe.mesh()
    rng = np.random.default_rng(11)
    along = pipe.path.points[rng.integers(0, len(pipe.path), 2000)]
    points = along + rng.normal(0, RADIUS, (2000, 3))
    analytic = world.inside("p", points).signed_distance
    away = np.abs(analytic) > BAND
    in_mesh = winding_numbers(mesh.triangles, points[away]) > 0.5
    np.testing.assert_array_equal(analytic[away] < 0, in_mesh)
    assert 300 < in_mesh.sum() < len(in_mesh) - 300
    # outside, the analytic value is the exact distance to the round tube
    outside = analytic > BAND
    to_mesh = np.abs(trimesh.proximity.signed_distance(mesh.to_trimesh(), points[outside][:500]))
    np.testing.assert_allclose(analytic[outside][:500], to_mesh, atol=BAND)


def test_pipe_to_pipe_distance_agrees_with_the_meshes():
    import fcl

    pipe = smooth_pipe()
    other = Pipe(Path.spline([[0, -1, 0.2], [1, 0.4, -0.3], [2, -0.5, 0.6]], step=0.05), 0.1,
                 sides=SIDES, caps="round")
    world = CollisionWorld()
    world.add("a", pipe)
    world.add("b", other)
    objects = []
    for m in (pipe.mesh(), other.mesh()):
        bvh = fcl.BVHModel()
        bvh.beginModel(len(m.vertices), len(m.faces))
        bvh.addSubModel(np.array(m.vertices), np.array(m.faces))
        bvh.endModel()
        objects.append(fcl.CollisionObject(bvh, fcl.Transform()))
    for dz in np.linspace(0.3, 1.2, 10):
        move = np.eye(4)
        move[2, 3] = dz
        world.set_pose("b", move)
        objects[1].setTransform(fcl.Transform(np.eye(3), move[:3, 3]))
        expected = fcl.distance(*objects, fcl.DistanceRequest(), fcl.DistanceResult())
        found = world.distance("a", "b")
        if expected > 2 * BAND:
            assert found.distance == pytest.approx(expected, abs=2 * BAND)
            assert np.linalg.norm(found.point_b - found.point_a) == pytest.approx(
                found.distance, abs=1e-9)
            # both points lie on their tube's surface
            for name, point in (("a", found.point_a), ("b", found.point_b)):
                assert abs(world.inside(name, point[None]).signed_distance[0]) < 1e-9
        else:
            assert found.distance < 3 * BAND


def test_closed_pipes_and_tapered_units():
    ring = Pipe(Path([[np.cos(a), np.sin(a), 0] for a in np.linspace(0, 2 * np.pi, 48,
                                                                        endpoint=False)],
                     closed=True), 0.1, sides=32)
    world = CollisionWorld()
    world.add("ring", ring)
    assert world.inside("ring", [[1, 0, 0]]).inside[0]
    assert not world.inside("ring", [[0, 0, 0]]).inside[0]
    cone = Pipe([[0, 0, 2], [0, 0, 3]], [0.5, 0.1], caps="round")
    world.add("cone", cone)
    sd = world.inside("cone", [[0.45, 0, 2.1], [0.45, 0, 2.9], [0, 0, 3.05]]).signed_distance
    assert sd[0] < 0 < sd[1] and sd[2] < 0


def brute_gap(a0, a1, ra0, ra1, b0, b1, rb0, rb1, n=121):
    s, t = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n), indexing="ij")
    p = a0 + s[..., None] * (a1 - a0) - b0 - t[..., None] * (b1 - b0)
    return (np.linalg.norm(p, axis=-1) - ra0 - s * (ra1 - ra0) - rb0 - t * (rb1 - rb0)).min()


coords = st.lists(st.floats(-2, 2), min_size=3, max_size=3).map(np.array)
radii = st.floats(0.01, 0.8)


@settings(max_examples=150, deadline=None)
@given(coords, coords, radii, radii, coords, coords, radii, radii)
def test_unit_gap_is_the_true_minimum(a0, a1, ra0, ra1, b0, b1, rb0, rb1):
    gap, s, t = (float(x[0]) for x in unit_pair_gap(
        a0[None], a1[None], np.array([ra0]), np.array([ra1]), b0[None], b1[None],
        np.array([rb0]), np.array([rb1])))
    assert 0 <= s <= 1 and 0 <= t <= 1
    attained = np.linalg.norm(a0 + s * (a1 - a0) - b0 - t * (b1 - b0)) \
        - ra0 - s * (ra1 - ra0) - rb0 - t * (rb1 - rb0)
    assert attained == pytest.approx(gap, abs=1e-9)
    assert gap <= brute_gap(a0, a1, ra0, ra1, b0, b1, rb0, rb1) + 1e-9


@settings(max_examples=150, deadline=None)
@given(coords, coords, radii, radii, coords)
def test_point_distance_matches_the_union_of_balls(a, b, ra, rb, p):
    sd = round_cone_distance(p[None, None], a[None], b[None], np.array([ra]), np.array([rb]))
    s = np.linspace(0, 1, 4001)[:, None]
    balls = np.linalg.norm(p - (a + s * (b - a)), axis=1) - (ra + s[:, 0] * (rb - ra))
    assert (sd[0, 0] <= 0) == (balls.min() <= 0) or abs(balls.min()) < 1e-3
    if balls.min() > 0:
        assert sd[0, 0] == pytest.approx(balls.min(), abs=1e-4)


def test_chain_gap_prunes_without_losing_the_minimum():
    rng = np.random.default_rng(2)
    a = Chain.along(np.cumsum(rng.normal(0, 0.3, (60, 3)), axis=0), 0.05)
    b = Chain.along(np.cumsum(rng.normal(0, 0.3, (45, 3)), axis=0) + 1.0, 0.08)
    gap, pa, pb = a.gap(b)
    i, j = np.meshgrid(np.arange(len(a.edges)), np.arange(len(b.edges)), indexing="ij")
    i, j = i.ravel(), j.ravel()
    every = unit_pair_gap(a.starts[i], a.ends[i], a.start_radii[i], a.end_radii[i],
                          b.starts[j], b.ends[j], b.start_radii[j], b.end_radii[j])[0]
    assert gap == pytest.approx(every.min(), abs=1e-12)
