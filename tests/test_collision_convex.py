"""The convex pieces' clearance bound (GJK): never above the exact clearance, and
close to it for convex bodies, so it can stand in for exact queries."""

import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

from cadpipe import Mesh, Path, Pipe
from cadpipe.collision import Box, narrow
from cadpipe.collision.bodies import as_body
from cadpipe.collision.convex import Pieces, body_gaps


def bodies():
    ellipsoid = Mesh.from_trimesh(trimesh.creation.icosphere(2, 0.3)).transformed(
        np.diag([1.0, 0.5, 2.0, 1.0]))
    ring = Mesh.from_trimesh(trimesh.creation.torus(0.3, 0.08, major_sections=24,
                                                    minor_sections=12))
    duct = Pipe(Path.spline([[-0.4, 0.5, 0.05], [0.1, 0.5, 0.7], [0.6, 0.35, 0.95]],
                            step=0.05), 0.04, caps="round")
    hose = Pipe([[-0.6, 0.6, 0.1], [-0.2, 0.1, 0.8], [0.3, -0.5, 1.3]], [0.04, 0.1, 0.05],
                caps="round")
    return [as_body(b, str(k)) for k, b in enumerate((ellipsoid, Box((0.4, 0.2, 0.6)), ring,
                                                      duct, hose))]


def poses(rng, count):
    m = np.tile(np.eye(4), (count, 1, 1))
    m[:, :3, :3] = Rotation.random(count, random_state=rng).as_matrix()
    m[:, :3, 3] = rng.uniform(-1.0, 1.0, (count, 3))
    return m


@pytest.mark.parametrize("other", [1, 2, 3, 4])
def test_the_bound_is_below_the_exact_clearance_and_tight_for_convex_pairs(other):
    rng = np.random.default_rng(other)
    found = bodies()
    pieces = Pieces(found)
    count = 300
    pose_a, pose_b = poses(rng, count), poses(rng, count)
    bound = np.empty(count)
    body_gaps(*pieces.arrays(), np.zeros(count, np.int64), pose_a,
              np.full(count, other, np.int64), pose_b, np.full(count, np.inf), bound)
    exact = np.array([narrow.distance(found[0], a, found[other], b)[0]
                      for a, b in zip(pose_a, pose_b)])
    assert np.all(bound <= exact + 1e-12)
    apart = exact > 0
    assert apart.mean() > 0.5
    # the ellipsoid's and box's hulls are the bodies (a pipe's units are its pieces):
    # the bound is the clearance but for the iteration's last step and the meshing
    close = bound[apart] >= exact[apart] - 0.02 * (1 + exact[apart])
    assert close.mean() > (0.9 if other != 2 else 0.3)
    # a pair the bound calls apart is apart
    assert np.all(exact[bound > 0] > 0)


def test_a_needed_clearance_stops_the_search_early_but_stays_a_bound():
    rng = np.random.default_rng(7)
    found = bodies()
    pieces = Pieces(found)
    count = 200
    pose_a, pose_b = poses(rng, count), poses(rng, count)
    full, early = np.empty(count), np.empty(count)
    ids = np.zeros(count, np.int64), np.full(count, 3, np.int64)
    body_gaps(*pieces.arrays(), ids[0], pose_a, ids[1], pose_b, np.full(count, np.inf), full)
    body_gaps(*pieces.arrays(), ids[0], pose_a, ids[1], pose_b, np.full(count, 0.05), early)
    assert np.all(early <= full + 1e-12)
    # what the caller needed is reached wherever the full bound reaches it
    assert np.all(early[full >= 0.05] >= 0.05)


def test_bodies_that_are_their_pieces_get_the_clearance_bracketed():
    """For a convex mesh, a box and a pipe of one radius the two GJK bounds bracket
    the exact clearance and meet it; other bodies are not marked exact."""
    from cadpipe.collision.bodies import Surface
    from cadpipe.collision.convex import body_bounds

    found = bodies()
    cup = Mesh.from_trimesh(trimesh.creation.box(extents=[0.2, 0.2, 0.2]))
    cup = Mesh(cup.vertices, cup.faces[cup.face_normals[:, 2] < 0.9])
    extra = [as_body(Surface(cup), "cup"), as_body(Box((0.1, 0.2, 0.3)), "box")]
    pieces = Pieces(found + extra)
    # ellipsoid, box, torus (not convex), duct (one radius), hose (tapered), cup (open), box
    assert pieces.exact.tolist() == [True, True, False, True, False, False, True]
    rng = np.random.default_rng(12)
    checked = 0
    for other in (1, 3, 6):
        pose_a, pose_b = poses(rng, 150), poses(rng, 150)
        for a, b in zip(pose_a, pose_b):
            lower, upper = body_bounds(*pieces.arrays(), 0, a, other, b, np.inf)
            exact = narrow.distance(found[0], a, (found + extra)[other], b)[0]
            assert lower <= exact + 1e-12
            if exact > 0:
                assert upper >= exact - 1e-9 and upper - lower <= 1e-6 * (1 + exact)
                checked += 1
            else:
                assert lower <= 0
    assert checked > 200
