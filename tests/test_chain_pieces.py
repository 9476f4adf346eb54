"""Spliced chains are checked piece against piece (issue 10): pipes that overlap or
cross, and pipes that meet at a corner, give one valid solid, never crossing faces.
Every result goes through the independent checks of :mod:`oracle`."""

import numpy as np
import pytest

import cadpipe
from cadpipe import HollowChain, HollowPipe, InputError, Junction, Pipe, splice
from oracle import solid_problems


def line(a, b, radius=1.0, sides=8, **kw):
    return Pipe([a, b], radius, sides=sides, **kw)


def covers(mesh, points, radius):
    """Whether every ball of ``radius`` about ``points`` lies inside ``mesh`` (sampled:
    points on each sphere against trimesh's winding-number containment)."""
    rng = np.random.default_rng(3)
    u = rng.normal(size=(200, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    probes = (np.asarray(points)[:, None, :] + 0.999 * radius * u).reshape(-1, 3)
    return bool(mesh.to_trimesh().contains(probes).all())


@pytest.mark.parametrize("second", [
    [[9.8, 0, 0], [20, 0, 0]],           # starts 0.2 before the first one ends
    [[8.0, 0, 0], [20, 0, 0]],           # starts 2 before: a transition would run back
    [[9.8, 0.8, 0], [20, 0.8, 0]],       # beside the first one's end
    [[9.8, 0, 0], [9.8, 10, 0]],         # across it
])
def test_overlapping_second_pipe_gives_one_valid_solid(second):
    first = line([0, 0, 0], [10, 0, 0])
    mesh = splice(first, line(*second, sides=6))
    assert solid_problems(mesh) == []
    # both pipes' axes stay inside the result (octagon and hexagon inradii > 0.85)
    start, end = np.asarray(second, float)
    along = (end - start) / np.linalg.norm(end - start)
    assert covers(mesh, np.linspace([1, 0, 0], [9, 0, 0], 5), 0.85)
    assert covers(mesh, np.linspace(start + along, end - along, 5), 0.85)


@pytest.mark.parametrize("transition", ["lcm", "merge"])
def test_third_pipe_crossing_the_first_is_united_and_reported(transition):
    a, b = line([0, 0, 0], [10, 0, 0]), line([12, 0, 0], [20, 0, 0], sides=6)
    c = Pipe([[22, 0, 0], [25, 0, 0], [25, 10, 0], [5, 10, 0], [5, -10, 0]], 0.8, sides=5)
    mesh = splice(a, b, c, transition=transition)
    assert solid_problems(mesh) == []
    assert "pipe0 and pipe2 (they cross)" in mesh.attributes["merged"]
    assert {"pipe0", "pipe1", "pipe2", "transition0", "transition1"} <= set(mesh.part_names)
    assert covers(mesh, [[5, 0, 0], [5, -5, 0], [5, 5, 0], [2, 0, 0]], 0.6)


CROSSING = np.array([[0, 0, 0], [2, 0, 0], [2, 2, 0], [1, 2, 0], [1, -1, 0.1]])


@pytest.mark.parametrize("options", [{}, {"envelope": True}, {"caps": "round"},
                                     {"corners": "round"}])
@pytest.mark.parametrize("transition", ["lcm", "merge"])
def test_a_pipe_that_overlaps_itself_in_a_splice_is_its_swept_solid(options, transition):
    """'splice: pipe 0 intersects itself' was raised where a lone Pipe builds its swept
    solid; in a chain the pipe is that same solid, cut flat where a transition goes on."""
    first = Pipe(CROSSING, 0.2, **options)
    mesh = splice(first, Pipe([[1, -3, 0.1], [1, -5, 0.1]], 0.2, 6, **options),
                  transition=transition)
    assert solid_problems(mesh) == []
    assert "pipe0 (its swept solid" in mesh.attributes["merged"]
    assert {"pipe0", "pipe1", "transition0"} <= set(mesh.part_names)
    inradius = 0.2 * np.cos(np.pi / 16)
    axis = np.concatenate([np.linspace(a, b, 6)[1:-1] for a, b in zip(CROSSING[:-1],
                                                                       CROSSING[1:])])
    assert covers(mesh, axis, 0.95 * inradius)
    assert covers(mesh, [[1, -4, 0.1]], 0.95 * 0.2 * np.cos(np.pi / 6))


def test_a_strict_pipe_that_overlaps_itself_in_a_splice_is_refused_at_its_index():
    with pytest.raises(cadpipe.GeometryError, match="pipe 1 intersects itself") as caught:
        splice(line([1, -5, 0.1], [1, -3, 0.1], 0.2, 6), Pipe(CROSSING, 0.2, strict=True))
    assert (caught.value.key, caught.value.index, caught.value.fix) == (
        "pipes", 1, {"strict": False})


def test_a_hollow_chain_with_a_pipe_that_overlaps_itself_is_one_valid_shell():
    mesh = HollowChain(Pipe(CROSSING, 0.2), Pipe([[1, -3, 0.1], [1, -5, 0.1]], 0.2, 6),
                       wall=0.05).mesh()
    assert solid_problems(mesh) == []
    assert not mesh.to_trimesh().contains([[1.5, 0, 0], [1, -4, 0.1]]).any()   # open bore


def test_a_pipe_coincident_with_another_in_a_chain_is_covered_once():
    """Coaxial coincident pieces: a pipe lying on an earlier one (same line, same
    radius) is their union, covered once (a doubled shell has winding number 2, which
    the triangle oracle cannot see)."""
    from test_envelope import winding

    a = line([0, 0, 0], [10, 0, 0])
    detour = Pipe([[12, 0, 0], [14, 0, 0], [14, 5, 0], [-5, 5, 0], [-5, 0, 0]], 1.0, 8)
    for again in (line([0, 0, 0], [10, 0, 0]), line([-2, 0, 0], [4, 0, 0], 0.5, 6)):
        mesh = splice(a, detour, again)
        assert solid_problems(mesh) == []
        assert np.allclose(winding(mesh, np.array([[1, 0, 0], [3, 0.2, 0.1], [8, 0, 0]])), 1)


def test_clean_chain_is_stitched_as_it_is():
    a, b = line([0, 0, 0], [10, 0, 0]), line([12, 0, 0], [20, 3, 0], sides=6)
    mesh = splice(a, b)
    assert "merged" not in mesh.attributes
    assert mesh.part_names == ("pipe0", "pipe1", "transition0")


@pytest.mark.parametrize("radius", [0.05, 0.3, 1.0, 3.0])
@pytest.mark.parametrize("sides", [(8, 8), (5, 7), (4, 12)])
def test_polyline_split_at_a_right_angle_is_joined_at_any_radius(radius, sides):
    first = line([0, 0, 0], [10, 0, 0], radius, sides[0])
    second = line([10, 0, 0], [10, 10, 0], radius, sides[1])
    mesh = splice(first, second)
    assert solid_problems(mesh) == []
    assert "joint0" in mesh.part_names
    # the corner point is covered by the full radius (a ball joint), the legs by their
    # inradius
    assert covers(mesh, [[10, 0, 0]], radius)
    inradius = radius * np.cos(np.pi / min(sides))
    assert covers(mesh, [[10 - 2 * radius, 0, 0], [10, 2 * radius, 0]], inradius)


def test_closed_chain_of_corners_is_a_ring():
    square = np.array([[0, 0, 0], [10, 0, 0], [10, 10, 0], [0, 10, 0]])
    mesh = splice(*[line(square[i], square[(i + 1) % 4], sides=n)
                    for i, n in enumerate([4, 5, 6, 7])], closed=True)
    assert solid_problems(mesh) == []
    assert mesh.genus == 1
    assert covers(mesh, square, 1.0)
    assert covers(mesh, (square + np.roll(square, -1, axis=0)) / 2, np.cos(np.pi / 4))


def test_envelope_chain_at_a_corner_holds_every_ball():
    first = line([0, 0, 0], [10, 0, 0], 1.0, 6, envelope=True)
    second = line([10, 0, 0], [10, 0, 10], 1.0, 6, envelope=True)
    mesh = splice(first, second)
    assert solid_problems(mesh) == []
    axis = np.concatenate([np.linspace([0, 0, 0], [10, 0, 0], 21),
                           np.linspace([10, 0, 0], [10, 0, 10], 21)])
    assert covers(mesh, axis, 1.0)


def test_hollow_chain_with_a_crossing_and_a_corner_is_one_valid_shell():
    a, b = line([0, 0, 0], [10, 0, 0], 1.0, 8), line([10, 0, 0], [10, 10, 0], 1.0, 8)
    c = Pipe([[12, 12, 0], [5, 12, 0], [5, -5, 0]], 1.0, sides=8)
    mesh = HollowChain(a, b, c, wall=0.2).mesh()
    assert solid_problems(mesh) == []
    # the bore stays open along the first pipe: its axis is not inside the solid
    assert not mesh.to_trimesh().contains([[2, 0, 0], [10, 5, 0]]).any()


def test_junction_with_a_crossing_third_pipe_is_one_valid_shell():
    pipes = [HollowPipe(line(*ab, 1.0, 8), 0.2) for ab in
             ([[0, 0, 0], [10, 0, 0]], [[10, 0, 0], [10, 10, 0]], [[5, -5, 0], [5, 12, 0]])]
    mesh = Junction(*pipes).mesh()
    assert solid_problems(mesh) == []


@pytest.mark.parametrize("call, key", [
    (lambda p: splice(p, p, closed="zz"), "closed"),
    (lambda p: splice(p, p, closed=None), "closed"),
    (lambda p: splice(p, p, transition=3), "transition"),
    (lambda p: splice(p, "p"), "pipes"),
    (lambda p: splice(), "pipes"),
    (lambda p: HollowChain(p, p, wall=0.1, closed="yes"), "closed"),
    (lambda p: HollowChain(p, p, wall="thin"), "wall"),
    (lambda p: HollowChain(p, p, wall=0.1, transition="gcd"), "transition"),
    (lambda p: HollowChain(p, p, wall=0.1, ends=3), "ends"),
    (lambda p: HollowChain(p, 2, wall=0.1), "pipes"),
    (lambda p: Junction(HollowPipe(p, 0.1), p), "pipes"),
    (lambda p: Junction(), "pipes"),
    (lambda p: HollowPipe(p, 0.1, ends=("open",)), "ends"),
    (lambda p: HollowPipe(p, [0.1, 0.2]), "wall"),
])
def test_bad_chain_arguments_name_their_key(call, key):
    with pytest.raises(InputError) as caught:
        call(line([0, 0, 0], [1, 0, 0], 0.2, 6))
    assert caught.value.key == key


def test_bad_pipe_argument_names_its_index():
    with pytest.raises(InputError) as caught:
        splice(line([0, 0, 0], [1, 0, 0]), cadpipe.Path([[0, 0, 0], [1, 0, 0]]))
    assert (caught.value.key, caught.value.index) == ("pipes", 1)


def along(pipe, count=30):
    """(count, 3) points and (count,) radii along ``pipe``'s path."""
    s = np.linspace(0, pipe.path.length, count)
    points = np.array([np.interp(s, pipe.path.arc_length, pipe.path.points[:, k])
                       for k in range(3)]).T
    return points, np.interp(s, pipe.path.arc_length, pipe.radii)


@pytest.mark.parametrize("pipes", [
    [line([0, 0, 0], [5, 0, 0], 1, 8, envelope=True),
     line([7, 0, 0], [12, 0, 0], 1, 6, envelope=True)],                      # a transition
    [line([0, 0, 0], [5, 0, 0], 1, 8, envelope=True),
     line([8, 1, 0], [10, 5, 0], 1, 6, envelope=True)],                      # a bent one
    [line([0, 0, 0], [5, 0, 0], 1, 8, envelope=True),
     line([5, 0, 0], [10, 1.8, 0], 1, 8, envelope=True)],                    # touching, 20 deg
    [line([0, 0, 0], [5, 0, 0], 1, 8, envelope=True),
     line([5, 0, 0], [10, 0, 0], 1.5, 12, envelope=True)],                   # touching, wider
    [line([0, 0, 0], [5, 0, 0], 1, 8, envelope=True),
     line([5, 0, 0], [5, 5, 0], 1, 8, envelope=True)],                       # a corner
    [Pipe([[0, 0, 0], [5, 0, 0]], [1, 0.5], 8, envelope=True, caps="round"),
     Pipe([[7, 0, 0], [12, 2, 0]], [0.5, 1.2], 6, envelope=True, caps="round")],  # tapers, caps
    [Pipe([[0, 0, 0], [5, 0, 0]], 1, 5, envelope=True),
     Pipe([[5, 0, 0], [5, 5, 0], [5, 5, 5]], 1, 7, envelope=True, corners="round")],
], ids=["gap", "bent-gap", "touch-20", "touch-wider", "corner", "tapers-caps", "round-joints"])
def test_envelope_chain_holds_every_ball_on_its_pipes_paths(pipes):
    mesh = splice(*pipes)
    assert solid_problems(mesh, round_trip=False) == []
    for pipe in pipes:
        points, radii = along(pipe)
        for point, radius in zip(points, radii):
            assert covers(mesh, [point], radius), (point, radius)
