"""Pipes and hollow parts are immutable values: settings cannot be set, so nothing
derived from them can go stale; ``replace()`` makes a changed copy."""

import dataclasses

import numpy as np
import pytest

from cadpipe import HollowChain, HollowPipe, Junction, Pipe, splice

BENT = [[0, 0, 0], [1, 0, 0], [1, 1, 0]]


def test_pipe_settings_cannot_be_set():
    pipe = Pipe(BENT, 0.1)
    with pytest.raises(dataclasses.FrozenInstanceError):
        pipe.sides = 12
    with pytest.raises(ValueError):
        pipe.radii[0] = 1.0                       # derived arrays are read-only


def test_replace_carries_every_setting_through_trim():
    pipe = Pipe(BENT, 0.1, caps="round", envelope=True).replace(sides=12)
    assert pipe.sides == 12 and pipe.trimmed(0.1).sides == 12
    assert pipe.trimmed(0.1).caps == "round" and pipe.trimmed(0.1).envelope
    # the cached rings follow the new value, not the old one
    assert pipe.rings().shape == (3, 12, 3)
    assert dataclasses.replace(pipe, sides=5).rings().shape == (3, 5, 3)


def test_sides_from_tolerance_is_chosen_again_on_replace():
    thin = Pipe(BENT, 0.01, tolerance=1e-4)
    thick = thin.replace(radius=0.1)
    assert thick.sides > thin.sides
    assert thin.replace(sides=7, radius=0.1).sides == 7


def test_pipes_compare_by_identity_and_hash():
    a, b = Pipe(BENT, 0.1), Pipe(BENT, 0.1)
    assert a != b and len({a, b}) == 2


def test_hollow_pipe_is_a_value():
    hollow = HollowPipe(Pipe(BENT, 0.1), 0.02)
    with pytest.raises(dataclasses.FrozenInstanceError):
        hollow.wall = 0.03
    thicker = hollow.replace(wall=0.03)
    assert thicker.wall == 0.03 and thicker.ends == ("open", "open")
    assert thicker.mesh().volume > hollow.mesh().volume


def run_and_branch():
    return (HollowPipe(Pipe([[-1, 0, 0], [1, 0, 0]], 0.2, 16), 0.04),
            HollowPipe(Pipe([[0, 0, 0], [0, 1, 0]], 0.2, 16), 0.04))


def test_junction_takes_its_pipes_as_arguments_like_splice():
    run, branch = run_and_branch()
    tee = Junction(run, branch)
    assert tee.pipes == (run, branch)
    assert dataclasses.replace(tee, pipes=(run,)).pipes == (run,)
    with pytest.raises(dataclasses.FrozenInstanceError):
        tee.pipes = ()


def chain_pipes():
    return (Pipe([[0, 0, 0], [1, 0, 0]], 0.10, 12),
            Pipe([[1, 0, 0], [1.5, 0.5, 0], [2, 0.5, 0]], 0.08, 16))


def test_hollow_chain_takes_its_pipes_as_arguments_like_splice():
    pipes = chain_pipes()
    chain = HollowChain(*pipes, wall=0.02, ends="closed")
    assert (chain.pipes, chain.wall, chain.ends) == (pipes, 0.02, ("closed", "closed"))
    (outer,), _ = chain.solids()
    assert outer.volume == pytest.approx(splice(*pipes).volume, rel=1e-9)
    merged = chain.replace(transition="merge")
    assert merged.transition == "merge" and merged.pipes == chain.pipes
    assert np.isclose(merged.wall, 0.02)
