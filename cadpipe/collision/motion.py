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
   and ``A_L`` bounds how fast any point's speed can grow (:func:`_link_motion`):
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

The whole advancement of a segment is one compiled call (numba), forward
kinematics included; it comes back to Python only for an exact clearance.
"""

import weakref
from dataclasses import dataclass

import numba
import numpy as np

from cadpipe.collision.convex import ITERATIONS, body_bounds, bounds
from cadpipe.collision.kinematics import chain_poses
from cadpipe.errors import InputError

#: default clearance (world units, metres for URDF robots) counted as contact
TOLERANCE = 1e-4
#: advancement steps of one pair over one segment before it is taken as grazing at
#: just over the tolerance (then reported as in contact: conservative)
MAX_STEPS = 10_000

# what :func:`_advance` comes back with
_FREE, _CONTACT, _ASK, _REFUSED, _GRAZING = 0, 1, 2, 3, 4

_jit = numba.njit(cache=True, nogil=True, error_model="numpy")


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
    ``len(times)`` of them."""
    tolerance, margin = motion_settings(tolerance, margin)
    robot, base = world.robot(group)
    values = robot.joint_array(configurations)
    if len(values) < 2:
        raise InputError("a motion needs at least two configurations", key="configurations")
    q = np.asarray(configurations, np.float64)
    setup = _setup(world, group, robot)
    kinematics = (*setup.kinematics, base)
    count = len(setup.pairs[0])
    calls, posed, segments, done = 0, np.zeros(2), [], 0
    for segment in range(len(values) - 1):
        t, given, steps = np.zeros(count), np.full(count, np.nan), np.zeros(count, np.int64)
        posed[1] = -1.0
        while True:
            code, k, bound = _advance(kinematics, setup.chain, setup.pairs, setup.pieces,
                                      values[segment], values[segment + 1], tolerance,
                                      margin, t, given, steps, posed, times)
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
    kinematics = (*_kinematics(robot), np.eye(4) if base is None else np.asarray(base, float))
    chain = _chain(robot)
    return _motions(kinematics, chain, values[0], values[1], float(t), chain[0])


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
            np.array([j.kind in ("revolute", "continuous") for j in joints]),
            np.array([j.kind == "prismatic" for j in joints]),
            np.array([np.linalg.norm(j.origin[:3, 3]) for j in joints]),
            np.array([frames[j.parent] for j in joints], np.int64),
            np.array([j.origin for j in joints]).reshape(-1, 4, 4),
            np.array([j.axis for j in joints]).reshape(-1, 3))
    return _CHAINS[robot]


@_jit
def _chain_levers(chain, v_a, v_b):
    """Per segment: ``lever`` (F, J), the chain bound of the distance of each
    frame's link from each turning joint's origin above it (1 for a sliding
    joint, 0 off its path), and ``relative`` (F, J), how fast the joints below
    ``j`` can move the link relative to ``j`` (the chain bounds times the joint
    steps)."""
    radius, above, below, turning, sliding, offset = chain[2], chain[3], chain[4], chain[5], \
        chain[6], chain[7]
    count, joints = above.shape
    lever, relative = np.zeros((count, joints)), np.zeros((count, joints))
    for f in range(count):
        for j in range(joints):
            if not above[f, j]:
                continue
            if sliding[j]:
                lever[f, j] = 1.0
            elif turning[j]:
                reach = radius[f]
                for k in range(joints):
                    if below[f, j, k]:
                        reach += offset[k]
                        if sliding[k]:
                            reach += max(abs(v_a[k]), abs(v_b[k]))
                lever[f, j] = reach
        for j in range(joints):
            for k in range(joints):
                if below[f, j, k]:
                    relative[f, j] += lever[f, k] * abs(v_b[k] - v_a[k])
    return lever, relative


@_jit
def _link_motion(chain, lever, relative, v_a, v_b, frames, link, other, remaining, box, reach):
    """``(D, S, A)`` of the link of frame ``link`` over the ``remaining`` part of the
    segment,
    ``frames`` (F, 4, 4) where every frame stands now, leaving out the joints
    above frame ``other`` too (-1: none): the speed bound ``D`` (step 1 of the
    module docstring), the greatest speed ``S`` of the link's box now, and a
    bound ``A`` of how fast any point's speed can grow (see :func:`_closing`).

    With the joints' rates ``dq_j`` (per unit of ``t``), axes ``u_j`` and
    origins ``o_j``, a point ``p`` of the link moves at
    ``sum_j dq_j u_j x (p - o_j)`` (turning) plus ``dq_j u_j`` (sliding): a
    rigid velocity field, greatest at a corner of the link's box. Its rate of
    change is at most ``sum_j |dq_j| (2 w_j R_j + sum_(k >= j) |dq_k| r_k)``,
    ``w_j`` the rates of the turning joints above ``j`` (how fast ``u_j``
    turns), ``R_j`` the chain bound of ``|p - o_j|`` and ``r_k`` the lever of
    ``D`` (1 for a sliding joint). ``box`` (8, 3) and ``reach`` (J,) are scratch.
    """
    corners, above, below = chain[1], chain[3], chain[4]
    turning, sliding, parent, origin, axis = chain[5], chain[6], chain[8], chain[9], chain[10]
    pose = frames[link]
    for c in range(8):
        for r in range(3):
            box[c, r] = pose[r, 0] * corners[link, c, 0] + pose[r, 1] * corners[link, c, 1] \
                + pose[r, 2] * corners[link, c, 2] + pose[r, 3]
    joints = above.shape[1]
    # the velocity field p -> spin x p + shift; reach[j] is r_j over the rest of the segment
    sx, sy, sz, hx, hy, hz = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    speed = 0.0
    for j in range(joints):
        rate = v_b[j] - v_a[j]
        reach[j] = 0.0
        if not above[link, j] or rate == 0.0 or (other >= 0 and above[other, j]):
            continue
        up, o = frames[parent[j]], origin[j]
        # the joint's axis where it stands: its origin p and unit direction d
        px = up[0, 0] * o[0, 3] + up[0, 1] * o[1, 3] + up[0, 2] * o[2, 3] + up[0, 3]
        py = up[1, 0] * o[0, 3] + up[1, 1] * o[1, 3] + up[1, 2] * o[2, 3] + up[1, 3]
        pz = up[2, 0] * o[0, 3] + up[2, 1] * o[1, 3] + up[2, 2] * o[2, 3] + up[2, 3]
        dx, dy, dz = 0.0, 0.0, 0.0
        for m in range(3):
            local = o[m, 0] * axis[j, 0] + o[m, 1] * axis[j, 1] + o[m, 2] * axis[j, 2]
            dx += up[0, m] * local
            dy += up[1, m] * local
            dz += up[2, m] * local
        if sliding[j]:
            reach[j] = 1.0
            hx, hy, hz = hx + rate * dx, hy + rate * dy, hz + rate * dz
        elif turning[j]:
            far = 0.0
            for c in range(8):
                ex, ey, ez = box[c, 0] - px, box[c, 1] - py, box[c, 2] - pz
                along = ex * dx + ey * dy + ez * dz
                far = max(far, ex * ex + ey * ey + ez * ez - along * along)
            reach[j] = min(lever[link, j], np.sqrt(far) + relative[link, j] * remaining)
            sx, sy, sz = sx + rate * dx, sy + rate * dy, sz + rate * dz
            # u x (p - o) = u x p - u x o
            hx -= rate * (dy * pz - dz * py)
            hy -= rate * (dz * px - dx * pz)
            hz -= rate * (dx * py - dy * px)
        speed += reach[j] * abs(rate)
    fastest = 0.0
    for c in range(8):
        x, y, z = box[c, 0], box[c, 1], box[c, 2]
        vx = sy * z - sz * y + hx
        vy = sz * x - sx * z + hy
        vz = sx * y - sy * x + hz
        fastest = max(fastest, vx * vx + vy * vy + vz * vz)
    growth = 0.0
    for j in range(joints):
        if reach[j] == 0.0:
            continue
        turns, onward = 0.0, reach[j] * abs(v_b[j] - v_a[j])
        for k in range(joints):
            if reach[k] == 0.0:
                continue
            if below[link, k, j] and turning[k]:
                turns += abs(v_b[k] - v_a[k])
            elif below[link, j, k]:
                onward += reach[k] * abs(v_b[k] - v_a[k])
        growth += abs(v_b[j] - v_a[j]) * (2.0 * turns * lever[link, j] + onward) if turning[j] \
            else abs(v_b[j] - v_a[j]) * turns
    return speed, np.sqrt(fastest), growth


@_jit
def _closing(speed, now, growth, clearance):
    """How far the pair can go (a fraction of the segment) before it could close
    ``clearance``: it closes at most ``min(D s, S s + A s^2 / 2)`` over ``s``."""
    return max(clearance / speed, 2.0 * clearance / (now + np.sqrt(now * now + 2.0 * growth
                                                                   * clearance)))


@_jit
def _frames_at(kinematics, v_a, v_b, t, values):
    """Every frame's pose (F, 4, 4) at time ``t`` of the segment."""
    terms, kinds, links, frame_index, base = kinematics
    for j in range(len(v_a)):
        values[0, j] = v_a[j] + t * (v_b[j] - v_a[j])
    return chain_poses(values, terms, kinds, links, base, frame_index)[0]


@_jit
def _motions(kinematics, chain, v_a, v_b, t, chosen):
    """``(D, S, A)`` of the frames ``chosen`` from time ``t`` of the segment from
    ``v_a`` to ``v_b``: see :func:`speed_bounds`."""
    lever, relative = _chain_levers(chain, v_a, v_b)
    frames = _frames_at(kinematics, v_a, v_b, t, np.empty((1, len(v_a))))
    out = np.empty((len(chosen), 3))
    box, reach = np.empty((8, 3)), np.empty(len(v_a))
    for k in range(len(chosen)):
        out[k] = _link_motion(chain, lever, relative, v_a, v_b, frames, chosen[k], -1, 1.0 - t,
                              box, reach)
    return out


@_jit
def _fastest(kinematics, chain, values, frame):
    """``(S,)`` a bound of the speed of ``frame``'s origin (per unit of each
    segment's parameter) all along each segment between rows of ``values``."""
    out = np.empty(len(values) - 1)
    chosen = np.array([frame])
    for s in range(len(out)):
        speed, now, growth = _motions(kinematics, chain, values[s], values[s + 1], 0.0,
                                      chosen)[0]
        out[s] = min(speed, now + growth)
    return out


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
    return _fastest(kinematics, chain, values, f) + \
        reach * np.abs(np.diff(values[:, turning], axis=0)).sum(axis=1)


@_jit
def _posed(posed, times, t):
    """Count (and record, while ``times`` has room) a configuration posed at time
    ``t``, unless it is the one posed last (a call after :data:`_ASK` starts there)."""
    if posed[0] > 0 and posed[1] == t:
        return
    at = int(posed[0])
    if at < len(times):
        times[at] = t
    posed[0], posed[1] = at + 1, t


@_jit
def _advance(kinematics, chain, pairs, pieces, v_a, v_b, tolerance, margin, t, given, steps,
             posed, times):
    """Conservative advancement of every pair over the segment between full joint
    values ``v_a`` and ``v_b``, in time order; ``(code, pair, clearance)``.

    ``t`` (P,) is how far each pair is proven free (1: all of it), ``given`` (P,)
    exact clearances the caller supplies for the pairs it was asked about (NaN:
    none), ``steps`` (P,) each pair's advancement steps; all three carry over
    when the caller comes back after :data:`_ASK`. ``posed[0]`` counts the
    configurations posed (forward kinematics), ``posed[1]`` is the last one's
    time; the first ``len(times)`` times are written into ``times``. Codes:
    :data:`_FREE`; :data:`_CONTACT`, :data:`_REFUSED` (``margin > 0``) or :data:`_GRAZING` for
    the pair at ``t[pair]``; :data:`_ASK`, the caller is to put the exact
    clearance of ``pair`` at ``t[pair]`` into ``given`` and call again.
    """
    a_of, b_of, object_a, object_b, standing, exact, boxes = pairs
    flat = np.zeros(len(boxes))
    points, pads, piece_starts, centre, radius, owned = pieces
    lever, relative = _chain_levers(chain, v_a, v_b)
    values = np.empty((1, len(v_a)))
    frames, frames_at = _frames_at(kinematics, v_a, v_b, t.min(), values), t.min()
    _posed(posed, times, frames_at)
    box, reach = np.empty((8, 3)), np.empty(len(v_a))
    alone, alone_at = np.empty((len(chain[2]), 3)), np.full(len(chain[2]), -1.0)
    while True:
        k = -1
        for p in range(len(t)):                    # the pair furthest behind
            if t[p] < 1.0 and (k < 0 or t[p] < t[k]):
                k = p
        if k < 0:
            return _FREE, -1, 0.0
        now = t[k]
        if now != frames_at:
            frames, frames_at = _frames_at(kinematics, v_a, v_b, now, values), now
            _posed(posed, times, now)
        a, b = a_of[k], b_of[k]
        pose_a = frames[a]
        pose_b = frames[b] if b >= 0 else standing[k]
        remaining = 1.0 - now
        if b >= 0:
            speed, fastest, growth = _link_motion(chain, lever, relative, v_a, v_b, frames, a,
                                                  b, remaining, box, reach)
            more = _link_motion(chain, lever, relative, v_a, v_b, frames, b, a, remaining, box,
                                reach)
            speed, fastest, growth = speed + more[0], fastest + more[1], growth + more[2]
        else:                  # a link against standing objects: one motion for them all
            if alone_at[a] != now:
                alone[a] = _link_motion(chain, lever, relative, v_a, v_b, frames, a, -1,
                                        remaining, box, reach)
                alone_at[a] = now
            speed, fastest, growth = alone[a, 0], alone[a, 1], alone[a, 2]
        # the clearance that proves the rest of the segment (at most D times it)
        need = min(speed * remaining, (fastest + 0.5 * growth * remaining) * remaining) + margin
        if given[k] == given[k]:
            lower = upper = given[k]
            given[k] = np.nan
            known = True
        else:
            i, j = object_a[k], object_b[k]
            lower, upper = bounds(boxes, flat, 8 * i, 8 * i + 8, pose_a, 8 * j, 8 * j + 8,
                                  pose_b, need, ITERATIONS)
            if lower < need:          # the pieces lie inside the boxes: never nearer
                hull, upper = body_bounds(points, pads, piece_starts, centre, radius, owned,
                                          i, pose_a, j, pose_b, need, ITERATIONS)
                lower = max(lower, hull)
            known = exact[k]
        if lower >= need:
            t[k] = 1.0
            continue
        steps[k] += 1
        if steps[k] > MAX_STEPS:
            return _GRAZING, k, lower
        if margin > 0.0:
            if lower < 2.0 * margin:
                return _REFUSED, k, lower
            t[k] = min(now + _closing(speed, fastest, growth, lower - margin), 1.0)
        elif lower >= tolerance or (known and upper >= tolerance and lower > 0.0):
            t[k] = min(now + _closing(speed, fastest, growth, lower), 1.0)
        elif known and upper < tolerance:
            return _CONTACT, k, upper
        else:
            return _ASK, k, lower
