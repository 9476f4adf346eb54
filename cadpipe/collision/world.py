"""The collision world: named objects, allowed pairs, and the checks over them.

:meth:`CollisionWorld.check` follows the source's order. Pairs within one group
(a robot's links) are self-collision pairs and are decided first; with
``stop_after_self=True`` a self-collision ends the check, as the source does.
Every pair not allowed then goes down the same funnel, each stage able to prove
"apart", cheapest first: sweep-and-prune on AABBs, 18-DOPs, OBBs, optionally
the source's separation certificate, and finally the exact narrow phase. The report records
which stage decided each pair.

A robot checked along a path goes through the same funnel for all its
configurations at once: :meth:`CollisionWorld.check_path` (and
:meth:`~CollisionWorld.check_many` for any objects) poses every configuration
in one vectorized pass, runs each bounding-volume stage over all
(configuration, pair) entries together and hands the narrow phase whole
batches per pair. :meth:`~CollisionWorld.check` is the batch of one.
"""

import operator
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from cadpipe import _deprecated
from cadpipe.errors import InputError
from cadpipe.solids.transform import is_rigid
from cadpipe.collision import bounds
from cadpipe.collision import narrow
from cadpipe.collision.bodies import as_body

#: stages that can decide a pair, in the order a pair meets them
STAGES = ("allowed", "aabb", "kdop", "obb", "certificate", "fcl", "containment", "analytic",
          "not checked")
_CODE = {name: i for i, name in enumerate(STAGES)}
#: configurations per pass of the broad phase (bounds the entry arrays' memory)
CONFIGURATION_CHUNK = 2048


def _expand(values, where, fill):
    """``values`` placed at the True positions of ``where``, ``fill`` elsewhere."""
    out = np.full(len(where), fill, values.dtype)
    out[where] = values
    return out


def _record(target, config, k, value):
    """Write ``value`` for entries ``(config, k)`` of a (C, P) array; configuration -1
    (a pair of standing objects) stands for every row."""
    if len(target) == 1:                # one configuration: every entry is in row 0
        target[0, k] = value
        return
    every = config < 0
    target[:, k[every]] = value
    target[config[~every], k[~every]] = value


def as_pose(transform, name):
    """A rigid 4x4 float matrix (the identity for None), or :class:`InputError`
    naming the object."""
    if transform is None:
        return np.eye(4)
    return as_poses(transform, name, shape=(4, 4))


def as_poses(transforms, name, shape=None):
    """Rigid 4x4 float matrices ``(..., 4, 4)`` (exactly ``shape`` when given), or
    :class:`InputError` naming the object."""
    try:
        m = np.array(transforms, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{name}: transform must be a 4x4 matrix of numbers") from None
    if m.shape[-2:] != (4, 4) or (shape is not None and m.shape != shape):
        raise InputError(f"{name}: transform must be a 4x4 matrix, got shape {m.shape}")
    if not np.isfinite(m).all():
        raise InputError(f"{name}: transform has NaN or infinite entries; pass a finite matrix")
    if not is_rigid(m):
        raise InputError(f"{name}: transform must be rigid (a rotation and a translation); "
                         "scale or mirror the mesh itself instead")
    return m


@dataclass(frozen=True)
class PairResult:
    """How one pair was decided: the ``detail`` of a collision entry."""

    a: str
    b: str
    colliding: bool
    decided_by: str
    phase: str                  # "self" (same group) or "world"
    certificate: object = None  # a Certificate when decided_by == "certificate"

    def to_dict(self):
        return {"a": self.a, "b": self.b, "colliding": self.colliding,
                "decided_by": self.decided_by, "phase": self.phase}


@dataclass(frozen=True)
class Clearance:
    """Result of :meth:`CollisionWorld.distance`: 0 (and no points) when touching."""

    distance: float
    point_a: np.ndarray
    point_b: np.ndarray
    colliding: bool
    decided_by: str


class CollisionReport:
    """The outcome of :meth:`CollisionWorld.check`.

    ``collisions`` lists ``(name_a, name_b, detail)`` for touching pairs:
    self-collisions first, then the rest, each in the order objects were added.
    ``pairs`` holds a :class:`PairResult` for every pair, allowed ones included.
    """

    def __init__(self, names, first, second, same, codes, colliding, allowed_reasons,
                 certificates, stopped_after_self):
        self._names = names
        self._first, self._second, self._same = first, second, same
        self._codes, self._colliding = codes, colliding
        self._allowed_reasons = allowed_reasons
        self._certificates = certificates
        self.stopped_after_self = stopped_after_self

    def _result(self, k):
        return PairResult(self._names[self._first[k]], self._names[self._second[k]],
                          bool(self._colliding[k]), STAGES[self._codes[k]],
                          "self" if self._same[k] else "world", self._certificates.get(k))

    @cached_property
    def pairs(self):
        return [self._result(k) for k in self._order(np.arange(len(self._codes)))]

    @cached_property
    def collisions(self):
        hits = self._order(self._colliding.nonzero()[0])
        return [(r.a, r.b, r) for r in map(self._result, hits)]

    def _order(self, ks):
        """Self pairs first, then by the objects' insertion order."""
        return ks[np.lexsort((self._second[ks], self._first[ks], ~self._same[ks]))]

    @property
    def allowed(self):
        """``(name_a, name_b, reason)`` of the pairs skipped as allowed."""
        return [(self._names[self._first[k]], self._names[self._second[k]],
                 self._allowed_reasons[k]) for k in np.flatnonzero(self._codes == _CODE["allowed"])]

    def counts(self):
        """How many pairs each stage decided."""
        found = np.bincount(self._codes, minlength=len(STAGES))
        return {name: int(n) for name, n in zip(STAGES, found) if n}

    def __bool__(self):
        return bool(self.collisions)

    def to_dict(self):
        return {"collisions": [{"a": a, "b": b, "decided_by": d.decided_by, "phase": d.phase}
                               for a, b, d in self.collisions],
                "stopped_after_self": self.stopped_after_self,
                "counts": self.counts(),
                "allowed": [{"a": a, "b": b, "reason": r} for a, b, r in self.allowed],
                "pairs": [p.to_dict() for p in self.pairs]}


class CollisionReports(Sequence):
    """The outcome of :meth:`CollisionWorld.check_path` and
    :meth:`CollisionWorld.check_many`: one :class:`CollisionReport` per
    configuration (built when asked for), and the answers as arrays.

    ``colliding[c]`` says whether configuration ``c`` has any collision;
    ``pair_colliding`` and ``decided_by`` hold every pair's answer and stage
    code (an index into :data:`STAGES`) per configuration, pairs in
    ``np.triu_indices`` order of the objects; ``stopped_after_self[c]`` is
    :attr:`CollisionReport.stopped_after_self` of configuration ``c``.
    """

    def __init__(self, names, first, second, same, codes, colliding, allowed_reasons,
                 certificates, stopped_after_self):
        self._names, self._first, self._second, self._same = names, first, second, same
        self.decided_by, self.pair_colliding = codes, colliding
        self._allowed_reasons = allowed_reasons
        self._certificates = certificates          # (configuration or -1 for all, pair)
        self.stopped_after_self = stopped_after_self

    def __len__(self):
        return len(self.decided_by)

    def __getitem__(self, c):
        if isinstance(c, slice):
            return [self[k] for k in range(*c.indices(len(self)))]
        c = operator.index(c)
        if not -len(self) <= c < len(self):
            raise IndexError(f"configuration {c} out of range for {len(self)}")
        c %= len(self)
        certificates = {k: cert for (at, k), cert in self._certificates.items() if at in (-1, c)}
        return CollisionReport(self._names, self._first, self._second, self._same,
                               self.decided_by[c], self.pair_colliding[c], self._allowed_reasons,
                               certificates, bool(self.stopped_after_self[c]))

    @cached_property
    def colliding(self):
        """(C,) bool: whether each configuration has any collision."""
        return self.pair_colliding.any(axis=1)

    def counts(self):
        """How many (configuration, pair) entries each stage decided."""
        found = np.bincount(self.decided_by.ravel(), minlength=len(STAGES))
        return {name: int(n) for name, n in zip(STAGES, found) if n}


class CollisionWorld:
    """Named meshes, pipes and primitives, placed by rigid transforms.

    Examples
    --------
    >>> world = CollisionWorld()
    >>> world.add("link1", mesh, transform=T1, group="robot")      # doctest: +SKIP
    >>> world.add("weld_pipe", pipe)                                # doctest: +SKIP
    >>> world.allow("link1", "link2", reason="adjacent")            # doctest: +SKIP
    >>> world.check().collisions                                    # doctest: +SKIP
    """

    def __init__(self):
        self._names, self._index, self._bodies, self._groups = [], {}, [], []
        self._poses = np.zeros((0, 4, 4))
        self._versions = np.zeros(0, np.int64)
        self._stale = np.zeros(0, bool)     # moved since their bounds were placed
        self._allowed = {}                 # (i, j) with i < j -> reason
        self._robots = {}                  # group -> (robot, base pose, object ids of links)
        self._cache = {}                   # (i, j, certify) -> (versions, code, colliding, cert)
        self._supports = None              # bounds.Supports of all objects, rebuilt on add()
        self._placed = None                # world 18-DOP, OBB centre and axes per object
        self._pair_table = None            # pairs, self-pair and allowed masks
        self._reasons = {}                 # allowed pair index -> reason

    # -- contents -------------------------------------------------------------
    def add(self, name, obj, transform=None, group=None):
        """Add ``obj`` (a Mesh, Pipe, Box, Sphere or Capsule) under a new ``name``.

        Objects sharing a ``group`` are checked against each other as
        self-collision pairs; every object is checked against every other.
        """
        if not isinstance(name, str) or not name:
            raise InputError(f"object name must be a non-empty string, got {name!r}")
        if name in self._index:
            raise InputError(f"{name}: an object of that name is already in the world; "
                             "use set_pose() to move it or pick another name")
        pose = as_pose(transform, name)
        body = as_body(obj, name)
        self._index[name] = len(self._names)
        self._names.append(name)
        self._bodies.append(body)
        self._groups.append(None if group is None else str(group))
        self._poses = np.concatenate([self._poses, pose[None]])
        self._versions = np.append(self._versions, 0)
        self._stale = np.append(self._stale, True)
        self._supports = self._placed = self._pair_table = None
        return self

    def _find(self, name):
        try:
            return self._index[name]
        except (KeyError, TypeError):
            known = ", ".join(self._names) or "none yet"
            raise InputError(f"unknown object {name!r}; objects in the world: {known}") from None

    @property
    def names(self):
        return tuple(self._names)

    def group(self, name):
        return self._groups[self._find(name)]

    def pose(self, name):
        return self._poses[self._find(name)].copy()

    def set_pose(self, name, transform):
        """Move object ``name`` to a new rigid 4x4 ``transform``."""
        i = self._find(name)
        self._moved([i], as_pose(transform, name)[None])

    def _moved(self, ids, poses):
        self._poses[ids] = poses
        self._versions[ids] += 1
        self._stale[ids] = True

    def allow(self, a, b, reason="allowed by user"):
        """Never report the pair ``a``, ``b`` (e.g. links joined by a joint)."""
        i, j = sorted((self._find(a), self._find(b)))
        if i == j:
            raise InputError(f"allow({a!r}, {b!r}): an object cannot collide with itself")
        self._allowed[(i, j)] = str(reason)
        self._pair_table = None

    @property
    def allowed(self):
        """``(name_a, name_b, reason)`` for every allowed pair (a list, as
        :attr:`CollisionReport.allowed`)."""
        return _deprecated.Listing([(self._names[i], self._names[j], r)
                                    for (i, j), r in sorted(self._allowed.items())],
                                   "CollisionWorld.allowed")

    # -- robots ---------------------------------------------------------------
    def add_robot(self, robot, joints=None, transform=None, group=None):
        """Add each link of a :class:`~cadpipe.collision.Robot` with geometry, posed by
        ``joints``; the robot's allowed pairs (adjacent links, SRDF) come along.

        Links are named by their link names, in group ``group`` (default: the
        robot's name), so :meth:`set_joints` and :meth:`check_path` can move
        them later.
        """
        group = robot.name if group is None else str(group)
        if group in self._robots:
            raise InputError(f"a robot with group {group!r} is already in the world; "
                             "pass another group=")
        base = as_pose(transform, f"robot {robot.name}")
        for link, pose in robot.link_poses(joints, base).items():
            self.add(link, robot.link_meshes[link], transform=pose, group=group)
        for a, b, reason in robot.allowed_pairs:
            self.allow(a, b, reason)
        self._robots[group] = (robot, base, np.array([self._index[k] for k in robot.link_meshes]))
        return self

    def _robot(self, group):
        if group not in self._robots:
            raise InputError(f"no robot in group {group!r}; robots: {', '.join(self._robots)}")
        return self._robots[group]

    def set_joints(self, group, joints):
        """Re-pose the links of the robot added as ``group`` (one configuration: a
        sequence over ``robot.actuated`` or a mapping by joint name)."""
        robot, base, ids = self._robot(group)
        self._moved(ids, robot.link_poses_at(joints, base))

    # -- bounding volumes -------------------------------------------------------
    def _placed_bounds(self):
        """World 18-DOP (its first three slabs are the AABB), OBB centre and OBB axes of
        every object where it stands; objects moved since the last call are placed
        again."""
        if self._supports is None:
            self._supports = bounds.Supports([b.support for b in self._bodies],
                                             [b.obb for b in self._bodies])
            n = len(self._bodies)
            self._placed = (np.zeros((n, 2, 9)), np.zeros((n, 3)), np.zeros((n, 3, 3)))
            self._stale[:] = True
        if self._stale.any():
            ids = self._stale.nonzero()[0]
            for target, value in zip(self._placed, self._supports.place(
                    ids, self._poses[ids, :3, :3], self._poses[ids, :3, 3])):
                target[ids] = value
            self._stale[:] = False
        return self._placed

    def bounds(self, name):
        """The world AABB of ``name`` as a (2, 3) array."""
        i = self._find(name)
        return self._placed_bounds()[0][i, :, :3].copy()

    # -- checks ---------------------------------------------------------------
    def _pairs(self):
        """Every pair (i < j) in ``np.triu_indices`` order, whether it is a self pair,
        and the allowed mask; cached until objects change."""
        if self._pair_table is None:
            n = len(self._names)
            first, second = np.triu_indices(n, k=1)
            ids = {g: k for k, g in enumerate(dict.fromkeys(self._groups))}
            groups = np.array([-1 if g is None else ids[g] for g in self._groups], np.int64)
            same = (groups[first] == groups[second]) & (groups[first] != -1)
            allowed = np.zeros(len(first), bool)
            for i, j in self._allowed:
                allowed[(i * (2 * n - i - 1)) // 2 + j - i - 1] = True
            self._pair_table = first, second, same, allowed
            self._reasons = {k: self._allowed[(first[k], second[k])]
                             for k in np.flatnonzero(allowed)}
        return self._pair_table

    def check(self, stop_after_self=False, certify=False):
        """Decide every pair; returns a :class:`CollisionReport`.

        Parameters
        ----------
        stop_after_self : bool
            As the source: if any self-collision is found, report it and leave
            the other pairs ``"not checked"`` (the report's
            ``stopped_after_self`` says so).
        certify : bool
            Before the exact test, try the source's separation certificate on
            pairs whose boxes overlap; a pair it separates is decided by
            ``"certificate"`` and carries the certificate.
        """
        return self._evaluate(np.zeros(0, np.int64), np.zeros((1, 0, 4, 4)), stop_after_self,
                              certify)[0]

    def check_path(self, group, configurations, stop_after_self=False, certify=False):
        """:meth:`check` at each of many joint configurations of the robot ``group``,
        in one vectorized pass; returns :class:`CollisionReports`.

        ``configurations`` is a ``(C, A)`` array over ``robot.actuated`` (a
        trajectory's waypoints, say). Each configuration is checked where it
        stands -- the motion between them is not swept -- and its report is
        the one :meth:`set_joints` then :meth:`check` would give. The robot
        stays where :meth:`set_joints` last put it.
        """
        robot, base, ids = self._robot(group)
        poses = robot.link_pose_array(configurations, base)
        return self._evaluate(ids, poses, stop_after_self, certify)

    def check_many(self, poses, stop_after_self=False, certify=False):
        """:meth:`check` with objects placed at each of C poses, in one vectorized pass.

        ``poses`` maps object names to ``(C, 4, 4)`` rigid transforms (the same C
        for all); objects not named stay where they are. Returns
        :class:`CollisionReports`, one report per configuration, each the one
        :meth:`set_pose` then :meth:`check` would give.
        """
        if not hasattr(poses, "items") or not poses:
            raise InputError("check_many(poses): pass a mapping of object names to (C, 4, 4) "
                             "pose arrays")
        ids = np.array([self._find(name) for name in poses])
        stacked = [as_poses(p, name) for name, p in poses.items()]
        if any(p.ndim != 3 for p in stacked) or len({len(p) for p in stacked}) != 1:
            raise InputError("check_many(poses): every object needs a (C, 4, 4) array with the "
                             "same C, got shapes " + ", ".join(str(p.shape) for p in stacked))
        return self._evaluate(ids, np.stack(stacked, axis=1), stop_after_self, certify)

    def _evaluate(self, ids, poses, stop_after_self, certify):
        """Every pair in each of C configurations: objects ``ids`` at ``poses``
        (C, m, 4, 4), all others where they stand. Configurations go through in
        chunks that keep the entry arrays small."""
        first, second, same, allowed = self._pairs()
        count = len(poses)
        codes = np.full((count, len(first)), _CODE["aabb"], np.int8)
        codes[:, allowed] = _CODE["allowed"]
        colliding = np.zeros(codes.shape, bool)
        stopped = np.zeros(count, bool)
        certificates = {}
        if len(self._names) >= 2:
            for start in range(0, count, CONFIGURATION_CHUNK):
                part = slice(start, start + CONFIGURATION_CHUNK)
                entries = self._broad_phase(ids, poses[part], codes[part])
                found = self._narrow_phase(entries, codes[part], colliding[part],
                                           stopped[part], stop_after_self, certify)
                certificates.update({(c if c < 0 else c + start, k): cert
                                     for (c, k), cert in found.items()})
        return CollisionReports(tuple(self._names), first, second, same, codes, colliding,
                                self._reasons, certificates, stopped)

    def _broad_phase(self, ids, poses, codes):
        """Run the bounding-volume stages over every (configuration, pair) entry,
        recording the pairs they decide in ``codes``; returns the entries left as
        ``(configuration, pair, pose_a, pose_b)`` arrays.

        Objects are placed in slots: slot ``i < n`` is object ``i`` where it
        stands, slot ``n + c m + r`` is object ``ids[r]`` in configuration ``c``.
        A pair of standing objects is one entry (configuration -1: all of them);
        a pair with a moving object gets one entry per configuration.
        """
        n, (count, m) = len(self._names), poses.shape[:2]
        first, second, same, allowed = self._pairs()
        kdop, centre, axes = self._placed_bounds()
        standing = ~allowed
        if m:
            moving = np.zeros(n, bool)
            moving[ids] = True
            standing = standing & ~moving[first] & ~moving[second]
        near = bounds.overlapping_pairs(kdop[:, 0, :3], kdop[:, 1, :3], first, second)
        k = (standing & near).nonzero()[0]
        config, slot_a, slot_b = np.full(len(k), -1), first[k], second[k]
        objects, slot_poses = np.arange(n), self._poses
        if m:
            placed_ids = np.tile(ids, count)
            placed = self._supports.place(placed_ids, poses[..., :3, :3].reshape(-1, 3, 3),
                                          poses[..., :3, 3].reshape(-1, 3))
            kdop, centre, axes = (np.concatenate([a, b]) for a, b in zip(self._placed, placed))
            objects, slot_poses = np.r_[objects, placed_ids], np.concatenate(
                [self._poses, poses.reshape(-1, 4, 4)])
            rank = np.zeros(n, np.int64)
            rank[ids] = np.arange(m)
            pairs = np.flatnonzero(~allowed & (moving[first] | moving[second]))
            c, kk = np.repeat(np.arange(count), len(pairs)), np.tile(pairs, count)
            a, b = first[kk], second[kk]
            a = np.where(moving[a], n + c * m + rank[a], a)
            b = np.where(moving[b], n + c * m + rank[b], b)
            box_a, box_b = kdop[a, :, :3], kdop[b, :, :3]
            near = bounds.boxes_overlap(box_a[:, 0], box_a[:, 1], box_b[:, 0], box_b[:, 1])
            config, k = np.r_[config, c[near]], np.r_[k, kk[near]]
            slot_a, slot_b = np.r_[slot_a, a[near]], np.r_[slot_b, b[near]]
        dop_a, dop_b = kdop[slot_a], kdop[slot_b]
        keep = bounds.boxes_overlap(dop_a[:, 0], dop_a[:, 1], dop_b[:, 0], dop_b[:, 1])
        _record(codes, config[~keep], k[~keep], _CODE["kdop"])
        config, k, slot_a, slot_b = config[keep], k[keep], slot_a[keep], slot_b[keep]
        half = self._supports.half
        keep = bounds.obb_overlap(centre[slot_a], axes[slot_a], half[objects[slot_a]],
                                  centre[slot_b], axes[slot_b], half[objects[slot_b]])
        _record(codes, config[~keep], k[~keep], _CODE["obb"])
        return config[keep], k[keep], slot_poses[slot_a[keep]], slot_poses[slot_b[keep]]

    def _narrow_phase(self, entries, codes, colliding, stopped, stop_after_self, certify):
        """Decide the entries the bounding volumes left, self pairs first; returns
        the certificates found, by (configuration, pair)."""
        config, k, poses_a, poses_b = entries
        first, second, same, allowed = self._pairs()
        certificates = {}
        own = same[k]
        self._decide(config, k, poses_a, poses_b, own.nonzero()[0], codes, colliding,
                     certificates, certify)
        world = (~own).nonzero()[0]
        if stop_after_self:
            stopped[:] = colliding[:, same].any(axis=1)
            at = config[world]
            world = world[np.where(at < 0, not stopped.all(), ~stopped[at])]
        self._decide(config, k, poses_a, poses_b, world, codes, colliding, certificates,
                     certify)
        if stopped.any():
            rest = ~same & ~allowed
            codes[np.ix_(stopped, rest)] = _CODE["not checked"]
            colliding[np.ix_(stopped, rest)] = False
        return certificates

    def _decide(self, config, k, poses_a, poses_b, chosen, codes, colliding, certificates,
                certify):
        """The exact answer for entries ``chosen``: a pair of standing objects on its
        own (its answer kept while neither moves), the others one batch per pair."""
        first, second, _, _ = self._pairs()
        moving = config[chosen] >= 0
        for e in chosen[~moving]:
            pair = k[e]
            codes[:, pair], colliding[:, pair], cert = self._standing(
                first[pair], second[pair], poses_a[e], poses_b[e], certify)
            if cert is not None:
                certificates[(-1, pair)] = cert
        batch = chosen[moving]
        if not batch.size:
            return
        batch = batch[np.argsort(k[batch], kind="stable")]
        pairs, starts = np.unique(k[batch], return_index=True)
        for pair, at in zip(pairs, np.split(batch, starts[1:])):
            code, touching, certs = self._settle(first[pair], second[pair], poses_a[at],
                                                 poses_b[at], certify)
            codes[config[at], pair], colliding[config[at], pair] = code, touching
            certificates.update({(config[at[e]], pair): cert for e, cert in certs.items()})

    def _standing(self, i, j, pose_a, pose_b, certify):
        """``(code, colliding, certificate)`` of a pair of standing objects, reused
        while neither has moved."""
        key, versions = (i, j, certify), (self._versions[i], self._versions[j])
        cached = self._cache.get(key)
        if cached is None or cached[0] != versions:
            code, touching, certs = self._settle(i, j, pose_a[None], pose_b[None], certify)
            cached = self._cache[key] = (versions, code[0], touching[0], certs.get(0))
        return cached[1:]

    def _settle(self, i, j, poses_a, poses_b, certify):
        """``(codes, touching, certificates by entry)`` of one pair at E placements:
        the certificate first when asked for, then the exact narrow phase."""
        body_a, body_b = self._bodies[i], self._bodies[j]
        certificates = {}
        if certify:
            from cadpipe.collision.certificate import find_certificate

            for e in range(len(poses_a)):
                cert = find_certificate(body_a, poses_a[e], body_b, poses_b[e],
                                        names=(self._names[i], self._names[j]))
                if cert is not None:
                    certificates[e] = cert
        if certificates:
            todo = np.ones(len(poses_a), bool)
            todo[list(certificates)] = False
            poses_a, poses_b = poses_a[todo], poses_b[todo]
        touching, contained = narrow.collide(body_a, poses_a, body_b, poses_b)
        exact = _CODE["analytic" if body_a.kind == body_b.kind == "chain" else "fcl"]
        codes = np.where(contained, _CODE["containment"], exact).astype(np.int8)
        if certificates:
            codes, touching = _expand(codes, todo, _CODE["certificate"]), _expand(touching, todo,
                                                                                  False)
        return codes, touching, certificates

    def distance(self, a, b):
        """Clearance between ``a`` and ``b`` with the closest points (a
        :class:`Clearance`); 0 when they touch or one contains the other."""
        i, j = self._find(a), self._find(b)
        dist, pa, pb, stage = narrow.distance(self._bodies[i], self._poses[i], self._bodies[j],
                                              self._poses[j])
        return Clearance(float(dist), pa, pb, dist <= 0, stage)

    def separate(self, a, b, step_degrees=None):
        """The source's separation certificate for ``a`` and ``b``, or None.

        A returned :class:`~cadpipe.collision.certificate.Certificate` has passed
        its independent verifier: it proves the pair does not touch.
        """
        from cadpipe.collision.certificate import find_certificate

        i, j = self._find(a), self._find(b)
        options = {} if step_degrees is None else {"step_degrees": step_degrees}
        return find_certificate(self._bodies[i], self._poses[i], self._bodies[j],
                                self._poses[j], names=(a, b), **options)

    def inside(self, pipe_name, points):
        """Virtual fixture: which ``(P, 3)`` world points lie inside the pipe (or other
        ball chain) ``pipe_name``, and where the polyline through them first leaves it.

        Returns a :class:`PipeContainment`.
        """
        from cadpipe._validate import as_points
        from cadpipe.collision.fixture import containment

        i = self._find(pipe_name)
        body = self._bodies[i]
        if body.kind != "chain":
            raise InputError(f"inside({pipe_name!r}): that object is a mesh; inside() needs a "
                             "pipe, sphere or capsule (use distance() for meshes)")
        points = as_points(points, "points")
        return containment(body.chain.moved(self._poses[i]), points)
