"""Hollow pipes and junctions: real walls, connected bores, no sealed voids."""

import itertools

import manifold3d
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import cadpipe
from cadpipe import HollowChain, HollowPipe, Junction, Pipe


def polygon_area(radius, sides):
    return 0.5 * sides * radius ** 2 * np.sin(2 * np.pi / sides)


def inside(mesh, point, size=1e-4):
    """Whether ``point`` lies in the solid: a tiny cube around it keeps some volume."""
    solid = mesh.to_manifold()
    probe = manifold3d.Manifold.cube((size,) * 3, True).translate(tuple(point))
    return (solid ^ probe).volume() > 0.5 * size ** 3


def shells(mesh):
    """Volumes of the solid's connected surfaces (a negative one is a sealed void)."""
    return [s.volume() for s in mesh.to_manifold().decompose()]


@settings(max_examples=20, deadline=None)
@given(st.floats(0.05, 1.0), st.floats(0.1, 0.9), st.integers(3, 48), st.floats(0.2, 3.0))
def test_open_straight_hollow_pipe_volume_is_the_wall_ring_area_times_length(
        radius, wall_fraction, sides, length):
    wall = radius * wall_fraction
    hollow = HollowPipe(Pipe([[0, 0, 0], [length, 0, 0]], radius, sides), wall)
    mesh = hollow.mesh()
    expected = (polygon_area(radius, sides) - polygon_area(radius - wall, sides)) * length
    assert mesh.is_watertight and mesh.volume == pytest.approx(expected, rel=1e-6)
    assert mesh.n_bodies == 1 and mesh.genus == 1                 # a tube: open at both ends


bent_paths = st.sampled_from([
    [[0, 0, 0], [1, 0, 0], [1, 1, 0]],
    [[0, 0, 0], [1, 0, 0.2], [1.5, 1, 0.4], [0.5, 1.6, 1]],
    [[0, 0, 0], [0.5, 0.3, 0], [1, 0, 0.3], [1.5, 0.3, 0.6]],
])


@settings(max_examples=20, deadline=None)
@given(bent_paths, st.floats(0.03, 0.12), st.floats(0.1, 0.8), st.integers(6, 32),
       st.sampled_from(["flat", "round"]))
def test_closed_hollow_pipe_volume_is_outer_minus_inner(path, radius, wall_fraction, sides, caps):
    hollow = HollowPipe(Pipe(path, radius, sides, caps=caps), radius * wall_fraction,
                        ends="closed")
    mesh = hollow.mesh()
    outer, inner = hollow.pipe.mesh(), hollow.bore.mesh()
    assert mesh.is_watertight
    assert mesh.volume == pytest.approx(outer.volume - inner.volume, rel=1e-6)
    assert sorted(np.sign(shells(mesh))) == [-1, 1]              # closed ends: one inner void


def test_closed_flat_ends_keep_a_wall_as_thick_as_the_side_wall():
    hollow = HollowPipe(Pipe([[0, 0, 0], [1, 0, 0]], 0.1, 16), 0.02, ends=("closed", "open"))
    mesh = hollow.mesh()
    assert inside(mesh, [0.01, 0, 0])               # in the end wall
    assert not inside(mesh, [0.03, 0, 0])           # in the bore, past the end wall
    assert not inside(mesh, [0.999, 0, 0])          # the open end is open


def tee(ends_of_branch=("open", "open")):
    run = HollowPipe(Pipe([[-1, 0, 0], [1, 0, 0]], 0.2, 24), 0.04)
    branch = HollowPipe(Pipe([[0, 0, 0], [0, 1, 0]], 0.2, 24), 0.04, ends=ends_of_branch)
    return Junction(run, branch)


def test_tee_bores_connect_through_the_run_wall():
    mesh = tee().mesh()
    assert mesh.is_watertight and mesh.n_bodies == 1
    # on the branch axis, inside the run's wall: the branch bore has cut through it
    assert not inside(mesh, [0, 0.18, 0])
    assert inside(mesh, [0.5, 0.18, 0])                     # the run's wall away from the tee
    assert mesh.genus == 2                                  # three openings: the channels meet


def test_tee_with_a_closed_branch_end_is_a_bent_tube():
    assert tee(("open", "closed")).mesh().genus == 1


def test_y_junction_from_round_capped_branches_meets_at_the_node():
    wall, r = 0.01, 0.05
    legs = [[[0, 0, 0], [0, 0, -0.6]], [[0, 0, 0], [-0.3, 0, 0.5]], [[0, 0, 0], [0.3, 0, 0.5]]]
    y = Junction(*(HollowPipe(Pipe(p, r, 24, caps="round"), wall, ends=("closed", "open"))
                   for p in legs))
    mesh = y.mesh()
    assert mesh.is_watertight and shells(mesh) == [pytest.approx(mesh.volume)]
    assert mesh.genus == 2
    for _, end in legs:                          # each leg's axis near the node is open
        direction = np.array(end) / np.linalg.norm(end)
        assert not inside(mesh, 0.03 * direction)


def test_lattice_of_hollow_pipes_is_one_shell_without_voids():
    spacing, radius, wall = 1.0, 0.2, 0.05
    grid = np.arange(3) * spacing
    asm = cadpipe.Assembly()
    for axis in range(3):
        for a, b in itertools.product(grid, grid):
            start, end = np.zeros(3), np.zeros(3)
            others = [k for k in range(3) if k != axis]
            start[others] = end[others] = a, b
            start[axis], end[axis] = -0.5, 2.5
            asm.add(f"pipe-{axis}-{a}-{b}", HollowPipe(Pipe([start, end], radius, 16), wall))
    solid = asm.union()
    assert solid.is_watertight and solid.is_outward
    volumes = shells(solid)
    assert len(volumes) == 1 and volumes[0] > 0       # one shell; a void would be a second one
    # every node is open inside: the point where three bores cross is not solid
    assert not any(inside(solid, node) for node in itertools.product(grid, grid, grid))


def test_unioning_hollow_tubes_directly_would_seal_voids():
    """Why assemblies cut bores after the union: the naive way plugs the bores."""
    a = HollowPipe(Pipe([[-1, 0, 0], [1, 0, 0]], 0.2, 16), 0.05)
    b = HollowPipe(Pipe([[0, -1, 0], [0, 1, 0]], 0.2, 16), 0.05)
    naive = cadpipe.Assembly().add("a", a.mesh()).add("b", b.mesh()).union()
    assert len(shells(naive)) > 1 and inside(naive, [0, 0.17, 0])
    right = cadpipe.Assembly().add("a", a).add("b", b).union()
    assert len(shells(right)) == 1 and not inside(right, [0, 0.17, 0])


def test_closed_loop_hollow_pipe_is_a_torus_shell_with_a_void():
    angles = np.linspace(0, 2 * np.pi, 48, endpoint=False)
    loop = cadpipe.Path(np.c_[np.cos(angles), np.sin(angles), np.zeros_like(angles)], closed=True)
    hollow = HollowPipe(Pipe(loop, 0.1, 12), 0.02)
    mesh = hollow.mesh()
    assert mesh.volume == pytest.approx(hollow.pipe.mesh().volume - hollow.bore.mesh().volume,
                                        rel=1e-6)
    assert sorted(np.sign(shells(mesh))) == [-1, 1]


def chain_pipes():
    return [Pipe([[0, 0, 0], [1, 0, 0]], 0.10, 12),
            Pipe([[1, 0, 0], [1.5, 0.5, 0], [2, 0.5, 0]], 0.08, 16)]


@pytest.mark.parametrize("transition", ["lcm", "merge"])
def test_hollow_chain_bore_lies_inside_the_spliced_outer(transition):
    chain = HollowChain(*chain_pipes(), wall=0.02, ends="closed", transition=transition)
    mesh = chain.mesh()
    (outer,), (inner,) = chain.solids()
    # outer - bore has exactly their volume difference only if the bore is inside
    assert mesh.is_watertight and mesh.volume == pytest.approx(outer.volume - inner.volume,
                                                               rel=1e-6)
    assert sorted(np.sign(shells(mesh))) == [-1, 1]


def test_open_hollow_chain_is_one_tube_through_its_transitions():
    mesh = HollowChain(*chain_pipes(), wall=0.02).mesh()
    assert mesh.is_watertight and mesh.n_bodies == 1 and mesh.genus == 1
    assert not inside(mesh, [1.0, 0, 0])         # the axis where the transition begins


def test_closed_hollow_chain_is_a_ring_shell_around_a_ring_void():
    def arc(a0, a1):
        t = np.radians(np.linspace(a0, a1, 20))
        return np.c_[np.cos(t), np.sin(t), np.zeros_like(t)]

    chain = HollowChain(Pipe(arc(0, 160), 0.1, 12), Pipe(arc(180, 340), 0.1, 16), wall=0.02,
                        closed=True)
    mesh = chain.mesh()
    (outer,), (inner,) = chain.solids()
    assert mesh.volume == pytest.approx(outer.volume - inner.volume, rel=1e-6)
    assert sorted(np.sign(shells(mesh))) == [-1, 1]


@pytest.mark.parametrize("wall, ends, match", [
    (0.1, "open", "wall: 0.1 must be less than"), (-0.01, "open", "wall: must be finite and > 0"),
    (0.01, "half", "ends: expected one of"), (0.01, ["open"], "ends: expected 'open', 'closed'")])
def test_bad_wall_or_ends_raise_input_errors(wall, ends, match):
    with pytest.raises(cadpipe.InputError, match=match):
        HollowPipe(Pipe([[0, 0, 0], [1, 0, 0]], 0.1), wall, ends)
