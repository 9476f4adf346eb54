"""Continuous collision checks of a robot's motion between joint configurations.

A motion is the straight line in joint space, ``q(t) = q_a + t (q_b - q_a)``
for ``t`` in [0, 1] (what OMPL, MoveIt and a trajectory's linear interpolation
mean by "the motion between two states"). It is certified by conservative
advancement (Mirtich 1996; Schwarzer, Saha and Latombe 2005), pair by pair:

1. **How far a link can move.** Turning joint ``j`` by ``dq`` moves a point at
   distance ``r`` from its axis by at most ``r |dq|``; sliding it moves every
   point below it by ``|dq|``. For link ``L`` below joint ``j``, ``r`` is at
   most the length of the chain from ``j``'s frame to the link's points: the
   sum of the joint-origin offsets between them, plus the prismatic travel of
   the sliding joints between them over the segment, plus the link's own
   radius about its frame. Summed over the joints above ``L``:
   ``D_L = sum_j r_jL |dq_j|`` bounds the distance any point of ``L`` travels
   during the segment (mimic joints count with their own ``dq``).
2. **How far a pair can close.** For two links of one robot only the joints
   above one and not the other change their distance (shared joints move
   both rigidly), so ``D = D_a + D_b`` over the unshared joints; a link
   against a standing object has ``D = D_L``.
3. **Advancing.** If a pair is apart by ``d`` at ``t``, it cannot touch before
   ``t + d / D``: that stretch is proven free and the pair advances there.
   Cheap lower bounds of ``d`` are tried first -- bounding balls, then the
   convex pieces' GJK bound (:mod:`cadpipe.collision.convex`); a bound of at
   least :data:`EXACT_BELOW` advances the pair by itself, and only below that
   is the exact clearance (:meth:`CollisionWorld.distance_at`) asked for.
   The start of each segment is checked whole (:meth:`CollisionWorld.check_path`,
   containment included); after it only boundaries can meet first, so the
   advancement measures the distance between boundaries.

A pair whose clearance falls below ``tolerance`` is in contact: the first such
time over all pairs is the motion's contact time ``t_c``. Everything before
``t_c`` is proven free, and at ``t_c`` the pair is closer than ``tolerance``,
so a real contact follows within about ``tolerance / speed``. Pairs keep
advancing only up to the earliest contact found so far (the early exit).
"""

import weakref
from dataclasses import dataclass

import numpy as np

from cadpipe.collision.convex import body_gaps
from cadpipe.errors import InputError

#: default clearance (world units, metres for URDF robots) counted as contact
TOLERANCE = 1e-4
#: advancement rounds before giving up on a pair that grazes at just over the
#: tolerance (it is then reported as in contact: conservative)
MAX_ROUNDS = 10_000
#: clearance bounds (world units) below which the exact clearance is asked for; above
#: it the pair advances by its bound alone
EXACT_BELOW = 5e-4


@dataclass(frozen=True)
class MotionCheck:
    """The answer of :meth:`CollisionWorld.check_motion` and of
    :meth:`CollisionWorld.check_path` with ``between=True``.

    ``free`` is a proof that the whole motion is free. Otherwise the motion is
    proven free before ``time`` along segment ``segment`` (a fraction in
    [0, 1]; segment ``k`` runs from configuration ``k`` to ``k + 1``), where
    ``pair`` comes within ``clearance <= tolerance`` of contact, at joint values
    ``configuration``. ``distance_calls`` counts the exact clearance queries.
    """

    free: bool
    segment: int | None
    time: float | None
    pair: tuple | None
    configuration: np.ndarray | None
    clearance: float | None
    tolerance: float
    distance_calls: int

    def __bool__(self):
        """True when the motion collides (as a :class:`CollisionReport` is)."""
        return not self.free


def check_motion(world, group, configurations, tolerance=TOLERANCE):
    """Certify the motion through ``(C, A)`` ``configurations`` of robot ``group``
    segment by segment, stopping at the first contact; a :class:`MotionCheck`.

    Pairs of standing objects are not the motion's concern (see
    :meth:`CollisionWorld.check`); every other pair not allowed is checked.
    """
    if not tolerance > 0:
        raise InputError(f"tolerance must be > 0, got {tolerance!r}", key="tolerance")
    robot, base = world.robot(group)
    values = robot.joint_array(configurations)
    if len(values) < 2:
        raise InputError("a motion needs at least two configurations", key="configurations")
    q = np.asarray(configurations, np.float64)
    pairs = _pairs(world, group, robot)
    chain = _chain(robot)
    calls = 0
    starts = start_contacts(world, group, q[:-1])
    for segment in range(len(values) - 1):
        if starts[segment] is not None:
            return MotionCheck(False, segment, 0.0, starts[segment], q[segment].copy(), 0.0,
                               tolerance, calls)
        found, used = _advance(world, robot, base, chain, pairs, q[segment], q[segment + 1],
                               values[segment], values[segment + 1], tolerance)
        calls += used
        if found is not None:
            t, k, clearance = found
            at = q[segment] + t * (q[segment + 1] - q[segment])
            return MotionCheck(False, segment, t, (pairs.name_a[k], pairs.name_b[k]), at,
                               clearance, tolerance, calls)
    return MotionCheck(True, None, None, None, None, None, tolerance, calls)


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


_PAIRS = weakref.WeakKeyDictionary()


def _pairs(world, group, robot):
    """The world's :class:`_Pairs` for ``group``, made again only when objects,
    allowed pairs or the standing objects' poses have changed."""
    robot_ids = world._robot(group)[2]
    standing = np.setdiff1d(np.arange(len(world.names)), robot_ids)
    key = (group, world.layout_version, world.pose_versions[standing].tobytes())
    known = _PAIRS.get(world)
    if known is None or known[0] != key:
        known = _PAIRS[world] = (key, _Pairs(world, group, robot))
    return known[1]


class _Pairs:
    """The pairs a robot's motion can change, not allowed: link-link (``b`` a
    geometry-link index) and link-object (``b < 0``, the object standing still)."""

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
        self.a, self.b, self.other = (np.array(v, np.int64) for v in (a, b, other))
        # the world's object indices of each pair, and every object's convex pieces
        index = {name: k for k, name in enumerate(world.names)}
        self.object_a = np.array([index[links[i]] for i in a], np.int64)
        self.object_b = np.array([index[links[j]] if j >= 0 else index[others[o]]
                                  for j, o in zip(b, other)], np.int64)
        self.pieces = world.checker.layout.pieces.arrays()
        self.name_a = [links[i] for i in a]
        self.name_b = [links[j] if j >= 0 else others[o] for j, o in zip(b, other)]
        # each standing object's world box and pose
        self.box = np.array([world.bounds(n) for n in others]).reshape(-1, 2, 3)
        self.pose = np.array([world.pose(n) for n in others]).reshape(-1, 4, 4)


_CHAINS = weakref.WeakKeyDictionary()


def _chain(robot):
    """The robot's :class:`_Chain`, built once (robots do not change)."""
    if robot not in _CHAINS:
        _CHAINS[robot] = _Chain(robot)
    return _CHAINS[robot]


class _Chain:
    """The kinematic facts the bound needs, per geometry link and joint."""

    def __init__(self, robot):
        joints = robot.joints
        parent_joint = {j.child: k for k, j in enumerate(joints)}
        meshes = list(robot.link_meshes.values())
        n = len(joints)
        # above[l, j]: joint j is on the path from the base to geometry link l;
        # below[l, j, k]: joint k is on it too, after joint j
        self.above = np.zeros((len(meshes), n), bool)
        self.below = np.zeros((len(meshes), n, n), bool)
        for g, link in enumerate(robot.link_meshes):
            path = []
            while link in parent_joint:
                path.append(parent_joint[link])
                link = joints[path[-1]].parent
            path.reverse()
            self.above[g, path] = True
            for at, j in enumerate(path):
                self.below[g, j, path[at + 1:]] = True
        self.offset = np.array([np.linalg.norm(j.origin[:3, 3]) for j in joints])
        frames = {name: k for k, name in enumerate(robot.frames)}
        self.parent = np.array([frames[j.parent] for j in joints], np.int64)
        self.origin = np.array([j.origin for j in joints]).reshape(-1, 4, 4)
        self.axis = np.array([j.axis for j in joints]).reshape(-1, 3)
        self.turning = np.array([j.kind in ("revolute", "continuous") for j in joints])
        self.sliding = np.array([j.kind == "prismatic" for j in joints])
        self.radius = np.array([np.linalg.norm(m.vertices, axis=1).max() for m in meshes])
        # a ball around each link (its box centre, in the link's frame)
        self.centre = np.array([0.5 * (m.bounds[0] + m.bounds[1]) for m in meshes])
        self.ball = np.array([np.linalg.norm(m.vertices - c, axis=1).max()
                              for m, c in zip(meshes, self.centre)])
        self.geometry = np.array([frames[name] for name in robot.link_meshes], np.int64)

    def reach(self, v_a, v_b, frames, links):
        """``(L, J)`` how far a point of link ``l`` can move per unit of joint ``j``'s
        motion over the segment between full joint values ``v_a`` and ``v_b``:
        its lever arm for a turning joint, 1 for a sliding one, 0 off its path.

        The lever is the smaller of the chain bound (joint offsets, prismatic
        travel and the link's radius, good everywhere) and the lever at the
        segment's start (the link's ball's distance from the axis, ``frames``
        and ``links`` being every frame's and each geometry link's start pose)
        plus how far the link can move relative to joint ``j`` meanwhile.
        """
        travel = np.where(self.sliding, np.maximum(np.abs(v_a), np.abs(v_b)), 0.0)
        lever = self.below @ (self.offset + travel) + self.radius[:, None]
        step = np.abs(v_b - v_a)
        chain = np.where(self.above, np.where(self.turning, lever, self.sliding * 1.0), 0.0)
        # relative[l, j]: the chain bound of link l's travel in joint j's frame
        relative = np.einsum("ljk,lk->lj", self.below, chain * step)
        joint = frames[self.parent] @ self.origin                          # (J, 4, 4)
        point, direction = joint[:, :3, 3], np.einsum("jab,jb->ja", joint[:, :3, :3], self.axis)
        centre = np.einsum("lab,lb->la", links[:, :3, :3], self.centre) + links[:, :3, 3]
        offset = centre[:, None] - point[None]                              # (L, J, 3)
        along = np.einsum("lja,ja->lj", offset, direction)
        off_axis = np.sqrt(np.maximum(np.einsum("lja,lja->lj", offset, offset) - along ** 2, 0))
        start = off_axis + self.ball[:, None] + relative
        return np.where(self.turning & self.above, np.minimum(chain, start), chain)

    def speed(self, pairs, v_a, v_b, frames, links):
        """``(P,)`` how much each pair's clearance can shrink over the segment: the
        bound of the module docstring, joints shared by two links left out."""
        per_joint = self.reach(v_a, v_b, frames, links) * np.abs(v_b - v_a)   # (L, J)
        own = pairs.b >= 0
        b = np.where(own, pairs.b, 0)
        shared = self.above[pairs.a] & self.above[b] & own[:, None]
        return (np.where(shared, 0.0, per_joint[pairs.a]).sum(axis=1)
                + np.where(own, np.where(shared, 0.0, per_joint[b]).sum(axis=1), 0.0))


def _advance(world, robot, base, chain, pairs, q_a, q_b, v_a, v_b, tolerance):
    """Conservative advancement of every pair over one segment; returns
    ``((t, pair, clearance) or None, exact clearance calls)``.

    Each round places the links of every pair still short of the horizon at
    its own ``t`` (one batched forward-kinematics call), advances the pairs
    whose bounding balls or convex pieces prove the rest of the way, steps the
    pairs whose bound is at least :data:`EXACT_BELOW` by it, and asks the exact
    clearance of the others.
    """
    frames = robot.all_frame_poses(q_a[None], base)[0]
    speed = chain.speed(pairs, v_a, v_b, frames, frames[chain.geometry])
    t = np.zeros(len(pairs.a))
    horizon, hit, calls = 1.0, None, 0
    for _ in range(MAX_ROUNDS):
        active = np.flatnonzero(t < horizon)
        if not active.size:
            return hit, calls
        times, inverse = np.unique(t[active], return_inverse=True)
        poses = robot.link_pose_array(q_a + times[:, None] * (q_b - q_a), base)
        a, b, other = pairs.a[active], pairs.b[active], pairs.other[active]
        link_b = b >= 0
        pose_a = poses[inverse, a]
        pose_b = np.where(link_b[:, None, None], poses[inverse, np.maximum(b, 0)],
                          pairs.pose[np.maximum(other, 0)] if len(pairs.pose) else pose_a)
        centre_a = _apply(pose_a, chain.centre[a])
        # a lower bound of the clearance: link ball to link ball, or to the object's box
        centre_b = _apply(pose_b, chain.centre[np.maximum(b, 0)])
        if len(pairs.box):
            box = pairs.box[np.maximum(other, 0)]
            nearest = np.minimum(np.maximum(centre_a, box[:, 0]), box[:, 1])
            centre_b = np.where(link_b[:, None], centre_b, nearest)
        ball_b = np.where(link_b, chain.ball[np.maximum(b, 0)], 0.0)
        lower = np.linalg.norm(centre_a - centre_b, axis=1) - chain.ball[a] - ball_b
        need = speed[active] * (horizon - t[active])
        # the balls are not enough: the convex pieces' bound (compiled GJK)
        close = np.flatnonzero(lower < need)
        if close.size:
            hulls = np.empty(close.size)
            body_gaps(*pairs.pieces, pairs.object_a[active[close]],
                      np.ascontiguousarray(pose_a[close]), pairs.object_b[active[close]],
                      np.ascontiguousarray(pose_b[close]), need[close], hulls)
            lower[close] = np.maximum(lower[close], hulls)
        enough = lower >= need
        t[active[enough]] = horizon
        # a bound of at least EXACT_BELOW advances its pair without an exact query
        cheap = ~enough & (lower >= max(EXACT_BELOW, tolerance)) & (speed[active] > 0)
        t[active[cheap]] = np.minimum(t[active[cheap]] + lower[cheap] / speed[active[cheap]],
                                      horizon)
        for e in np.flatnonzero(~enough & ~cheap):
            k = active[e]
            if t[k] >= horizon:            # a contact found this round comes earlier
                continue
            d = world.distance_at(pairs.name_a[k], pairs.name_b[k], pose_a[e], pose_b[e],
                                  containment=False)
            calls += 1
            if d < tolerance:
                horizon, hit = t[k], (float(t[k]), int(k), float(d))
            else:
                t[k] = horizon if speed[k] <= 0 else min(t[k] + d / speed[k], horizon)
    # still short of the horizon after MAX_ROUNDS: grazing; report it as contact
    k = int(np.argmin(np.where(t < horizon, t, np.inf)))
    return (float(t[k]), k, float("nan")), calls


def _apply(poses, points):
    """``(E, 3)`` points moved by their ``(E, 4, 4)`` poses."""
    return np.einsum("eij,ej->ei", poses[:, :3, :3], points) + poses[:, :3, 3]
