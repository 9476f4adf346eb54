"""Property tests of spliced chains (issue 10): chains of 2-5 pipes along random paths,
of different sides and variable radius, touching at corners, overlapping, crossing
each other, open or closed, through lcm and merge transitions, hollow or not. Every
result must pass :func:`oracle.solid_problems` (the triangle oracle, manifold3d,
trimesh, STL and 3MF round trips); invalid arguments must raise cadpipe errors naming
their key."""


import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, note, settings
from hypothesis import strategies as st

import cadpipe
from cadpipe import CadpipeError, HollowChain, HollowPipe, Junction, Pipe, splice
from oracle import solid_problems
from rates import assert_builds_mostly

#: share of valid chains that must build (the rest: a pipe that cuts itself)
SETTINGS = settings(deadline=None, suppress_health_check=list(HealthCheck), derandomize=True)


def unit(v):
    return v / np.linalg.norm(v)


def turned(direction, angle, spin):
    """``direction`` turned by ``angle`` about an axis across it chosen by ``spin``."""
    helper = np.eye(3)[int(np.argmin(np.abs(direction)))]
    u = unit(np.cross(direction, helper))
    w = np.cross(direction, u)
    axis = np.cos(spin) * u + np.sin(spin) * w
    return (np.cos(angle) * direction + np.sin(angle) * np.cross(axis, direction))


angles = st.floats(0.0, np.pi / 3)
spins = st.floats(0.0, 2 * np.pi)


@st.composite
def chains(draw):
    """``(pipes, options)``: a valid chain for :func:`cadpipe.splice`."""
    count = draw(st.integers(2, 5))
    r = draw(st.floats(0.05, 1.0))
    direction = unit(np.array(draw(st.lists(st.floats(-1, 1), min_size=3, max_size=3)))
                     + [1e-3, 0, 0])
    start = np.zeros(3)
    pipes, joins = [], []
    for _ in range(count):
        points = [start]
        for _ in range(draw(st.integers(1, 4))):
            direction = unit(turned(direction, draw(angles), draw(spins)))
            points.append(points[-1] + draw(st.floats(3.0, 8.0)) * r * direction)
        if draw(st.booleans()):
            radius = r * np.array([draw(st.floats(0.7, 1.3)) for _ in points])
        else:
            radius = r * draw(st.floats(0.7, 1.3))
        pipes.append(Pipe(np.array(points), radius, sides=draw(st.integers(3, 12)),
                          caps=draw(st.sampled_from(["flat", "round"])),
                          envelope=draw(st.sampled_from([False, False, True]))))
        if draw(st.integers(0, 5)) == 0:           # a coil whose turns overlap
            t = np.linspace(0, 2 * np.pi * 1.5, 40)
            coil = np.c_[np.cos(t), np.sin(t), 0.3 * t / (2 * np.pi)] * 3 * r
            coil = points[-1] + coil - coil[0]
            pipes[-1] = pipes[-1].replace(path=np.vstack([points, coil[1:]]),
                                          radius=float(np.min(radius)), sides=pipes[-1].sides)
            points = list(pipes[-1].path.points)
        join = draw(st.sampled_from(["gap", "gap", "corner", "overlap", "cross"]))
        joins.append(join)
        end = points[-1]
        if join == "gap":
            direction = unit(turned(direction, draw(angles), draw(spins)))
            start = end + draw(st.floats(2.0, 6.0)) * r * direction
        elif join == "corner":                     # a polyline split at a corner
            direction = unit(turned(direction, draw(st.floats(np.pi / 6, 0.9 * np.pi)),
                                    draw(spins)))
            start = end
        elif join == "overlap":                    # starts before the previous one ends
            start = end - draw(st.floats(0.1, 2.0)) * r * direction
        else:                                      # heads back across the first pipe
            first = pipes[0].path.points
            target = (first[0] + first[1]) / 2
            start = end + 2.5 * r * direction
            direction = unit(target - start) if np.linalg.norm(target - start) > r else direction
    for join in joins[:-1]:
        event(f"join: {join}")
    closed = draw(st.sampled_from([False, False, False, True]))
    transition = draw(st.sampled_from(["lcm", "merge"]))
    return pipes, {"closed": closed, "transition": transition}


def attempt(outcomes, make):
    """Build a valid chain: nothing is refused (a pipe that overlaps itself is its swept
    solid, pieces that cross are united)."""
    mesh = make()
    event("built" + (" (united)" if "merged" in mesh.attributes else " (stitched)"))
    outcomes["built"] += 1
    return mesh


def check_random_chains(examples, round_trip):
    @given(chains())
    def run(outcomes, chain):
        pipes, options = chain
        note(repr([p.path.points.tolist() for p in pipes]))
        mesh = attempt(outcomes, lambda: splice(*pipes, **options))
        if mesh is not None:
            assert solid_problems(mesh, round_trip=round_trip) == []
            # every pipe's axis lies inside (a pipe may be wholly inside a joint)
            axes = np.concatenate([(p.path.points[1:] + p.path.points[:-1]) / 2
                                   for p in pipes])
            assert mesh.to_trimesh().contains(axes).all()

    assert_builds_mostly(run, examples, "chains", SETTINGS)


@pytest.mark.slow
def test_random_chains_are_valid_solids():
    check_random_chains(60, round_trip=True)


def test_random_chains_are_valid_solids_quick():
    check_random_chains(15, round_trip=False)


@pytest.mark.slow
def test_random_hollow_chains_are_valid_shells():
    @given(chains(), st.floats(0.05, 0.3))
    def run(outcomes, chain, fraction):
        pipes, options = chain
        wall = fraction * min(float(p.ring_radii.min()) for p in pipes) * np.cos(np.pi / 3)
        note(repr([p.path.points.tolist() for p in pipes]))
        mesh = attempt(outcomes, lambda: HollowChain(*pipes, wall=wall, **options).mesh())
        if mesh is not None:
            assert solid_problems(mesh) == []

    assert_builds_mostly(run, 25, "chains", SETTINGS)


# -- invalid arguments ---------------------------------------------------------------
not_flags = st.sampled_from(["zz", "true", None, 1, 0, [], 2.5, "False"])
not_transitions = st.sampled_from(["gcd", 3, None, ["lcm"], "LCM", ""])
not_pipes = st.sampled_from(["pipe", None, 1.0, np.zeros((2, 3)), [[0, 0, 0], [1, 0, 0]],
                             cadpipe.Path([[0, 0, 0], [1, 0, 0]])])
not_walls = st.sampled_from([0, -1, "x", float("nan"), float("inf"), 1e3, [0.1, 0.2], None])
not_ends = st.sampled_from(["x", 3, ("open",), ("open", "open", "open"), None, ("open", 1)])


def good_pipe():
    return Pipe([[0, 0, 0], [1, 0, 0], [1, 1, 0]], 0.2, sides=6)


@st.composite
def bad_calls(draw):
    """``(call, key)``: a splice, HollowChain or Junction call with one bad argument."""
    p = good_pipe()
    kind = draw(st.sampled_from(["closed", "transition", "pipes", "wall", "ends", "junction",
                                 "loop"]))
    if kind == "closed":
        bad = draw(not_flags)
        return draw(st.sampled_from([lambda: splice(p, p, closed=bad),
                                     lambda: HollowChain(p, p, wall=0.05, closed=bad)])), kind
    if kind == "transition":
        bad = draw(not_transitions)
        return draw(st.sampled_from([lambda: splice(p, p, transition=bad),
                                     lambda: HollowChain(p, p, wall=0.05, transition=bad)])), kind
    if kind == "pipes":
        bad = draw(not_pipes)
        return draw(st.sampled_from([lambda: splice(p, bad), lambda: splice(bad),
                                     lambda: HollowChain(p, bad, wall=0.05)])), kind
    if kind == "loop":
        loop = Pipe(cadpipe.Path([[0, 0, 0], [1, 0, 0], [0, 1, 0]], closed=True), 0.05)
        return draw(st.sampled_from([lambda: splice(p, loop),
                                     lambda: HollowChain(loop, p, wall=0.01)])), "pipes"
    if kind == "wall":
        bad = draw(not_walls)
        return draw(st.sampled_from([lambda: HollowChain(p, p, wall=bad),
                                     lambda: HollowPipe(p, bad)])), kind
    if kind == "ends":
        bad = draw(not_ends)
        return draw(st.sampled_from([lambda: HollowChain(p, p, wall=0.05, ends=bad),
                                     lambda: HollowPipe(p, 0.05, ends=bad)])), kind
    bad = draw(not_pipes)
    return (lambda: Junction(HollowPipe(p, 0.05), bad)), "pipes"


@SETTINGS
@given(bad_calls())
def test_invalid_chain_arguments_raise_cadpipe_errors_naming_the_key(case):
    call, key = case
    with pytest.raises(CadpipeError) as caught:
        call()
    event(f"refused: {key}")
    assert caught.value.key == key, caught.value
