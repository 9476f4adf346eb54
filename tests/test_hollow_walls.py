"""Hollow walls are ``wall`` thick across the faces (issue 10): along tapers, round and
flat closed ends, bends and a chain's transitions. Measured by sampling the bore's
surface and asking trimesh for each point's distance to the outer surface (an
independent reference)."""

import numpy as np
import pytest
import trimesh

from cadpipe import HollowChain, HollowPipe, Pipe

WALL = 0.02


def thinnest(hollow):
    """The smallest distance from the bore's surface (vertices, face centres and random
    samples) to the outer surface, over ``hollow.wall``."""
    bodies, bores = hollow.solids()
    outer = trimesh.util.concatenate([b.to_trimesh() for b in bodies])
    inner = trimesh.util.concatenate([b.to_trimesh() for b in bores])
    points = np.concatenate([inner.vertices, inner.triangles_center,
                             trimesh.sample.sample_surface(inner, 4000, seed=1)[0]])
    assert outer.contains(points).all()          # closed ends: the bore is inside
    return float(trimesh.proximity.closest_point(outer, points)[1].min()) / hollow.wall


@pytest.mark.parametrize("pipe, least", [
    (Pipe([[0, 0, 0], [1, 0, 0]], 0.1, 4), 1),                               # square duct
    (Pipe([[0, 0, 0], [1, 0, 0]], 0.1, 6), 1),                               # hex duct
    (Pipe([[0, 0, 0], [0.5, 0, 0], [1, 0, 0]], [0.1, 0.2, 0.1], 8), 1),      # tapers
    (Pipe([[0, 0, 0], [1, 0, 0]], 0.1, 8, caps="round"), 1),
    (Pipe([[0, 0, 0], [1, 0, 0]], 0.1, 16, caps="round"), 1),
    (Pipe([[0, 0, 0], [1, 0, 0]], 0.1, 8, caps="round", envelope=True), 1),
    (Pipe([[0, 0, 0], [1, 0, 0]], 0.1, 6, envelope=True), 1),                # flat, r past
    (Pipe([[0, 0, 0], [1, 0, 0], [1, 1, 0.3]], 0.1, 6), 1),                  # a bend
    (Pipe([[0, 0, 0], [1, 0, 0], [1, 1, 0.3]], 0.1, 8, caps="round"), 1),
    # known short of the wall: a round cap on a cone (0.9999), a tapered 90 degree
    # miter (0.96: the taper is made up for along the path, not in the stretched ring)
    (Pipe([[0, 0, 0], [1, 0, 0]], [0.1, 0.3], 6, caps="round"), 0.999),
    (Pipe([[0, 0, 0], [1, 0, 0], [1, 1, 0.3]], [0.1, 0.15, 0.1], 8), 0.95),
], ids=["square", "hex", "tapers", "round8", "round16", "envelope-round", "envelope-flat",
        "bend", "bend-round", "cone-round", "tapered-bend"])
def test_closed_hollow_pipe_wall_is_the_wall_across_faces(pipe, least):
    assert thinnest(HollowPipe(pipe, WALL, ends="closed")) >= least - 1e-6


@pytest.mark.parametrize("transition, sides, least", [
    ("lcm", (6, 6), 0.9), ("merge", (6, 6), 0.9), ("lcm", (4, 8), 0.9), ("merge", (4, 8), 0.75)])
def test_hollow_chain_transition_keeps_most_of_the_wall(transition, sides, least):
    # known short of the wall: a transition that bends and tapers at once (0.92), the
    # stitches between a square and an octagon, which lean both ways (0.93), most where
    # a merge transition changes shape halfway (0.76)
    chain = HollowChain(Pipe([[0, 0, 0], [1, 0, 0]], 0.1, sides[0]),
                        Pipe([[1.3, 0, 0], [2, 0.2, 0]], 0.15, sides[1]), wall=WALL,
                        ends="closed", transition=transition)
    assert thinnest(chain) >= least


def test_hollow_chain_straight_transition_of_one_shape_keeps_the_wall():
    chain = HollowChain(Pipe([[0, 0, 0], [1, 0, 0]], 0.1, 6),
                        Pipe([[1.3, 0, 0], [2, 0, 0]], 0.1, 6), wall=WALL, ends="closed")
    assert thinnest(chain) >= 1 - 1e-6
