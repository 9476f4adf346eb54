"""OMPL planning with cadpipe's validators: planned paths never collide between states."""

import sys
from pathlib import Path as FilePath

import numpy as np
import pytest

from cadpipe import InputError
from cadpipe.collision import Robot
from cadpipe.collision.motion import robot_collides
from cadpipe.planning import Counter, plan, setup

EXAMPLES = FilePath(__file__).parent.parent / "examples"
sys.path.insert(0, str(EXAMPLES))
import plan_panda  # noqa: E402  (the example is the scene under test)


@pytest.fixture(scope="module")
def scene():
    robot = Robot.from_urdf(plan_panda.PANDA / "panda.urdf", srdf=plan_panda.PANDA / "panda.srdf")
    return robot, plan_panda.window_cell(robot)


def _dense(path, count=400):
    t = np.linspace(0.0, 1.0, count)
    return np.concatenate([a + t[:, None] * (b - a) for a, b in zip(path[:-1], path[1:])])


@pytest.mark.slow
@pytest.mark.parametrize("planner, margin", [("RRTConnect", 0.0), ("RRTConnect", 0.002),
                                             ("KPIECE1", 0.0)])
def test_planned_paths_are_free_at_every_dense_state_between_waypoints(scene, planner, margin):
    """Exact motions, a MoveIt-style padding, and a planner that asks OMPL's
    checkMotion for a last valid state (KPIECE1; the bindings give none back)."""
    robot, world = scene
    counter = Counter()
    path = plan(world, robot.name, plan_panda.START, plan_panda.GOAL, seconds=60.0,
                counter=counter, step=0.5, planner=planner, margin=margin)
    np.testing.assert_allclose(path[0], plan_panda.START)
    np.testing.assert_allclose(path[-1], plan_panda.GOAL)
    assert counter.states > 0 and counter.motions > 0
    assert not robot_collides(world, robot.name, _dense(path)).any()
    for a, b in zip(path[:-1], path[1:]):       # each motion keeps the margin asked for
        assert world.check_motion(robot.name, a, b, margin=margin).free
    # and the straight line from start to goal does collide: planning was needed
    assert not world.check_motion(robot.name, plan_panda.START, plan_panda.GOAL).free


def test_validators_answer_as_the_world_does(scene):
    robot, world = scene
    counter = Counter()
    simple = setup(world, robot.name, counter)
    information = simple.getSpaceInformation()
    space = simple.getStateSpace()

    def state(q):
        s = space.allocState()
        for k, v in enumerate(q):
            s[k] = float(v)
        return s

    start, goal = state(plan_panda.START), state(plan_panda.GOAL)
    assert information.isValid(start) and information.isValid(goal)
    assert not information.checkMotion(start, goal)          # through the wall
    folded = np.array([-1.726, 1.544, -2.348, -3.057, -1.026, 3.718, -1.363, 0.033])
    assert not information.isValid(state(folded))          # self-collision
    assert counter.states >= 3 and counter.motions == 1


def test_bad_planning_input(scene):
    robot, world = scene
    folded = np.array([-1.726, 1.544, -2.348, -3.057, -1.026, 3.718, -1.363, 0.033])
    with pytest.raises(InputError, match="start configuration is in collision"):
        plan(world, robot.name, folded, plan_panda.GOAL, seconds=0.1)
    with pytest.raises(InputError, match="planner must be one of"):
        setup(world, robot.name, planner="Dijkstra")
    with pytest.raises(InputError, match="outside its limits"):
        plan(world, robot.name, plan_panda.START, plan_panda.GOAL + 10, seconds=0.1)
    for margin in (-0.01, "wide", float("nan")):
        with pytest.raises(InputError, match="margin") as caught:
            plan(world, robot.name, plan_panda.START, plan_panda.GOAL, seconds=0.1,
                 margin=margin)
        assert caught.value.key == "margin"
    # the start beside the duct has a few centimetres of room, not half a metre
    with pytest.raises(InputError, match="start configuration is within 2 \\* margin") as caught:
        plan(world, robot.name, plan_panda.START, plan_panda.GOAL, seconds=0.1, margin=0.25)
    assert caught.value.key == "start"
