"""Continuous collision checks of a robot's motion between joint configurations.

A motion is the straight line in joint space, ``q(t) = q_a + t (q_b - q_a)``
for ``t`` in [0, 1] (what OMPL, MoveIt and a trajectory's linear interpolation
mean by "the motion between two states"). It is certified by conservative
advancement (Mirtich 1996; Schwarzer, Saha and Latombe 2005), pair by pair:

1. **How fast a link can move.** Turning joint ``j`` at rate ``dq_j`` moves a
   point at distance ``r`` from its axis at speed ``r |dq_j|``; sliding it moves
   every point below it at ``|dq_j|``. For link ``L`` below a turning joint
   ``j``, over what is left of the segment from ``t``, ``r`` is at most the
   smaller of

   * the chain bound: the joint-origin offsets from ``j`` down to ``L``, plus
     the prismatic travel between them over the segment, plus ``L``'s radius
     about its frame (true in every configuration), and
   * the lever at ``t``: the farthest corner of ``L``'s box (its mesh's bounds
     in its own frame) from ``j``'s axis where both stand at ``t``, plus how far the joints between
     ``j`` and ``L`` can move ``L`` relative to ``j`` over the rest of the
     segment (their chain bounds times their steps).

   ``D_L = sum_j r_jL |dq_j|`` bounds the speed of every point of ``L`` (per
   unit of ``t``) from ``t`` to the end of the segment; mimic joints count with
   their own ``dq``. Beside it, the joints' velocities at ``t`` move ``L``
   rigidly, so the greatest speed ``S_L`` of its box now is exact (a corner's),
   and ``A_L`` bounds how fast any point's speed can grow (``link_motion`` in
   ``csrc/motion.c`` derives it):
   a point's path from ``t`` to ``t + s`` is at most
   ``min(D_L s, S_L s + A_L s^2 / 2)`` long.
2. **How fast a pair can close.** For two links of one robot only the joints
   above one and not the other change their distance (shared joints move both
   rigidly), so the pair's bounds are the sums of both links' over the unshared
   joints; a link against a standing object has the link's.
3. **Advancing.** If a pair is apart by ``d`` at ``t``, it cannot touch before
   the ``s`` at which ``min(D s, S s + A s^2 / 2) = d``: that stretch is proven
   free and the pair advances there. ``d`` is a lower bound from the objects'
   oriented boxes, then their convex pieces (:mod:`cadpipe.collision.convex`,
   GJK): exact to 1e-9 for bodies that are their pieces (boxes, spheres,
   capsules, convex meshes, pipes of one radius), never above the clearance for
   the others (a mesh's hull is never nearer than the mesh). Below ``tolerance``
   such a pair gets the exact clearance (:meth:`CollisionWorld.distance_at`).
   At a segment's start the bound is between solids (a body inside another is
   at 0), so the start is checked whole; after it only boundaries can meet first.

The pairs advance in time order -- always the one furthest behind -- so the first
pair found within ``tolerance`` of contact, at ``t_c``, is the motion's first
contact: every other pair is already proven free beyond ``t_c`` (the early exit).
Everything before ``t_c`` is proven free, and at ``t_c`` the pair is closer than
``tolerance``, so a real contact follows within about ``tolerance / speed``.

With a ``margin`` (a planner's padding) no contact time is sought: a pair
advances as if ``d - margin`` were its clearance and the motion is refused as
soon as a pair's bound falls below ``2 margin``. "Free" then proves a clearance
of at least ``margin`` all along, each step advances by at least ``margin / D``,
and no exact query is ever needed.

The whole advancement of a segment is one compiled call (C,
``csrc/motion.c``), forward kinematics and GJK included; it comes back to Python
only for an exact clearance.
"""

import weakref
from dataclasses import dataclass

import numpy as np

from cadpipe.collision.convex import ITERATIONS
from cadpipe.core.kernels import native
from cadpipe.errors import InputError

#: default clearance (world units, metres for URDF robots) counted as contact
TOLERANCE = 1e-4
#: advancement steps of one pair over one segment before it is taken as grazing at
#: just over the tolerance (then reported as in contact: conservative)
MAX_STEPS = 10_000

# what the advancement of a segment (``native.advance``, see :func:`_certify`) comes
# back with
_FREE, _CONTACT, _ASK, _REFUSED, _GRAZING = 0, 1, 2, 3, 4


@dataclass(frozen=True)
class MotionCheck:
    """The answer of :meth:`CollisionWorld.check_motion` and of
    :meth:`CollisionWorld.check_path` with ``between=True``.

    ``free`` is a proof that the whole motion is free (with ``margin > 0``:
    that it keeps at least ``margin`` from everything). Otherwise the motion is
    proven free before ``time`` along segment ``segment`` (a fraction in
    [0, 1]; segment ``k`` runs from configuration ``k`` to ``k + 1``), where
    ``pair`` comes within ``clearance < tolerance`` of contact, at joint values
    ``configuration``; with ``margin > 0``, where the pair's clearance bound
    ``clearance`` fell below ``2 margin`` (not a proven contact: the motion is
    refused). ``distance_calls`` counts the exact clearance queries and
    ``states`` the configurations the proof posed the robot at (see
    :func:`proof_states`).
    """

    free: bool
    segment: int | None
    time: float | None
    pair: tuple | None
    configuration: np.ndarray | None
    clearance: float | None
    tolerance: float
    distance_calls: int
    margin: float = 0.0
    states: int = 0

    def __bool__(self):
        """True when the motion collides (as a :class:`CollisionReport` is)."""
        return not self.free


def motion_settings(tolerance=None, margin=0.0):
    """``(tolerance, margin)`` of a motion check as floats, the default tolerance for
    None; :class:`InputError` naming the key otherwise, so a spec, a planner setup and
    a direct call refuse the same values with the same words before any work."""
    tolerance = _finite(TOLERANCE if tolerance is None else tolerance, "tolerance")
    if not tolerance > 0:
        raise InputError(f"tolerance must be > 0, got {tolerance!r}", key="tolerance")
    margin = _finite(margin, "margin")
    if not margin >= 0:
        raise InputError(f"margin must be >= 0, got {margin!r}", key="margin")
    return tolerance, margin


def _finite(value, key):
    """``value`` as a finite float, or :class:`InputError` naming ``key``."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        number = float("nan")
    if isinstance(value, bool) or not np.isfinite(number):
        raise InputError(f"{key} must be a finite number, got {value!r}", key=key)
    return number


def check_motion(world, group, configurations, tolerance=None, margin=0.0):
    """Certify the motion through ``(C, A)`` ``configurations`` of robot ``group``
    segment by segment, stopping at the first contact; a :class:`MotionCheck`.

    Pairs of standing objects are not the motion's concern (see
    :meth:`CollisionWorld.check`); every other pair not allowed is checked.
    ``margin > 0`` asks for that clearance all along instead of a contact time
    (see the module docstring).
    """
    return _certify(world, group, configurations, tolerance, margin, np.empty(0))[0]


def proof_states(world, group, configurations, tolerance=None, margin=0.0,
                 most=100_000):
    """``(V, A)`` the configurations at which :func:`check_motion` posed the robot
    (forward kinematics, then the clearance bounds of the pairs due there), in
    the order it did, at most ``most``: the work behind one certificate, for
    comparing it with a sampling validator's states."""
    times = np.empty(most)
    _, segments = _certify(world, group, configurations, tolerance, margin, times)
    q = np.asarray(configurations, np.float64)
    return np.concatenate([q[k] + t[:, None] * (q[k + 1] - q[k]) for k, t in segments])


def _certify(world, group, configurations, tolerance, margin, times):
    """:func:`check_motion`, and per segment checked ``(index, times posed)``, up to
    ``len(times)`` of them. Each segment is one call of ``native.advance``
    (``csrc/motion.c`` says what it carries over between calls), again after each
    exact clearance it asks for."""
    tolerance, margin = motion_settings(tolerance, margin)
    robot, base = world.robot(group)
    values = robot.joint_array(configurations)
    if len(values) < 2:
        raise InputError("a motion needs at least two configurations", key="configurations")
    q = np.asarray(configurations, np.float64)
    setup = _setup(world, group, robot)
    kinematics = (*setup.kinematics, np.ascontiguousarray(base, np.float64))
    count = len(setup.pairs[0])
    calls, posed, segments, done = 0, np.zeros(2), [], 0
    for segment in range(len(values) - 1):
        t, given, steps = np.zeros(count), np.full(count, np.nan), np.zeros(count, np.int64)
        posed[1] = -1.0
        while True:
            code, k, bound = native.advance(kinematics, setup.chain, setup.pairs,
                                            setup.pieces, values[segment], values[segment + 1],
                                            tolerance, margin, t, given, steps, posed, times,
                                            ITERATIONS, MAX_STEPS)
            if code != _ASK:
                break
            given[k] = _clearance(world, setup, robot, base, q[segment], q[segment + 1], t[k], k)
            calls += 1
        now = int(posed[0])
        segments.append((segment, times[min(done, len(times)):min(now, len(times))]))
        done = now
        if code != _FREE:
            at = q[segment] + t[k] * (q[segment + 1] - q[segment])
            clearance = float("nan") if code == _GRAZING else float(bound)
            return MotionCheck(False, segment, float(t[k]), setup.names[k], at, clearance,
                               tolerance, calls, margin, done), segments
    return MotionCheck(True, None, None, None, None, None, tolerance, calls, margin,
                       done), segments


def _clearance(world, setup, robot, base, q_a, q_b, t, k):
    """The exact clearance of pair ``k`` at time ``t`` of the motion ``q_a -> q_b``;
    between solids at the segment's start, between boundaries after it."""
    poses = robot.all_frame_poses(q_a + t * (q_b - q_a), base)[0]
    a, b = setup.pairs[0][k], setup.pairs[1][k]
    name_a, name_b = setup.names[k]
    return world.distance_at(name_a, name_b, poses[a], poses[b] if b >= 0 else
                             setup.pairs[4][k], containment=t == 0.0)


def robot_pairs(world, group):
    """``(P,)`` bool over the world's pairs (``np.triu_indices`` order of
    ``world.names``, as :attr:`CollisionReports.pair_colliding`): the pairs not
    allowed with at least one link of robot ``group``, the ones its motion can
    change."""
    return world.checker.chosen(group)


def robot_collides(world, group, configurations):
    """``(C,)`` bool: whether robot ``group`` touches anything at each configuration
    (pairs of standing objects left out)."""
    reports = world.check_path(group, configurations)
    return (reports.pair_colliding & robot_pairs(world, group)).any(axis=1)


def start_contacts(world, group, q):
    """Per configuration, the first pair with a robot link in contact there (None
    if the robot is free)."""
    reports = world.check_path(group, q)
    hit = (reports.pair_colliding & robot_pairs(world, group)).any(axis=1)
    mine = {n for n in world.names if world.group(n) == group}
    found = []
    for c in range(len(q)):
        pairs = [(a, b) for a, b, _ in reports[c].collisions if a in mine or b in mine] \
            if hit[c] else []
        found.append(pairs[0] if pairs else None)
    return found


def speed_bounds(robot, q_a, q_b, t=0.0, base=None):
    """``(L, 3)`` per link with geometry (in ``robot.link_meshes`` order), over the
    motion ``q_a -> q_b`` from time ``t`` to its end, per unit of time: a bound
    ``D`` of the speed of any of its points, the greatest speed ``S`` of a
    point of its box at ``t``, and a bound ``A`` of how fast any
    point's speed can grow; a point's path from ``t`` to ``t + s`` is at most
    ``min(D s, S s + A s^2 / 2)`` long."""
    values = robot.joint_array(np.stack([q_a, q_b]))
    base = np.eye(4) if base is None else np.ascontiguousarray(base, np.float64)
    chain = _chain(robot)
    return native.motions((*_kinematics(robot), base), chain, values[0], values[1], float(t),
                          chain[0])


_SETUPS = weakref.WeakKeyDictionary()


def _setup(world, group, robot):
    """The world's :class:`_Setup` for ``group``, made again only when objects,
    allowed pairs or the standing objects' poses have changed."""
    known = _SETUPS.setdefault(world, {}).get(group)
    fresh = known is None or known.layout != world.layout_version
    standing = np.setdiff1d(np.arange(len(world.names)), world.robot_links(group)[2]) if fresh \
        else known.standing
    versions = world.pose_versions[standing].tobytes()
    if fresh or known.versions != versions:
        known = _SETUPS[world][group] = _Setup(world, group, robot)
        known.layout, known.standing, known.versions = world.layout_version, standing, versions
    return known


class _Setup:
    """What one robot's motion checks in one world take to the compiled advancement:
    the robot's kinematics and chain facts, the pairs its motion can change (not
    allowed: link-link, ``a`` and ``b`` their frames, and link-object, ``b < 0`` and
    the object's standing pose) and every object's convex pieces."""

    def __init__(self, world, group, robot):
        links = list(robot.link_meshes)
        others = [n for n in world.names if world.group(n) != group]
        allowed = {frozenset((x, y)) for x, y, _ in world.allowed}
        a, b, other = [], [], []
        for i, x in enumerate(links):
            for j in range(i + 1, len(links)):
                if frozenset((x, links[j])) not in allowed:
                    a.append(i), b.append(j), other.append(-1)
            for j, y in enumerate(others):
                if frozenset((x, y)) not in allowed:
                    a.append(i), b.append(-1), other.append(j)
        index = {name: k for k, name in enumerate(world.names)}
        object_a = np.array([index[links[i]] for i in a], np.int64)
        object_b = np.array([index[links[j]] if j >= 0 else index[others[o]]
                             for j, o in zip(b, other)], np.int64)
        standing = np.array([world.pose(others[o]) if o >= 0 else np.eye(4)
                             for o in other]).reshape(-1, 4, 4)
        layout = world.checker.layout
        pieces = layout.pieces
        # each object's oriented box (8 corners in its frame): a GJK on 8 points that
        # settles most pairs before their hulls' (Panda links: 100 to 150 points)
        boxes = box_corners(layout.obb_centre, layout.obb_axes, layout.half)
        self.chain = _chain(robot)
        frame = self.chain[0]
        self.pairs = (frame[a], np.where(np.array(b, np.int64) >= 0, frame[np.maximum(b, 0)], -1)
                      .astype(np.int64), object_a, object_b, standing,
                      pieces.exact[object_a] & pieces.exact[object_b],
                      np.ascontiguousarray(boxes.reshape(-1, 3)))
        self.names = [(links[i], links[j] if j >= 0 else others[o])
                      for i, j, o in zip(a, b, other)]
        self.pieces = pieces.arrays()
        self.kinematics = _kinematics(robot)


def _kinematics(robot):
    """The robot's joint terms, kinds and links for
    :func:`~cadpipe.collision.kinematics.chain_poses`, and every frame's index."""
    k = robot._kinematics
    return k["terms"], k["kinds"], k["joint_links"], k["frame_index"]


_CHAINS = weakref.WeakKeyDictionary()

#: the corners of the cube [-1, 1]^3, to place an oriented box's corners
_SIGNS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)


def box_corners(centre, axes, half):
    """``(..., 8, 3)`` corners of oriented boxes: ``centre`` (..., 3), ``axes``
    (..., 3, 3) as columns, ``half`` (..., 3) extents."""
    return centre[..., None, :] + np.einsum("kc,...c,...rc->...kr", _SIGNS, half, axes)


def _chain(robot):
    """The kinematic facts the speed bounds need, per frame of the URDF (in
    ``robot.frames`` order) and per joint, as a tuple for the compiled
    advancement (built once per robot: robots do not change): the frame index
    of each link with geometry; per frame the corners (8, 3) of its link's
    box (the mesh's bounds in the link's frame: as tight as an oriented box for
    the Panda's steps, and free; the frame's origin for a frame without
    geometry) and the link's radius about it; ``above`` (F, J), joint ``j`` on the path from the
    base to frame ``f``; ``below`` (F, J, J), joint ``k`` on it after ``j``; per
    joint its kind (turning, sliding), origin offset length, parent frame,
    origin and axis."""
    if robot not in _CHAINS:
        joints = robot.joints
        parent_joint = {j.child: k for k, j in enumerate(joints)}
        n = len(joints)
        above = np.zeros((len(robot.frames), n), bool)
        below = np.zeros((len(robot.frames), n, n), bool)
        corners = np.zeros((len(robot.frames), 8, 3))
        radius = np.zeros(len(robot.frames))
        for f, link in enumerate(robot.frames):
            if link in robot.link_meshes:
                lo, hi = robot.link_meshes[link].bounds
                corners[f] = box_corners(0.5 * (lo + hi), np.eye(3), 0.5 * (hi - lo))
                radius[f] = np.linalg.norm(robot.link_meshes[link].vertices, axis=1).max()
            path = []
            while link in parent_joint:
                path.append(parent_joint[link])
                link = joints[path[-1]].parent
            path.reverse()
            above[f, path] = True
            for at, j in enumerate(path):
                below[f, j, path[at + 1:]] = True
        frames = {name: k for k, name in enumerate(robot.frames)}
        _CHAINS[robot] = (
            np.array([frames[name] for name in robot.link_meshes], np.int64), corners,
            radius, above, below,
            np.array([j.kind in ("revolute", "continuous") for j in joints], bool),
            np.array([j.kind == "prismatic" for j in joints], bool),
            np.array([np.linalg.norm(j.origin[:3, 3]) for j in joints], np.float64),
            np.array([frames[j.parent] for j in joints], np.int64),
            np.array([j.origin for j in joints]).reshape(-1, 4, 4),
            np.array([j.axis for j in joints]).reshape(-1, 3))
    return _CHAINS[robot]


def frame_speeds(robot, frame, values, reach=0.0):
    """``(S,)`` a bound of how fast any point within ``reach`` of the origin of
    ``frame`` (any frame of the robot) moves, per unit of each segment's
    parameter, over the segments between rows of ``values`` (``(C, J)`` values
    of every joint, as :meth:`Robot.joint_array` gives them): the smaller of
    ``D`` and ``S + A`` of :func:`speed_bounds` for the origin, plus ``reach``
    times the sum of the changes of the turning joints on the frame's chain (a
    bound of how fast the frame turns)."""
    kinematics = (*_kinematics(robot), np.eye(4))
    chain, f = _chain(robot), robot.frames.index(frame)
    values = np.ascontiguousarray(values, np.float64)
    turning = chain[3][f] & chain[5]                    # above the frame, and turning
    return native.fastest(kinematics, chain, values, f) + \
        reach * np.abs(np.diff(values[:, turning], axis=0)).sum(axis=1)
