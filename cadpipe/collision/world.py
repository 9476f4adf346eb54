"""The collision world: a scene of named objects, and a checker that decides its pairs.

Two parts with one job each:

* :class:`Scene` is what is where: named bodies, their groups, rigid poses,
  allowed pairs and the robots that pose links. It changes only by explicit
  calls (``add``, ``allow``, ``set_pose``, ``set_joints``), and each change
  bumps a counter: ``layout_version`` when objects or allowed pairs are added,
  ``pose_versions[i]`` when object ``i`` moves.
* :class:`Checker` decides pairs of a scene. Everything it keeps -- the packed
  bounding volumes, the pair table, each object's placed bounds, each pair's
  last answer -- is stored with the versions it was computed at and reused
  only while they still match, so nothing is invalidated by hand and nothing
  can go stale. A pair whose two objects have not moved since it was decided is
  not decided again: after ``set_joints``, ``check()`` decides the robot's
  pairs and reuses every obstacle-obstacle answer.

:class:`CollisionWorld` is a scene with its checker's queries as methods.

:meth:`CollisionWorld.check` follows the source's order. Pairs within one group
(a robot's links) are self-collision pairs and are decided first; with
``stop_after_self=True`` a self-collision ends the check, as the source does,
and with ``first_hit=True`` the first collision found does. Every pair not
allowed goes down the same funnel, each stage able to prove "apart",
cheapest first: AABBs, 18-DOPs and OBBs (:mod:`cadpipe.collision.funnel`,
compiled), optionally the source's separation certificate, and finally the
exact narrow phase (:mod:`cadpipe.collision.narrow`). The report records which
stage decided each pair.

A robot checked along a path goes through the same funnel for all its
configurations at once: :meth:`CollisionWorld.check_path` (and
:meth:`~CollisionWorld.check_many` for any objects) places every moving object
of every configuration in one kernel call, tests all (configuration, pair)
entries in another and hands the narrow phase whole batches per pair.
"""

import operator
from collections.abc import Sequence
from typing import TYPE_CHECKING
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike

from cadpipe.errors import InputError
from cadpipe.core.kernels import native
from cadpipe.core.transform import as_matrix
from cadpipe.collision import bounds
from cadpipe.collision import funnel
from cadpipe.collision import narrow
from cadpipe.collision import packed
from cadpipe.collision.bodies import as_body

if TYPE_CHECKING:                       # the answer types of the optional queries
    from cadpipe.collision.certificate import Certificate
    from cadpipe.collision.fixture import PipeContainment
    from cadpipe.collision.motion import MotionCheck

#: stages that can decide a pair, in the order a pair meets them
STAGES = ("allowed", "aabb", "kdop", "obb", "hull", "certificate", "fcl", "containment", "analytic",
          "not checked")
_CODE = {name: i for i, name in enumerate(STAGES)}
assert (_CODE["aabb"], _CODE["kdop"], _CODE["obb"], _CODE["hull"]) == \
    (funnel.AABB, funnel.KDOP, funnel.OBB, funnel.HULL)
assert (_CODE["allowed"], _CODE["not checked"]) == (funnel.ALLOWED, funnel.NOT_CHECKED)
assert (_CODE["fcl"], _CODE["containment"], _CODE["analytic"]) == \
    (narrow.FCL, narrow.CONTAINMENT, narrow.ANALYTIC)
#: configurations per pass of the broad phase (bounds the entry arrays' memory)
CONFIGURATION_CHUNK = 2048
#: the first chunk of ``check_path(first_hit=True)``, doubled each pass after it
FIRST_CHUNK = 16


def as_pose(transform, name):
    """A rigid 4x4 float matrix (the identity for None), or :class:`InputError`
    naming the object."""
    if transform is None:
        return np.eye(4)
    return as_poses(transform, name, shape=(4, 4))


def _plain_pose(value):
    """Whether ``value`` is a float64 (4, 4) C-ordered array: what the compiled
    pose kernels take as it is (and check themselves)."""
    return type(value) is np.ndarray and value.shape == (4, 4) and \
        value.dtype == np.float64 and value.flags.c_contiguous


# ``native.set_pose(matrix, poses, versions, i)`` is :meth:`Scene.set_pose` of a (4, 4)
# float64 ``matrix`` in one compiled call: 0 when :func:`as_pose` accepts it (it is then
# written into ``poses[i]`` and ``versions[i]`` counts the move), else what :func:`as_pose`
# would refuse and nothing is written. A pose set per call: 2.5 us through as_pose, 1 us
# there.

#: what ``native.collide_pose`` returns for a pose :func:`as_pose` refuses; it is the
#: compiled ``settle`` (:mod:`cadpipe.collision.narrow`) of objects ``i`` and ``j`` of the
#: packed world at (4, 4) float64 poses, each first checked as :func:`as_pose` checks it,
#: in one call: ``(code, touching)``. Per pose, the two checks as calls of their own cost
#: 1.6 us of the 9 us a pipe-mesh pose took.
_REFUSED = -2
if native.collision_constants()["REFUSED"] != _REFUSED:
    raise ImportError("cadpipe's pose kernels were built with another refusal code than "
                      "cadpipe.collision.world holds")


def as_poses(transforms, name, shape=None):
    """Rigid 4x4 float matrices ``(..., 4, 4)`` (exactly ``shape`` when given), or
    :class:`InputError` naming the object."""
    m = as_matrix(transforms, part=name, stack=True, rigid=True)
    if shape is not None and m.shape != shape:
        raise InputError(f"transform must be a 4x4 matrix, got shape {m.shape}", part=name,
                         key="transform")
    return m


# -- results ------------------------------------------------------------------------
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


@dataclass(frozen=True, eq=False)
class PairTable:
    """Every pair ``i < j`` of a scene's objects, in ``np.triu_indices`` order.

    ``first``, ``second`` (P,) object indices; ``same`` (P,) whether both are in
    one group (a self pair); ``allowed`` (P,) whether the pair is skipped, with
    its reason in ``reasons`` (pair index -> str).
    """

    names: tuple
    first: np.ndarray
    second: np.ndarray
    same: np.ndarray
    allowed: np.ndarray
    reasons: dict = field(default_factory=dict)

    def __len__(self):
        return len(self.first)

    def order(self, ks):
        """Pair indices ``ks`` in report order: self pairs first, then by the
        objects' insertion order."""
        return ks[np.lexsort((self.second[ks], self.first[ks], ~self.same[ks]))]

    def result(self, k, code, colliding, certificate=None):
        return PairResult(self.names[self.first[k]], self.names[self.second[k]],
                          bool(colliding), STAGES[code],
                          "self" if self.same[k] else "world", certificate)

    def allowed_pairs(self):
        return tuple((self.names[self.first[k]], self.names[self.second[k]], self.reasons[k])
                     for k in np.flatnonzero(self.allowed))


def _counts(codes):
    found = np.bincount(np.ravel(codes), minlength=len(STAGES))
    return {name: int(n) for name, n in zip(STAGES, found) if n}


class CollisionReport:
    """The outcome of :meth:`CollisionWorld.check` for one configuration.

    Parameters
    ----------
    table : PairTable
    decided_by : (P,) int8
        Each pair's stage code, an index into :data:`STAGES`.
    colliding : (P,) bool
    certificates : dict
        Pair index -> Certificate, for pairs decided by ``"certificate"``.
    stopped_after_self : bool
        Whether a self-collision ended the check (``stop_after_self=True``).

    ``collisions`` lists ``(name_a, name_b, detail)`` for touching pairs:
    self-collisions first, then the rest, each in the order objects were added.
    ``pairs`` holds a :class:`PairResult` for every pair, allowed ones included.
    """

    def __init__(self, table, decided_by, colliding, certificates, stopped_after_self):
        self.table = table
        self.decided_by, self.pair_colliding = decided_by, colliding
        self.certificates = certificates
        self.stopped_after_self = bool(stopped_after_self)

    def _result(self, k):
        return self.table.result(k, self.decided_by[k], self.pair_colliding[k],
                                 self.certificates.get(k))

    @cached_property
    def pairs(self):
        return [self._result(k) for k in self.table.order(np.arange(len(self.table)))]

    @cached_property
    def collisions(self):
        hits = self.table.order(self.pair_colliding.nonzero()[0])
        return [(r.a, r.b, r) for r in map(self._result, hits)]

    @property
    def colliding(self):
        """Whether any pair touches."""
        return bool(np.count_nonzero(self.pair_colliding))     # a planner asks this per state

    @property
    def allowed(self):
        """``(name_a, name_b, reason)`` of the pairs skipped as allowed (the same
        meaning as :attr:`CollisionWorld.allowed`)."""
        return list(self.table.allowed_pairs())

    def counts(self):
        """How many pairs each stage decided."""
        return _counts(self.decided_by)

    def __bool__(self):
        return self.colliding

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

    Parameters
    ----------
    table : PairTable
    decided_by : (C, P) int8
        Every pair's stage code per configuration (an index into :data:`STAGES`),
        pairs in ``np.triu_indices`` order of the objects.
    pair_colliding : (C, P) bool
    certificates : dict
        ``(configuration, pair)`` -> Certificate; configuration -1 for a pair of
        standing objects (the certificate holds in every configuration).
    stopped_after_self : (C,) bool
    """

    def __init__(self, table, decided_by, pair_colliding, certificates, stopped_after_self):
        self.table = table
        self.decided_by, self.pair_colliding = decided_by, pair_colliding
        self.certificates = certificates
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
        certificates = {k: cert for (at, k), cert in self.certificates.items()
                        if at in (-1, c) and self.decided_by[c, k] == _CODE["certificate"]}
        return CollisionReport(self.table, self.decided_by[c], self.pair_colliding[c],
                               certificates, self.stopped_after_self[c])

    @cached_property
    def colliding(self):
        """(C,) bool: whether each configuration has any collision."""
        return self.pair_colliding.any(axis=1)

    def counts(self):
        """How many (configuration, pair) entries each stage decided."""
        return _counts(self.decided_by)


# -- the scene -----------------------------------------------------------------------
class Scene:
    """Named meshes, pipes and primitives placed by rigid transforms: what is where.

    Changed only by :meth:`add`, :meth:`allow`, :meth:`set_pose`,
    :meth:`add_robot` and :meth:`set_joints`; ``layout_version`` counts the
    first two kinds of change, ``pose_versions`` (N,) each object's moves.
    """

    def __init__(self):
        self._names, self._index, self._bodies, self._groups = [], {}, [], []
        self._poses = np.zeros((0, 4, 4))
        self._pose_versions = np.zeros(0, np.int64)
        self._allowed = {}                 # (i, j) with i < j -> reason
        self._robots = {}                  # group -> (robot, base pose, object ids of links)
        self.layout_version = 0

    @property
    def pose_versions(self):
        """(N,) int: how often each object has moved (read-only view)."""
        view = self._pose_versions.view()
        view.flags.writeable = False
        return view

    def add(self, name, obj, transform=None, group=None):
        """Add ``obj`` (a Mesh, Pipe, Box, Sphere or Capsule) under a new ``name``.

        Objects sharing a ``group`` are checked against each other as
        self-collision pairs; every object is checked against every other.
        """
        if not isinstance(name, str) or not name:
            raise InputError(f"object name must be a non-empty string, got {name!r}", key="name")
        if name in self._index:
            raise InputError("an object of that name is already in the world; "
                             "use set_pose() to move it or pick another name", part=name)
        pose = as_pose(transform, name)
        body = as_body(obj, name)
        self._index[name] = len(self._names)
        self._names.append(name)
        self._bodies.append(body)
        self._groups.append(None if group is None else str(group))
        self._poses = np.concatenate([self._poses, pose[None]])
        self._pose_versions = np.append(self._pose_versions, 0)
        self.layout_version += 1
        return self

    def _find(self, name):
        try:
            return self._index[name]
        except (KeyError, TypeError):
            known = ", ".join(self._names) or "none yet"
            raise InputError(f"unknown object {name!r}; objects in the world: {known}",
                             part=name if isinstance(name, str) else None) from None

    @property
    def names(self):
        return tuple(self._names)

    def group(self, name):
        return self._groups[self._find(name)]

    def pose(self, name):
        return self._poses[self._find(name)].copy()

    def body(self, name):
        """The :class:`~cadpipe.collision.bodies.Body` of ``name`` (in its own frame)."""
        return self._bodies[self._find(name)]

    def set_pose(self, name, transform):
        """Move object ``name`` to a new rigid 4x4 ``transform``."""
        i = self._find(name)
        # a float64 4x4 array is checked and written in one compiled call; anything
        # else, and any matrix that fails, goes through as_pose (and its message)
        if not (_plain_pose(transform)
                and native.set_pose(transform, self._poses, self._pose_versions, i) == 0):
            self._moved(i, as_pose(transform, name))

    def _moved(self, ids, poses):
        self._poses[ids] = poses
        self._pose_versions[ids] += 1

    def allow(self, a, b, reason="allowed by user"):
        """Never report the pair ``a``, ``b`` (e.g. links joined by a joint)."""
        i, j = sorted((self._find(a), self._find(b)))
        if i == j:
            raise InputError(f"allow({a!r}, {b!r}): an object cannot collide with itself",
                             part=a)
        self._allowed[(i, j)] = str(reason)
        self.layout_version += 1

    @property
    def allowed(self):
        """``(name_a, name_b, reason)`` for every allowed pair, in the objects' order
        (a list, as :attr:`CollisionReport.allowed`)."""
        return [(self._names[i], self._names[j], r)
                for (i, j), r in sorted(self._allowed.items())]

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
                             "pass another group=", key="group")
        base = as_pose(transform, f"robot {robot.name}")
        shapes = robot.link_shapes
        for link, pose in robot.link_poses(joints, base).items():
            self.add(link, shapes[link], transform=pose, group=group)
        for a, b, reason in robot.allowed_pairs:
            self.allow(a, b, reason)
        self._robots[group] = (robot, base, np.array([self._index[k] for k in robot.link_meshes]))
        return self

    def robot(self, group):
        """``(robot, base pose)`` of the robot added as ``group``."""
        robot, base, _ = self._robot(group)
        return robot, base.copy()

    def _robot(self, group):
        if group not in self._robots:
            raise InputError(f"no robot in group {group!r}; robots: {', '.join(self._robots)}",
                             key="group")
        return self._robots[group]

    def set_joints(self, group, joints):
        """Re-pose the links of the robot added as ``group`` (one configuration: a
        sequence over ``robot.actuated`` or a mapping by joint name)."""
        robot, base, ids = self._robot(group)
        # the links were added one after another, from ids[0] on
        robot.place_links(joints, base, self._poses, self._pose_versions,
                          int(ids[0]) if len(ids) else 0)


# -- the checker ---------------------------------------------------------------------
class _Layout:
    """What the checker derives from a scene's layout (its objects and allowed
    pairs, not their poses): the pair table and the packed bounding volumes."""

    def __init__(self, scene):
        n = len(scene._names)
        first, second = np.triu_indices(n, k=1)
        ids = {g: k for k, g in enumerate(dict.fromkeys(scene._groups))}
        groups = np.array([-1 if g is None else ids[g] for g in scene._groups], np.int64)
        same = (groups[first] == groups[second]) & (groups[first] != -1)
        allowed = np.zeros(len(first), bool)
        reasons = {}
        for (i, j), reason in scene._allowed.items():
            k = bounds.pair_index(i, j, n)
            allowed[k], reasons[k] = True, reason
        self.table = PairTable(tuple(scene._names), first, second, same, allowed, reasons)
        self.groups = np.array(scene._groups, object)
        bodies = scene._bodies
        supports = [b.support for b in bodies]
        counts = [len(p) for p, _ in supports]
        self.starts = np.r_[0, np.cumsum(counts)].astype(np.int64)
        self.points = np.concatenate([p for p, _ in supports]).reshape(-1, 3)
        self.pads = np.concatenate([np.broadcast_to(r, len(p)) for p, r in supports]) \
            .astype(np.float64)
        self.slack = np.array([bounds.rounding_slack(p) for p, _ in supports]).reshape(-1)
        self.obb_centre = np.array([b.obb[0] for b in bodies]).reshape(-1, 3)
        self.obb_axes = np.array([b.obb[1] for b in bodies]).reshape(-1, 3, 3)
        self.half = np.array([b.obb[2] for b in bodies]).reshape(-1, 3)
        #: group (or None for all) -> (P,) mask of the pairs ``check(only=group)`` decides
        self.chosen = {}
        self._bodies = tuple(bodies)
        self.chain = np.array([b.kind == "chain" for b in bodies], bool)
        self.closed = np.array([b.closed for b in bodies], bool)

    @cached_property
    def pieces(self):
        """Every object's convex pieces (:class:`cadpipe.collision.convex.Pieces`)."""
        from cadpipe.collision.convex import Pieces

        return Pieces(self._bodies)

    @cached_property
    def trees(self):
        """The arrays of the exact chain tests inside the funnel kernel
        (:func:`cadpipe.collision.narrow.packed_arrays`): triangle trees only for
        meshes in a pair with a chain that is not allowed."""
        table = self.table
        paired = ~table.allowed & (self.chain[table.first] != self.chain[table.second])
        near_chain = np.zeros(len(self.chain), bool)
        near_chain[table.first[paired]] = near_chain[table.second[paired]] = True
        return narrow.packed_arrays(self._bodies, near_chain & ~self.chain)

    def place(self, ids, poses):
        """Bounds of objects ``ids`` (E,) at ``poses`` (E, 4, 4): world 18-DOPs
        (E, 2, 9) (the first three slabs are the AABB), OBB centres (E, 3) and
        axes (E, 3, 3)."""
        count = len(ids)
        kdop, centre, axes = np.empty((count, 2, 9)), np.empty((count, 3)), np.empty((count, 3, 3))
        funnel.place(self.points, self.pads, self.starts, self.slack, self.obb_centre,
                     self.obb_axes, np.asarray(ids, np.int64),
                     np.ascontiguousarray(poses, np.float64), kdop, centre, axes,
                     np.arange(count, dtype=np.int64))
        return kdop, centre, axes


class Checker:
    """Decides the pairs of a :class:`Scene`; see the module docstring.

    Its caches are keyed by the scene's versions: the layout by
    ``layout_version``, each object's placed bounds by its pose version, each
    pair's answer by the pose versions of its two objects (and ``certify``).
    """

    def __init__(self, scene):
        self.scene = scene
        self._layout_key, self._layout = None, None
        self._records = {}                 # certify -> what _record() returns

    @property
    def layout(self):
        if self._layout_key != self.scene.layout_version:
            self._layout = _Layout(self.scene)
            self._layout_key = self.scene.layout_version
            self._records.clear()
            self._placed = _Placed(self._layout)
        return self._layout

    def placed(self):
        """Bounds of every object where it stands (see :meth:`_Layout.place`),
        placed again for the objects whose pose version changed."""
        layout = self.layout
        return self._placed.current(self.scene._poses, self.scene._pose_versions, layout)

    def bounds(self, name):
        """The world AABB of ``name`` as a (2, 3) array."""
        i = self.scene._find(name)
        return self.placed()[0][i, :, :3].copy()

    # -- checks ----------------------------------------------------------------
    def check(self, stop_after_self=False, certify=False, first_hit=False, only=None):
        """Decide every pair where the objects stand; a :class:`CollisionReport`.
        See :meth:`CollisionWorld.check`."""
        return self._standing(self.chosen(only), stop_after_self, certify, first_hit)

    def chosen(self, only=None):
        """(P,) mask of the pairs ``check(only=only)`` decides: not allowed, and with
        an object of group ``only`` (every pair for None); made once per layout."""
        layout = self.layout
        if only not in layout.chosen:
            layout.chosen[only] = ~layout.table.allowed if only is None else \
                ~layout.table.allowed & self._involving(only)
        return layout.chosen[only]

    def _standing(self, chosen, stop_after_self, certify, first_hit):
        """The report of the pairs ``chosen`` (P,) where their objects stand; the
        others are ``"allowed"`` or ``"not checked"``."""
        table = self.layout.table
        record, answers, left, left_poses, hits = self._record(bool(certify))
        count = len(table.first)
        codes, colliding = np.empty(count, np.int8), np.empty(count, bool)
        found = native.refresh(record, chosen, bool(first_hit), bool(stop_after_self), codes,
                               colliding)
        stopped = stop_after_self and bool(hits[0])
        if found:
            stopped = self._settle_left(left[:found], left_poses, answers, hits, codes,
                                        colliding, stop_after_self, certify, first_hit)
        certificates = {}
        if answers.certificates:
            for k in [k for k in answers.certificates if answers.code[k] != _CODE["certificate"]]:
                del answers.certificates[k]          # pairs the boxes have decided since
            certificates = {k: c for k, c in answers.certificates.items()
                            if codes[k] == _CODE["certificate"]}
        return CollisionReport(table, codes, colliding, certificates, stopped)

    def _settle_left(self, pairs, left_poses, answers, hits, codes, colliding,
                     stop_after_self, certify, first_hit):
        """Settle the ``pairs`` the funnel kernel left (meshes through FCL, probes,
        certificates), self pairs first, in order, stopping where asked to; store
        each answer and write it into the report's ``codes`` and ``colliding``.
        ``left_poses`` (P, 4, 4) holds each pair's relative pose, in the same
        order, ``hits`` (2,) what the kernel found. Returns whether a
        self-collision stopped the check."""
        scene, table = self.scene, self.layout.table
        versions, bodies = scene._pose_versions, scene._bodies
        hit_self, hit_other = bool(hits[0]), bool(hits[1])
        for n, pair in enumerate(pairs.tolist()):
            own = table.same[pair]
            if (first_hit and (hit_self or hit_other)) or (stop_after_self and not own
                                                           and hit_self):
                break
            i, j = table.first[pair], table.second[pair]
            certificate = None
            if not certify and bodies[i].kind == bodies[j].kind == "mesh":
                touching, contained = narrow.mesh_pair(bodies[i], bodies[j], left_poses[n])
                code = _CODE["containment" if contained else "fcl"]
            else:
                found, hit, certs = self._settle(i, j, scene._poses[i][None],
                                                 scene._poses[j][None], certify)
                code, touching, certificate = found[0], bool(hit[0]), certs.get(0)
            answers.store(pair, code, touching, versions, table, certificate)
            codes[pair], colliding[pair] = code, touching
            if own:
                hit_self |= touching
            else:
                hit_other |= touching
        stopped = stop_after_self and hit_self
        if stopped:                                  # a self-collision stops the other pairs
            codes[~table.same & ~table.allowed] = _CODE["not checked"]
            colliding[~table.same] = False
        return stopped

    def _record(self, certify):
        """``(record, answers, left, left_poses, hits)``: the
        :class:`~cadpipe.collision.packed.Packed` record that ``native.refresh``
        (:mod:`cadpipe.collision.funnel`) works on (layout, placed
        bounds, answers) and the arrays of it Python reads: each pair's stored
        answers with ``certify``, the pairs the last call left, their relative
        poses, its hits; made once per layout."""
        found = self._records.get(certify)
        if found is None:
            layout, placed, scene = self.layout, self._placed, self.scene
            count = len(layout.table)
            answers = _Answers(count)
            left, left_poses = np.empty(count, np.int64), np.empty((count, 4, 4))
            hits = np.zeros(2, bool)
            table, pieces = layout.table, layout.pieces
            record = packed.pack(
                points=layout.points, pads=layout.pads, starts=layout.starts,
                slack=layout.slack, obb_centre=layout.obb_centre, obb_axes=layout.obb_axes,
                half=layout.half, chain=layout.chain, closed=layout.closed,
                first=table.first, second=table.second, same=table.same,
                allowed=table.allowed, piece_points=pieces.points, piece_pads=pieces.pads,
                piece_starts=pieces.piece_starts, piece_centre=pieces.centre,
                piece_radius=pieces.radius, pieces=pieces.pieces, **layout.trees,
                poses=scene._poses, versions=scene._pose_versions, placed_at=placed.at,
                kdop=placed.kdop, centre=placed.centre, axes=placed.axes, at_a=answers.at_a,
                at_b=answers.at_b, code=answers.code, colliding=answers.colliding,
                left=left, left_poses=left_poses, hits=hits, certify=certify)
            found = self._records[certify] = (record, answers, left, left_poses, hits)
        return found

    def _involving(self, group):
        """(P,) mask of the pairs with an object of ``group``."""
        table, groups = self.layout.table, self.layout.groups
        if group not in set(groups):
            raise InputError(f"check(only={group!r}): no object in that group; groups: "
                             + ", ".join(sorted({str(g) for g in groups if g is not None})),
                             key="only")
        member = groups == group
        return member[table.first] | member[table.second]

    def check_moving(self, ids, poses, stop_after_self=False, certify=False, first_hit=False):
        """Every pair in each of C configurations: objects ``ids`` (m,) at ``poses``
        (C, m, 4, 4), all others where they stand; a :class:`CollisionReports`.

        Pairs of standing objects are decided once, as :meth:`check` decides
        them; pairs with a moving object go through the funnel for all
        configurations together, in chunks that keep the entry arrays small.
        With ``first_hit`` the chunks start small and grow, and the check stops
        after the chunk holding the first colliding configuration: every
        configuration after that one is left ``"not checked"``.
        """
        layout, n = self.layout, len(self.scene._names)
        table = layout.table
        count = len(poses)
        moving = np.zeros(n, bool)
        moving[ids] = True
        standing_pairs = ~moving[table.first] & ~moving[table.second]
        codes = np.full((count, len(table)), _CODE["allowed"], np.int8)
        colliding = np.zeros(codes.shape, bool)
        certificates = {}
        if standing_pairs.any():
            still = self._standing(standing_pairs & ~table.allowed, False, certify, False)
            codes[:, standing_pairs] = still.decided_by[standing_pairs]
            colliding[:, standing_pairs] = still.pair_colliding[standing_pairs]
            # configuration -1: a certificate that holds in every configuration
            certificates.update({(-1, k): cert for k, cert in still.certificates.items()})
        pairs = np.flatnonzero(~standing_pairs & ~table.allowed)
        start, size = 0, FIRST_CHUNK if first_hit else CONFIGURATION_CHUNK
        while start < count:
            part = slice(start, start + size)
            found = self._moving_pairs(ids, poses[part], pairs, codes[part], colliding[part],
                                       certify)
            certificates.update({(c + start, k): cert for (c, k), cert in found.items()})
            start, size = start + size, min(2 * size, CONFIGURATION_CHUNK)
            hit = np.flatnonzero(colliding[:start].any(axis=1)) if first_hit else ()
            if len(hit):
                after = slice(hit[0] + 1, None)
                codes[after, ~table.allowed] = _CODE["not checked"]
                colliding[after] = False
                certificates = {key: c for key, c in certificates.items() if key[0] <= hit[0]}
                break
        stopped = np.zeros(count, bool)
        if stop_after_self:
            stopped = colliding[:, table.same].any(axis=1)
            rest = ~table.same & ~table.allowed
            codes[np.ix_(stopped, rest)] = _CODE["not checked"]
            colliding[np.ix_(stopped, rest)] = False
        return CollisionReports(table, codes, colliding, certificates, stopped)

    def _moving_pairs(self, ids, poses, pairs, codes, colliding, certify):
        """Decide ``pairs`` (each with a moving object) in each configuration of
        ``poses`` (C, m, 4, 4) into ``codes``, ``colliding`` (C, P); returns the
        certificates by (configuration, pair)."""
        layout, scene = self.layout, self.scene
        table, n = layout.table, len(scene._names)
        count, m = poses.shape[:2]
        # slot[c, i]: the row of object i's placed bounds in configuration c: its
        # standing row (< n), or one of the C * m rows placed for the movers
        slot = np.broadcast_to(np.arange(n), (count, n)).copy()
        slot[:, ids] = n + np.arange(count * m).reshape(count, m)
        moved = layout.place(np.tile(ids, count), poses.reshape(-1, 4, 4))
        kdop, centre, axes = (np.concatenate([a, b]) for a, b in zip(self.placed(), moved))
        obj = np.r_[np.arange(n), np.tile(ids, count)]
        slot_poses = np.concatenate([scene._poses, poses.reshape(-1, 4, 4)])
        config = np.repeat(np.arange(count), len(pairs))
        k = np.tile(pairs, count)
        slot_a, slot_b = slot[config, table.first[k]], slot[config, table.second[k]]
        found = np.empty(len(k), np.int8)
        funnel.decide(kdop, centre, axes, layout.half[obj], slot_a, slot_b,
                      None if certify else layout.pieces.arrays(), layout.chain, obj,
                      slot_poses, found)
        boxed = found != funnel.NARROW
        codes[config[boxed], k[boxed]] = found[boxed]
        rest = (~boxed).nonzero()[0]
        rest = rest[np.argsort(k[rest], kind="stable")]
        certificates = {}
        pair_ids, starts = np.unique(k[rest], return_index=True)
        for pair, at in zip(pair_ids, np.split(rest, starts[1:])):
            code, touching, certs = self._settle(table.first[pair], table.second[pair],
                                                 slot_poses[slot_a[at]], slot_poses[slot_b[at]],
                                                 certify)
            codes[config[at], pair], colliding[config[at], pair] = code, touching
            certificates.update({(config[at[e]], pair): cert for e, cert in certs.items()})
        return certificates

    def _settle(self, i, j, poses_a, poses_b, certify):
        """``(codes, touching, certificates by entry)`` of one pair at E placements:
        the certificate first when asked for, then the exact narrow phase."""
        body_a, body_b = self.scene._bodies[i], self.scene._bodies[j]
        certificates = {}
        if certify:
            from cadpipe.collision.certificate import find_certificate

            for e in range(len(poses_a)):
                cert = find_certificate(body_a, poses_a[e], body_b, poses_b[e],
                                        names=(self.scene._names[i], self.scene._names[j]))
                if cert is not None:
                    certificates[e] = cert
        exact = _CODE["analytic" if body_a.kind == body_b.kind == "chain" else "fcl"]
        if not certificates:
            touching, contained = narrow.collide(body_a, poses_a, body_b, poses_b)
            return np.where(contained, _CODE["containment"], exact).astype(np.int8), touching, {}
        todo = np.ones(len(poses_a), bool)
        todo[list(certificates)] = False
        codes = np.full(len(poses_a), _CODE["certificate"], np.int8)
        touching = np.zeros(len(poses_a), bool)
        if todo.any():
            hit, contained = narrow.collide(body_a, poses_a[todo], body_b, poses_b[todo])
            codes[todo] = np.where(contained, _CODE["containment"], exact)
            touching[todo] = hit
        return codes, touching, certificates

    # -- per-pair queries ---------------------------------------------------------
    def collide_at(self, i, pose_i, j, pose_j):
        """Whether objects ``i`` and ``j`` collide at float64 (4, 4) C-ordered poses
        ``pose_i``, ``pose_j``, or None (nothing decided) where one is not a pose
        :func:`as_pose` accepts: the compiled walks of the funnel kernel where they
        decide (the compiled settle of :mod:`cadpipe.collision.narrow`), :func:`narrow.collide`
        for the rest; the same answer either way."""
        code, touching = native.collide_pose(self._record(False)[0], i, pose_i, j, pose_j)
        if code == _REFUSED:
            return None
        if code != narrow.UNSETTLED:
            return touching
        bodies = self.scene._bodies
        return bool(narrow.collide(bodies[i], pose_i[None], bodies[j], pose_j[None])[0][0])

    def distance(self, a, b):
        """Clearance between ``a`` and ``b`` with the closest points (a
        :class:`Clearance`); 0 when they touch or one contains the other."""
        i, j = self.scene._find(a), self.scene._find(b)
        scene = self.scene
        dist, pa, pb, stage = narrow.distance(scene._bodies[i], scene._poses[i], scene._bodies[j],
                                              self.scene._poses[j])
        return Clearance(float(dist), pa, pb, dist <= 0, stage)

    def separate(self, a, b, step_degrees=None):
        """The source's separation certificate for ``a`` and ``b``, or None.

        A returned :class:`~cadpipe.collision.certificate.Certificate` has passed
        its independent verifier: it proves the pair does not touch.
        """
        from cadpipe.collision.certificate import find_certificate

        i, j = self.scene._find(a), self.scene._find(b)
        options = {} if step_degrees is None else {"step_degrees": step_degrees}
        return find_certificate(self.scene._bodies[i], self.scene._poses[i], self.scene._bodies[j],
                                self.scene._poses[j], names=(a, b), **options)

    def inside(self, pipe_name, points):
        """Virtual fixture: which ``(P, 3)`` world points lie inside the pipe (or other
        ball chain) ``pipe_name``, and where the polyline through them first leaves it.

        Returns a :class:`PipeContainment`.
        """
        from cadpipe._validate import as_points
        from cadpipe.collision.fixture import containment

        i = self.scene._find(pipe_name)
        body = self.scene._bodies[i]
        if body.kind != "chain":
            raise InputError(f"inside({pipe_name!r}): that object is a mesh; inside() needs a "
                             "pipe, sphere or capsule (use distance() for meshes)",
                             part=pipe_name)
        points = as_points(points, "points")
        return containment(body.chain.moved(self.scene._poses[i]), points)


class _Placed:
    """Every object's placed bounds, each row with the pose version it was placed at."""

    def __init__(self, layout):
        n = len(layout.table.names)
        self.kdop, self.centre, self.axes = np.empty((n, 2, 9)), np.empty((n, 3)), \
            np.empty((n, 3, 3))
        self.at = np.full(n, -1, np.int64)

    def current(self, poses, versions, layout):
        ids = (self.at != versions).nonzero()[0]
        if ids.size:
            funnel.place(layout.points, layout.pads, layout.starts, layout.slack,
                         layout.obb_centre, layout.obb_axes, ids, poses[ids], self.kdop,
                         self.centre, self.axes, ids)
            self.at[ids] = versions[ids]
        return self.kdop, self.centre, self.axes


class _Answers:
    """Each pair's last answer, with the pose versions of its objects it holds for."""

    def __init__(self, count):
        self.code = np.zeros(count, np.int8)
        self.colliding = np.zeros(count, bool)
        self.at_a = np.full(count, -1, np.int64)
        self.at_b = np.full(count, -1, np.int64)
        self.certificates = {}

    def store(self, k, code, colliding, versions, table, certificate=None):
        """The answer for pair ``k``, holding while its objects are at ``versions``."""
        self.code[k], self.colliding[k] = code, colliding
        self.at_a[k], self.at_b[k] = versions[table.first[k]], versions[table.second[k]]
        self.certificates.pop(k, None)
        if certificate is not None:
            self.certificates[k] = certificate


# -- the world -----------------------------------------------------------------------
class CollisionWorld(Scene):
    """A :class:`Scene` with the checks of its :class:`Checker`.

    Examples
    --------
    >>> world = CollisionWorld()
    >>> world.add("link1", mesh, transform=T1, group="robot")      # doctest: +SKIP
    >>> world.add("weld_pipe", pipe)                                # doctest: +SKIP
    >>> world.allow("link1", "link2", reason="adjacent")            # doctest: +SKIP
    >>> world.check().collisions                                    # doctest: +SKIP
    """

    @cached_property
    def checker(self) -> "Checker":
        """The :class:`Checker` of this scene."""
        return Checker(self)

    def bounds(self, name: str) -> np.ndarray:
        """The world AABB of an object where it stands.

        Parameters
        ----------
        name : str
            The object.

        Returns
        -------
        (2, 3) array
            Its lower and upper corner (world units).
        """
        return self.checker.bounds(name)

    def check(self, stop_after_self: bool = False, certify: bool = False,
              first_hit: bool = False, only: str | None = None) -> CollisionReport:
        """Decide every pair where the objects stand.

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
        first_hit : bool
            Stop at the first collision found (self pairs are tried first):
            the pairs the exact phase had not reached are ``"not checked"``.
            ``bool(report)`` is then the answer a planner's validity check needs.
        only : str, optional
            A group (a robot's name): decide only the pairs with an object of
            that group -- the robot against itself and the world -- and leave
            obstacle-obstacle pairs ``"not checked"``.

        Returns
        -------
        CollisionReport
            Pairs whose objects have not moved since they were last decided keep
            that answer: after ``set_joints`` only the robot's pairs are decided.
        """
        return self.checker.check(stop_after_self, certify, first_hit, only)

    def check_motion(self, group: str, q_a: ArrayLike, q_b: ArrayLike,
                     tolerance: float | None = None, margin: float = 0.0) -> "MotionCheck":
        """Certify the straight joint-space motion of robot ``group`` from ``q_a`` to
        ``q_b``; see :mod:`cadpipe.collision.motion` for the bound.

        Parameters
        ----------
        group : str
            The robot's group (see :meth:`add_robot`).
        q_a, q_b : (A,) array
            Joint values over ``robot.actuated`` at the start and the end.
        tolerance : float, optional
            Clearance (world units) counted as contact.
        margin : float
            A planner's padding (world units): with ``margin > 0`` the motion
            is free only if it keeps at least ``margin`` from everything, and is
            refused as soon as a clearance bound falls below ``2 margin``,
            without a contact time.

        Returns
        -------
        MotionCheck
            ``free`` proves the whole motion free; otherwise where it first
            comes within ``tolerance`` of contact.
        """
        return self.check_path(group, [q_a, q_b], between=True, tolerance=tolerance,
                               margin=margin)

    def check_path(self, group: str, configurations: ArrayLike, stop_after_self: bool = False,
                   certify: bool = False, between: bool = False, tolerance: float | None = None,
                   first_hit: bool = False,
                   margin: float = 0.0) -> "CollisionReports | MotionCheck":
        """:meth:`check` at each of many joint configurations of the robot ``group``,
        in one vectorized pass.

        Parameters
        ----------
        group : str
            The robot's group (see :meth:`add_robot`).
        configurations : (C, A) array
            Joint values over ``robot.actuated`` (radians, metres): a
            trajectory's waypoints, say.
        stop_after_self, certify : bool
            As for :meth:`check`, per configuration.
        between : bool
            Certify the motion between consecutive configurations instead
            (conservative advancement, stopping at the first contact; see
            :mod:`cadpipe.collision.motion`).
        tolerance : float, optional
            With ``between``: the clearance (world units) counted as contact,
            :data:`cadpipe.collision.motion.TOLERANCE` by default.
        first_hit : bool
            Stop at the first colliding configuration: every pair of the
            configurations after it is ``"not checked"`` (and not colliding),
            so ``reports.colliding.argmax()`` is the first hit when
            ``reports.colliding.any()``. A motion check (``between``) always
            stops at its first contact.
        margin : float
            With ``between``: a planner's padding, as for :meth:`check_motion`.

        Returns
        -------
        CollisionReports
            One report per configuration, each the one :meth:`set_joints` then
            :meth:`check` would give (the motion between them is not swept);
            with ``between=True`` a :class:`~cadpipe.collision.motion.MotionCheck`.
            The robot stays where :meth:`set_joints` last put it.
        """
        if between:
            from cadpipe.collision import motion

            return motion.check_motion(self, group, configurations, tolerance, margin)
        robot, base, ids = self._robot(group)
        poses = robot.link_pose_array(configurations, base)
        return self.checker.check_moving(ids, poses, stop_after_self, certify, first_hit)

    def check_many(self, poses: dict, stop_after_self: bool = False,
                   certify: bool = False) -> CollisionReports:
        """:meth:`check` with objects placed at each of C poses, in one vectorized pass.

        Parameters
        ----------
        poses : mapping of name -> (C, 4, 4) array
            Rigid transforms (the same C for all); objects not named stay where
            they are.
        stop_after_self, certify : bool
            As for :meth:`check`, per configuration.

        Returns
        -------
        CollisionReports
            One report per configuration, each the one :meth:`set_pose` then
            :meth:`check` would give.
        """
        if not hasattr(poses, "items") or not poses:
            raise InputError("check_many(poses): pass a mapping of object names to (C, 4, 4) "
                             "pose arrays", key="poses")
        ids = np.array([self._find(name) for name in poses])
        stacked = [as_poses(p, name) for name, p in poses.items()]
        if any(p.ndim != 3 for p in stacked) or len({len(p) for p in stacked}) != 1:
            raise InputError("check_many(poses): every object needs a (C, 4, 4) array with the "
                             "same C, got shapes " + ", ".join(str(p.shape) for p in stacked),
                             key="poses")
        return self.checker.check_moving(ids, np.stack(stacked, axis=1), stop_after_self,
                                         certify)

    def distance(self, a: str, b: str) -> Clearance:
        """Clearance between two objects where they stand, with the closest points.

        Parameters
        ----------
        a, b : str
            The objects.

        Returns
        -------
        Clearance
            Distance 0 (and no points) when they touch or one contains the other.
        """
        return self.checker.distance(a, b)

    def distance_at(self, a: str, b: str, pose_a: np.ndarray, pose_b: np.ndarray,
                    containment: bool = True) -> float:
        """Clearance between ``a`` placed at ``pose_a`` and ``b`` at ``pose_b``;
        where they stand is unchanged.

        Parameters
        ----------
        a, b : str
            The objects.
        pose_a, pose_b : (4, 4) array
            Rigid poses to place them at.
        containment : bool
            False: the distance between the boundaries (a solid inside another is
            not seen), as a motion from a free state needs.

        Returns
        -------
        float
            The clearance (world units), 0 when touching.
        """
        i, j = self._find(a), self._find(b)
        return float(narrow.distance(self._bodies[i], pose_a, self._bodies[j], pose_b,
                                     containment)[0])

    def collide_at(self, a: str, b: str, pose_a: np.ndarray, pose_b: np.ndarray) -> bool:
        """Whether ``a`` placed at ``pose_a`` and ``b`` at ``pose_b`` touch, or one
        contains the other: one pose of one pair, as a fixture or a planner asks,
        straight to the exact test (the verdict :meth:`check` gives the pair there);
        where they stand is unchanged.

        Parameters
        ----------
        a, b : str
            The objects.
        pose_a, pose_b : (4, 4) array
            Rigid poses to place them at.

        Returns
        -------
        bool
            True when they collide there.
        """
        i, j = self._find(a), self._find(b)
        # float64 4x4 arrays go to the kernel as they are (it checks them); anything
        # else, and any pose it refuses, through as_pose (which converts or says why)
        found = self.checker.collide_at(i, pose_a, j, pose_b) \
            if _plain_pose(pose_a) and _plain_pose(pose_b) else None
        if found is None:
            found = self.checker.collide_at(i, np.ascontiguousarray(as_pose(pose_a, a)), j,
                                            np.ascontiguousarray(as_pose(pose_b, b)))
        return found

    def separate(self, a: str, b: str,
                 step_degrees: float | None = None) -> "Certificate | None":
        """The source's separation certificate for two objects where they stand.

        Parameters
        ----------
        a, b : str
            The objects.
        step_degrees : float, optional
            The angular step of the certificate's search.

        Returns
        -------
        Certificate or None
            A returned certificate has passed its independent verifier: it
            proves the pair does not touch.
        """
        return self.checker.separate(a, b, step_degrees)

    def inside(self, pipe_name: str, points: ArrayLike) -> "PipeContainment":
        """Virtual fixture: which world points lie inside a pipe (or other ball
        chain), and where the polyline through them first leaves it.

        Parameters
        ----------
        pipe_name : str
            The pipe, sphere or capsule.
        points : (P, 3) array
            World points, in the order a tool visits them.

        Returns
        -------
        PipeContainment
            Inside or not per point, and where the path first leaves.
        """
        return self.checker.inside(pipe_name, points)
