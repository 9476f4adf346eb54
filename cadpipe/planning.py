"""Motion planning with OMPL, collision-checked by a :class:`CollisionWorld`.

OMPL (the ``ompl`` wheel, OMPL 2's Python bindings; ``pip install
cadpipe[planning]``) plans in the robot's joint space, a box of its joint
limits (continuous joints span [-pi, pi]). cadpipe answers its two
questions:

* **Is this state valid?** (:func:`state_validity_checker`) -- the world's
  exact check of one configuration, stopping at the first collision, of the
  pairs with a robot link (``check(first_hit=True, only=group)``; standing
  obstacles touching each other are not the planner's concern). Like
  MoveIt's planning scene it poses the robot in the world to do so;
  :func:`plan` puts the robot back where it stood.
* **Is this motion valid?** (:class:`MotionValidator`) -- the world's
  continuous check of the straight joint-space motion
  (:meth:`CollisionWorld.check_motion`), a proof where OMPL's default
  validator only samples the motion at a resolution, so a thin obstacle or
  a corner between two samples is never missed.

Every motion a planner keeps has passed the motion validator, so a planned
path is collision-free between its states, not only at them.
:func:`plan` puts the pieces together the way ``SimpleSetup`` is usually
driven.
"""

import numpy as np

from cadpipe.collision.motion import start_contacts
from cadpipe.errors import CadpipeError, InputError

PLANNERS = ("RRTConnect", "RRT", "RRTstar", "PRM", "KPIECE1", "BITstar")


class PlanningError(CadpipeError):
    """The planner found no path in the time it was given."""


def _ompl():
    try:
        from ompl import base, geometric, util
    except ImportError:
        raise InputError("planning needs OMPL's Python bindings: pip install "
                         "'cadpipe[planning]' (the ompl wheel)") from None
    util.setLogLevel(util.LogLevel.LOG_WARN)
    return base, geometric


def _values(state, count):
    return np.fromiter((state[k] for k in range(count)), np.float64, count)


class Counter:
    """How many states and motions the world was asked about."""

    def __init__(self):
        self.states = 0
        self.motions = 0


def state_validity_checker(world, group, counter=None):
    """A callable OMPL accepts as a state validity checker: True where the robot
    ``group`` collides with nothing at the state (a joint vector over
    ``robot.actuated``). It leaves the robot posed at the last state asked."""
    robot, _ = world.robot(group)
    count = len(robot.actuated)
    counter = Counter() if counter is None else counter

    def valid(state):
        counter.states += 1
        world.set_joints(group, _values(state, count))
        return not world.check(first_hit=True, only=group)

    return valid


def motion_validator(world, group, space_information, counter=None, tolerance=None):
    """An ``ompl.base.MotionValidator`` backed by :meth:`CollisionWorld.check_motion`.

    ``counter`` (a :class:`Counter`) counts the motions asked about;
    ``tolerance`` is the motion check's contact tolerance.

    The states OMPL's own discrete validator would look at (its validity
    checking resolution) are screened first, in one batched
    ``check_path(first_hit=True)``: one of them colliding is a collision, and
    the motion is refused without the certificate's slow approach to the
    contact. A motion is called valid only by the certificate.
    """
    base, _ = _ompl()
    robot, _ = world.robot(group)
    count = len(robot.actuated)
    counter = Counter() if counter is None else counter
    step = space_information.getStateValidityCheckingResolution() * \
        space_information.getMaximumExtent()

    class MotionValidator(base.MotionValidator):
        def checkMotion(self, s1, s2, *rest):          # noqa: N802 (OMPL's name)
            counter.motions += 1
            q_a, q_b = _values(s1, count), _values(s2, count)
            samples = int(np.ceil(np.linalg.norm(q_b - q_a) / step)) if step > 0 else 0
            if samples > 1:
                t = np.arange(1, samples)[:, None] / samples
                screen = world.check_path(group, q_a + t * (q_b - q_a), first_hit=True)
                if (screen.pair_colliding & world.checker.chosen(group)).any():
                    return False
            return world.check_motion(group, q_a, q_b, tolerance).free

    return MotionValidator(space_information)


def joint_space(robot):
    """OMPL's ``RealVectorStateSpace`` of the robot's joint-limit box (continuous
    joints span [-pi, pi]) and its bounds (keep both alive together)."""
    base, _ = _ompl()
    lower, upper = robot.limits
    lower, upper = np.where(np.isfinite(lower), lower, -np.pi), \
        np.where(np.isfinite(upper), upper, np.pi)
    space = base.RealVectorStateSpace(len(lower))
    bounds = base.RealVectorBounds(len(lower))
    for k, (lo, hi) in enumerate(zip(lower, upper)):
        bounds.setLow(k, float(lo))
        bounds.setHigh(k, float(hi))
    space.setBounds(bounds)
    return space, bounds


def setup(world, group, counter=None, planner="RRTConnect", step=None):
    """An ``ompl.geometric.SimpleSetup`` for robot ``group`` of ``world``: the
    joint-limit box as state space, cadpipe's state validity checker and
    motion validator, and ``planner`` (a name in :data:`PLANNERS`) with its
    range (longest motion it tries, in joint-space units) set to ``step``
    when given."""
    base, geometric = _ompl()
    if planner not in PLANNERS:
        raise InputError(f"planner must be one of {', '.join(PLANNERS)}, got {planner!r}",
                         key="planner")
    robot, _ = world.robot(group)
    space, bounds = joint_space(robot)
    simple = geometric.SimpleSetup(space)
    counter = Counter() if counter is None else counter
    simple.setStateValidityChecker(state_validity_checker(world, group, counter))
    information = simple.getSpaceInformation()
    validator = motion_validator(world, group, information, counter)
    information.setMotionValidator(validator)
    chosen = getattr(geometric, planner)(information)
    if step is not None:
        if not step > 0:
            raise InputError(f"step must be > 0, got {step!r}", key="step")
        chosen.setRange(float(step))
    simple.setPlanner(chosen)
    # the objects OMPL holds by reference must live as long as the setup
    simple._cadpipe_keep = (space, bounds, validator, counter)
    return simple


def plan(world, group, start, goal, seconds=5.0, planner="RRTConnect", simplify=True,
         counter=None, step=None):
    """Plan a collision-free motion of robot ``group`` from ``start`` to ``goal``.

    Parameters
    ----------
    world : CollisionWorld
        Holds the robot (added with :meth:`~CollisionWorld.add_robot`) and the
        obstacles.
    group : str
        The robot's group.
    start, goal : (A,) arrays
        Joint values over ``robot.actuated`` (radians, metres).
    seconds : float
        Planning time limit.
    planner : str
        An OMPL geometric planner in :data:`PLANNERS`.
    simplify : bool
        Shortcut the path (OMPL's simplifier, every shortcut motion-checked).
    counter : Counter, optional
        Filled with the number of state and motion checks.
    step : float, optional
        The planner's range: the longest motion it tries (OMPL's default, a
        fifth of the joint-space extent, when None). Shorter motions are
        cheaper to certify.

    Returns
    -------
    (N, A) array
        Waypoints from ``start`` to ``goal``; the straight motion between
        consecutive ones is certified free.

    Raises
    ------
    InputError
        A start or goal that is in collision or outside the limits.
    PlanningError
        No exact solution within ``seconds``.
    """
    robot, _ = world.robot(group)
    robot.joint_array(np.stack([np.asarray(start, np.float64), np.asarray(goal, np.float64)]))
    for name, q in (("start", start), ("goal", goal)):
        hit = start_contacts(world, group, np.asarray(q, np.float64)[None])[0]
        if hit is not None:
            raise InputError(f"{name} configuration is in collision ({hit[0]} with {hit[1]})",
                             key=name)
    counter = Counter() if counter is None else counter
    simple = setup(world, group, counter, planner, step)
    space = simple.getStateSpace()
    states = []
    for q in (start, goal):
        state = space.allocState()
        for k, value in enumerate(np.asarray(q, np.float64)):
            state[k] = float(value)
        states.append(state)
    simple.setStartAndGoalStates(*states)
    links = list(robot.link_meshes)
    stood = [world.pose(link) for link in links]
    try:
        solved = simple.solve(float(seconds))
        if solved and simplify:
            simple.simplifySolution()
    finally:
        for link, pose in zip(links, stood):
            world.set_pose(link, pose)
    if not solved or "Exact" not in str(solved):
        raise PlanningError(f"{planner} found no path for {group} in {seconds:g} s "
                            f"({counter.states} states, {counter.motions} motions checked)")
    count = len(robot.actuated)
    return np.array([_values(s, count) for s in simple.getSolutionPath().getStates()])
