"""One shape for collision and files: a Pipe's collision chain contains its mesh
(miter tips, caps, envelopes, repaired stretches) and exceeds it by at most its
largest unit radius."""

import numpy as np
import pytest
import trimesh

from cadpipe import CollisionWorld, Pipe
from cadpipe.collision.bodies import Sphere, as_body
from cadpipe.collision.capsules import Chain

L_BEND = [[0, 0, 0], [1, 0, 0], [1, 1, 0]]


def pipes():
    return [Pipe(L_BEND, 0.05, 4),                                      # long miter tips
            Pipe(L_BEND, 0.05, 16, caps="round"),
            Pipe(L_BEND, 0.05, 8, caps="round", envelope=True),
            Pipe(L_BEND, 0.05, 8, caps="flat", envelope=True),
            Pipe([[0, 0, 0], [1, 0, 0], [0.35, 0.5, 0.1]], 0.04, 6),   # a 140-ish degree turn
            Pipe([[0, 0, 0], [1, 0, 0], [1.3, 0.6, 0.4]], [0.12, 0.06, 0.03], 12,
                 envelope=True),
            Pipe(np.c_[np.cos(np.arange(7) * 2 * np.pi / 7), np.sin(np.arange(7) * 2 * np.pi / 7),
                       np.zeros(7)], 0.08, 5, caps="round"),
            Pipe(cadpipe_loop(), 0.1, 6),
            Pipe(L_BEND, 0.05, 6, caps="round")]


def cadpipe_loop():
    import cadpipe

    t = np.linspace(0, 2 * np.pi, 9, endpoint=False)
    return cadpipe.Path(np.c_[np.cos(t), np.sin(t), 0.2 * np.sin(2 * t)], closed=True)


@pytest.mark.parametrize("index", range(9))
def test_chain_contains_every_mesh_vertex(index):
    pipe = pipes()[index]
    chain = as_body(pipe, "pipe").chain
    mesh = pipe.mesh()
    depth = chain.signed_distance(mesh.vertices)
    assert depth.max() <= 1e-9 * float(pipe.ring_radii.max())
    # and points just outside the faces' centres are not far from the chain either
    tri = mesh.vertices[mesh.faces]
    assert chain.signed_distance(tri.mean(axis=1)).max() <= 1e-9


@pytest.mark.parametrize("index", [0, 2, 3, 5])
def test_chain_exceeds_the_mesh_by_at_most_its_largest_unit_radius(index):
    pipe = pipes()[index]
    chain = as_body(pipe, "pipe").chain
    tolerance = float(chain.radii.max())
    rng = np.random.default_rng(index)
    lo, hi = pipe.mesh().vertices.min(axis=0) - 0.2, pipe.mesh().vertices.max(axis=0) + 0.2
    points = rng.uniform(lo, hi, size=(4000, 3))
    inside_chain = points[chain.signed_distance(points) < 0]
    mesh = trimesh.Trimesh(pipe.mesh().vertices, pipe.mesh().faces)
    _, distance, _ = trimesh.proximity.closest_point(mesh, inside_chain)
    assert distance.max() <= tolerance * (1 + 1e-9)


def test_a_ball_inside_the_mesh_near_a_right_angle_corner_collides():
    """The 0.1 chain of balls on the path missed the miter tip: 'not colliding'."""
    pipe = Pipe(L_BEND, 0.05, 4)
    tip = pipe.rings()[1]
    far = tip[np.argmax(np.linalg.norm(tip - [1, 0, 0], axis=1))]
    centre = np.array([1, 0, 0]) + 0.85 * (far - [1, 0, 0])       # inside, near the tip
    assert pipe.mesh().contains(centre[None])[0]
    old = Chain.along(pipe.path.points, pipe.ring_radii)
    assert old.signed_distance(centre[None])[0] > 0.005            # the old model missed it
    world = CollisionWorld()
    world.add("pipe", pipe)
    pose = np.eye(4)
    pose[:3, 3] = centre
    world.add("ball", Sphere(0.005), transform=pose)
    assert world.check().colliding
