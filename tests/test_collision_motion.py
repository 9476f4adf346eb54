"""Motion checks between configurations, against dense sampling of the motion."""

from pathlib import Path as FilePath

import numpy as np
import pytest

from cadpipe import CollisionWorld, InputError, Path, Pipe
from cadpipe.collision import Box, Robot
from cadpipe.collision.motion import proof_states, speed_bounds

PANDA = FilePath(__file__).parent.parent / "assets" / "robots" / "panda"
DENSE = 2001


def _shift(x, y, z):
    m = np.eye(4)
    m[:3, 3] = x, y, z
    return m


@pytest.fixture(scope="module")
def panda():
    return Robot.from_urdf(PANDA / "panda.urdf", srdf=PANDA / "panda.srdf")


@pytest.fixture(scope="module")
def cell(panda):
    world = CollisionWorld()
    world.add_robot(panda)
    world.add("wall", Box((0.02, 1.2, 1.2)), transform=_shift(0.55, 0.0, 0.5))
    duct = Pipe(Path([[-0.6, -0.6, 0.3], [-0.2, -0.5, 0.6], [0.3, -0.6, 0.4]]), radius=0.05)
    world.add("duct", duct)
    return world


def _free_pairs(world, robot, count, rng):
    """``count`` motions between random configurations free at both ends."""
    lo, hi = robot.limits
    found = []
    while len(found) < count:
        q = rng.uniform(lo, hi, (2, len(lo)))
        if not world.check_path(robot.name, q).colliding.any():
            found.append(q)
    return found


def _dense_first_hit(world, robot, q_a, q_b):
    t = np.linspace(0.0, 1.0, DENSE)
    hits = world.check_path(robot.name, q_a + t[:, None] * (q_b - q_a)).colliding
    return t[np.argmax(hits)] if hits.any() else None


@pytest.mark.slow
def test_free_motions_are_free_at_every_dense_state_and_contacts_are_found(panda, cell):
    rng = np.random.default_rng(5)
    outcomes = {"free": 0, "colliding": 0}
    for q_a, q_b in _free_pairs(cell, panda, 9, rng):
        result = cell.check_motion(panda.name, q_a, q_b)
        first = _dense_first_hit(cell, panda, q_a, q_b)
        if result.free:
            assert first is None, "a motion certified free collides in between"
            outcomes["free"] += 1
            continue
        outcomes["colliding"] += 1
        assert result.segment == 0 and 0.0 <= result.time <= 1.0
        assert result.clearance < result.tolerance
        # everything before the contact time is proven free: the dense first hit is later
        if first is not None:
            assert result.time <= first + 1e-12
            assert first - result.time < 5.0 / DENSE
        np.testing.assert_allclose(result.configuration, q_a + result.time * (q_b - q_a))
        poses = panda.link_poses(result.configuration)
        a, b = result.pair
        gap = cell.distance_at(a, b, poses[a], poses.get(b, cell.pose(b)))
        assert gap < result.tolerance
    assert outcomes["free"] >= 3 and outcomes["colliding"] >= 3, outcomes


def test_a_hand_passing_a_thin_wall_between_free_waypoints_is_caught(panda):
    world = CollisionWorld()
    world.add_robot(panda)
    world.add("sheet", Box((0.004, 0.6, 0.3)), transform=_shift(0.6, 0.0, 0.1))
    q_a = np.array([0, 0.0, 0, -2.2, 0, 2.2, 0.78, 0.02])
    q_b = q_a.copy()
    q_b[1], q_b[3] = 0.7, -1.6             # the hand reaches forward over the sheet's top
    path = q_a + np.linspace(0, 1, 3)[:, None] * (q_b - q_a)
    waypoints = world.check_path(panda.name, path[[0, -1]])
    assert not waypoints.colliding.any()          # both ends are free...
    first = _dense_first_hit(world, panda, q_a, q_b)
    assert first is not None                      # ...but the motion crosses the sheet
    result = world.check_path(panda.name, path, between=True)
    assert not result.free and result.pair[1] == "sheet"
    at = result.segment * 0.5 + result.time * 0.5
    assert at <= first + 1e-12 and first - at < 5.0 / DENSE


def test_the_motion_bounds_cover_every_vertex_of_every_link(panda):
    """Dense forward kinematics of each link's vertices never moves a vertex along
    a longer path than the bounds allow -- ``D s`` and ``S s + A s^2 / 2`` from a
    time ``t`` to ``t + s`` -- on random long and short segments; and the bounds
    are useful ones (a few times the longest path at most, typically)."""
    rng = np.random.default_rng(8)
    lo, hi = panda.limits
    ratios = []
    for k in range(24):
        q_a, q_b = rng.uniform(lo, hi, (2, len(lo)))
        if k % 2:                      # short segments too, where the lever at t decides
            q_b = q_a + 0.05 * (q_b - q_a)
        start = [0.0, 0.3, 0.9][k % 3]
        bounds = speed_bounds(panda, q_a, q_b, start)
        t = np.linspace(start, 1.0, 401)
        poses = panda.link_pose_array(q_a + t[:, None] * (q_b - q_a))
        s = t - start
        for link, (name, mesh) in enumerate(panda.link_meshes.items()):
            moved = mesh.vertices @ np.swapaxes(poses[:, link, :3, :3], 1, 2) \
                + poses[:, link, None, :3, 3]
            # each vertex's path length from the start to each later time
            length = np.concatenate([np.zeros((1, len(mesh.vertices))), np.cumsum(
                np.linalg.norm(np.diff(moved, axis=0), axis=2), axis=0)]).max(axis=1)
            speed, fastest, growth = bounds[link]
            bound = np.minimum(speed * s, fastest * s + 0.5 * growth * s ** 2)
            assert np.all(length <= bound * (1 + 1e-9) + 1e-12), name
            if length[-1] > 0:
                ratios.append(bound[-1] / length[-1])
    assert np.median(ratios) < 2.5, np.median(ratios)


def test_self_collision_along_a_motion_and_static_start(panda):
    folded = np.array([-1.726, 1.544, -2.348, -3.057, -1.026, 3.718, -1.363, 0.033])
    world = CollisionWorld()
    world.add_robot(panda)
    assert world.check_path(panda.name, folded[None]).colliding[0]
    start = panda.default
    result = world.check_motion(panda.name, start, folded)
    assert not result.free and result.time < 1.0
    first = _dense_first_hit(world, panda, start, folded)
    assert result.time <= first + 1e-12 and first - result.time < 5.0 / DENSE
    # a start in contact is a contact at time 0
    at_start = world.check_motion(panda.name, folded, start)
    assert at_start.time == 0.0 and not at_start.free
    # standing still where it is free is free, without a single distance query
    still = world.check_motion(panda.name, start, start)
    assert still.free and bool(still) is False


def test_multi_segment_paths_report_the_segment_and_stop_there(panda, cell):
    rng = np.random.default_rng(21)
    motions = _free_pairs(cell, panda, 12, rng)
    first_bad = next(k for k, (a, b) in enumerate(motions)
                     if not cell.check_motion(panda.name, a, b).free)
    path = np.concatenate([motions[k] for k in range(first_bad + 1)])
    result = cell.check_path(panda.name, path, between=True)
    assert not result.free
    # segment 2k runs through motion k; the joins between motions may collide first
    for segment in range(result.segment):
        assert cell.check_motion(panda.name, path[segment], path[segment + 1]).free
    assert result.segment <= 2 * first_bad


def test_bad_motion_input(panda, cell):
    with pytest.raises(InputError, match="at least two"):
        cell.check_path(panda.name, [panda.default], between=True)
    with pytest.raises(InputError, match="tolerance"):
        cell.check_motion(panda.name, panda.default, panda.default, tolerance=0)
    with pytest.raises(InputError, match="outside its limits"):
        cell.check_motion(panda.name, panda.default, panda.default + 10)
    for margin in (-1e-3, float("nan"), float("inf")):
        with pytest.raises(InputError, match="margin") as caught:
            cell.check_motion(panda.name, panda.default, panda.default, margin=margin)
        assert caught.value.key == "margin"


def _slider(tmp_path):
    """A robot whose one link, a 0.1 m cube, slides along x (prismatic, [-1, 1])."""
    urdf = tmp_path / "slider.urdf"
    urdf.write_text("""<robot name='slider'><link name='base'/>
      <link name='cube'><collision><geometry><box size='0.1 0.1 0.1'/></geometry></collision>
      </link>
      <joint name='x' type='prismatic'><parent link='base'/><child link='cube'/>
        <axis xyz='1 0 0'/><limit lower='-1' upper='1' effort='1' velocity='1'/></joint>
    </robot>""")
    return Robot.from_urdf(urdf)


def test_a_sliding_cube_meets_a_wall_at_the_analytic_time(tmp_path):
    """Head on: the cube's face is 0.45 from the wall at q = 0 and moves 0.8 over the
    motion, so it touches at t = 0.5625 and is within the tolerance after
    (0.45 - tol) / 0.8; boxes are their own hulls, so no exact query is needed."""
    robot = _slider(tmp_path)
    world = CollisionWorld()
    world.add_robot(robot)
    world.add("wall", Box((0.02, 1.0, 1.0)), transform=_shift(0.51, 0.0, 0.0))
    result = world.check_motion(robot.name, [0.0], [0.8])
    tolerance = result.tolerance
    assert not result.free and result.pair == ("cube", "wall")
    assert (0.45 - tolerance) / 0.8 < result.time <= 0.45 / 0.8
    assert result.clearance < tolerance and result.distance_calls == 0
    assert result.states == len(proof_states(world, robot.name, [[0.0], [0.8]]))


@pytest.mark.parametrize("gap, margin, free, at_start", [
    (3e-4, 0.0, True, None),          # grazing at 3 tolerances all along: proven free
    (5e-5, 0.0, False, True),         # within the tolerance from the start
    (3e-3, 1e-3, True, None),         # keeps the margin
    (1.5e-3, 1e-3, False, True),      # keeps the margin, but not twice it: refused
    (5e-4, 1e-3, False, True),        # inside the margin
])
def test_sliding_past_a_wall_grazes_keeps_or_breaks_a_margin(tmp_path, gap, margin, free,
                                                              at_start):
    robot = _slider(tmp_path)
    world = CollisionWorld()
    world.add_robot(robot)
    world.add("wall", Box((3.0, 0.02, 1.0)), transform=_shift(0.0, 0.06 + gap, 0.0))
    result = world.check_motion(robot.name, [-0.9], [0.9], margin=margin)
    assert result.free == free and result.margin == margin
    if not free:
        assert result.time == 0.0 and result.pair == ("cube", "wall")
        assert result.clearance <= gap + 1e-9     # the clearance (and rounding), or a bound
        assert result.clearance < (2 * margin if margin else result.tolerance)


@pytest.fixture(scope="module")
def walled(panda):
    world = CollisionWorld()
    world.add_robot(panda)
    world.add("wall", Box((0.02, 1.2, 1.2)), transform=_shift(0.5, 0.0, 0.5))
    return world


@pytest.mark.slow
def test_a_margin_motion_keeps_its_margin_at_every_dense_state(panda, walled):
    """Against python-fcl's distances on the meshes: a motion called free with a
    margin keeps it at every one of 201 states; a refused one reports a lower
    bound of its pair's clearance there."""
    import fcl

    from oracle import fcl_bvh

    margin = 0.01
    shapes = {name: fcl.CollisionObject(fcl_bvh(walled.body(name).mesh), fcl.Transform())
              for name in walled.names}
    shapes["wall"].setTransform(fcl.Transform(walled.pose("wall")[:3, 3]))
    allowed = {frozenset((a, b)) for a, b, _ in walled.allowed}
    pairs = [(a, b) for k, a in enumerate(walled.names) for b in walled.names[k + 1:]
             if frozenset((a, b)) not in allowed]

    def clearance(q, only=None):
        for link, pose in zip(panda.link_meshes, panda.link_pose_array(q)[0]):
            shapes[link].setTransform(fcl.Transform(pose[:3, :3], pose[:3, 3]))
        request = fcl.DistanceRequest()
        return min(fcl.distance(shapes[a], shapes[b], request, fcl.DistanceResult())
                   for a, b in (pairs if only is None else [only]))

    outcomes = {"free": 0, "refused": 0}
    for q_a, q_b in _free_pairs(walled, panda, 8, np.random.default_rng(3)):
        q_b = q_a + 0.3 * (q_b - q_a)
        result = walled.check_motion(panda.name, q_a, q_b, margin=margin)
        if result.free:
            outcomes["free"] += 1
            t = np.linspace(0.0, 1.0, 201)
            assert min(clearance((q_a + s * (q_b - q_a))[None]) for s in t) >= margin
        else:
            outcomes["refused"] += 1
            assert result.clearance < 2 * margin
            assert clearance(result.configuration[None], result.pair) >= result.clearance
    assert outcomes["free"] >= 2 and outcomes["refused"] >= 1, outcomes


def test_the_proof_states_lie_on_the_motion_in_time_order(panda, cell):
    q_a, q_b = _free_pairs(cell, panda, 1, np.random.default_rng(4))[0]
    result = cell.check_motion(panda.name, q_a, q_b)
    states = proof_states(cell, panda.name, np.stack([q_a, q_b]))
    assert len(states) == result.states >= 1
    t = (states - q_a) @ (q_b - q_a) / ((q_b - q_a) @ (q_b - q_a))
    np.testing.assert_allclose(states, q_a + t[:, None] * (q_b - q_a), atol=1e-12)
    assert t[0] == 0.0 and np.all(np.diff(t) > 0) and t[-1] < 1.0


@pytest.fixture(scope="module", params=[
    ("talos_data/robots/talos_reduced.urdf", "talos_data/srdf/talos.srdf"),
    ("pr2_description/urdf/pr2.urdf", "pr2_description/srdf/pr2.srdf")])
def stock(request):
    """A humanoid and a two-armed mobile manipulator (branching trees, mimic joints,
    a prismatic torso) from the example-robot-data wheel, alone in a world."""
    from test_robot_models import ROBOTS

    urdf, srdf = request.param
    robot = Robot.from_urdf(ROBOTS / urdf, srdf=ROBOTS / srdf)
    world = CollisionWorld()
    world.add_robot(robot)
    return robot, world


@pytest.mark.slow
def test_stock_trees_self_motions_against_dense_sampling(stock):
    """Self-collision motions of branching robots: links on two branches share the
    joints above the branch point, which the bound leaves out; certified free
    motions are free at 401 states, contacts come before the dense first hit."""
    robot, world = stock
    lo, hi = robot.limits
    lo, hi = np.where(np.isfinite(lo), lo, -np.pi), np.where(np.isfinite(hi), hi, np.pi)
    rng = np.random.default_rng(0)
    outcomes = {"free": 0, "colliding": 0}
    t = np.linspace(0.0, 1.0, 401)
    while min(outcomes.values()) < 2:
        q = rng.uniform(lo, hi, (2, len(lo)))
        q[1] = q[0] + 0.3 * (q[1] - q[0])
        if world.check_path(robot.name, q).colliding.any():
            continue
        result = world.check_motion(robot.name, q[0], q[1])
        dense = world.check_path(robot.name, q[0] + t[:, None] * (q[1] - q[0])).colliding
        if result.free:
            assert not dense.any()
            outcomes["free"] += 1
        else:
            assert dense.any() and result.time <= t[np.argmax(dense)] + 1e-12
            outcomes["colliding"] += 1
    # and the speed bounds hold for every link's vertices on these trees too
    q_a, q_b = q
    bounds = speed_bounds(robot, q_a, q_b, 0.25)
    s = np.linspace(0.25, 1.0, 201)
    poses = robot.link_pose_array(q_a + s[:, None] * (q_b - q_a))
    for link, (name, mesh) in enumerate(robot.link_meshes.items()):
        moved = mesh.vertices @ np.swapaxes(poses[:, link, :3, :3], 1, 2) \
            + poses[:, link, None, :3, 3]
        length = np.linalg.norm(np.diff(moved, axis=0), axis=2).sum(axis=0).max()
        assert length <= min(bounds[link, 0] * 0.75, bounds[link, 1] * 0.75 + 0.5
                             * bounds[link, 2] * 0.75 ** 2) * (1 + 1e-9) + 1e-12, name
