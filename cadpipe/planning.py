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
  a corner between two samples is never missed. A planner needs only yes or
  no: OMPL 2's Python bindings hand both ``checkMotion`` overloads to one
  Python method and take no last valid state back, so a planner that asks
  for one (KPIECE, say) gets fraction 0 and keeps no part of a refused motion.
  With a ``margin`` (MoveIt's padding) a motion must keep that clearance, and
  is refused without looking for its contact.

Every motion a planner keeps has passed the motion validator, so a planned
path is collision-free between its states, not only at them.
:func:`plan` puts the pieces together the way ``SimpleSetup`` is usually
driven.
"""

import numpy as np

from cadpipe.collision.motion import check_motion, motion_settings, start_contacts
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


def motion_validator(world, group, space_information, counter=None, tolerance=None,
                     margin=0.0):
    """An ``ompl.base.MotionValidator`` backed by :meth:`CollisionWorld.check_motion`:
    a motion is valid when the check proves it free.

    ``counter`` (a :class:`Counter`) counts the motions asked about;
    ``tolerance`` and ``margin`` are the motion check's.
    """
    base, _ = _ompl()
    robot, _ = world.robot(group)
    count = len(robot.actuated)
    counter = Counter() if counter is None else counter
    tolerance, margin = motion_settings(tolerance, margin)

    class MotionValidator(base.MotionValidator):
        def checkMotion(self, s1, s2, *rest):          # noqa: N802 (OMPL's name)
            counter.motions += 1
            q = np.empty((2, count))
            q[0], q[1] = _values(s1, count), _values(s2, count)
            return check_motion(world, group, q, tolerance, margin).free

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


def setup(world, group, counter=None, planner="RRTConnect", step=None, margin=0.0):
    """An ``ompl.geometric.SimpleSetup`` for robot ``group`` of ``world``: the
    joint-limit box as state space, cadpipe's state validity checker and
    motion validator (with ``margin``), and ``planner`` (a name in
    :data:`PLANNERS`) with its range (longest motion it tries, in joint-space
    units) set to ``step`` when given."""
    base, geometric = _ompl()
    if planner not in PLANNERS:
        raise InputError(f"planner must be one of {', '.join(PLANNERS)}, got {planner!r}",
                         key="planner")
    _, margin = motion_settings(margin=margin)
    robot, _ = world.robot(group)
    space, bounds = joint_space(robot)
    simple = geometric.SimpleSetup(space)
    counter = Counter() if counter is None else counter
    simple.setStateValidityChecker(state_validity_checker(world, group, counter))
    information = simple.getSpaceInformation()
    validator = motion_validator(world, group, information, counter, margin=margin)
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
         counter=None, step=None, margin=0.0):
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
    margin : float
        A clearance every planned motion keeps (world units; MoveIt's
        padding): motions are refused as soon as a clearance bound falls
        below ``2 margin`` (see :meth:`CollisionWorld.check_motion`), so the
        start and the goal need that much room. 0: any clearance.

    Returns
    -------
    (N, A) array
        Waypoints from ``start`` to ``goal``; the straight motion between
        consecutive ones is certified free.

    Raises
    ------
    InputError
        A start or goal that is in collision, outside the limits, or within
        ``2 margin`` of contact.
    PlanningError
        No exact solution within ``seconds``.
    """
    _, margin = motion_settings(margin=margin)
    robot, _ = world.robot(group)
    robot.joint_array(np.stack([np.asarray(start, np.float64), np.asarray(goal, np.float64)]))
    for name, q in (("start", start), ("goal", goal)):
        q = np.asarray(q, np.float64)
        hit = start_contacts(world, group, q[None])[0]
        if hit is not None:
            raise InputError(f"{name} configuration is in collision ({hit[0]} with {hit[1]})",
                             key=name)
        room = world.check_motion(group, q, q, margin=2 * margin) if margin > 0 else None
        if room is not None and not room.free:
            raise InputError(f"{name} configuration is within 2 * margin = {2 * margin:g} of "
                             f"contact ({room.pair[0]} with {room.pair[1]}); give a smaller "
                             "margin", key=name)
    counter = Counter() if counter is None else counter
    simple = setup(world, group, counter, planner, step, margin)
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
