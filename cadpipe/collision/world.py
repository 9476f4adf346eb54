"""The collision world: named objects, allowed pairs, and the checks over them.

:meth:`CollisionWorld.check` follows the source's order. Pairs within one group
(a robot's links) are self-collision pairs and are decided first; with
``stop_after_self=True`` a self-collision ends the check, as the source does.
Every pair not allowed then goes down the same funnel, each stage able to prove
"apart", cheapest first: sweep-and-prune on AABBs, 18-DOPs, OBBs, optionally
the source's separation certificate, and finally the exact narrow phase. The report records
which stage decided each pair.
"""

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..errors import InputError
from ..transform import is_rigid
from . import bounds, narrow
from .bodies import as_body

#: stages that can decide a pair, in the order a pair meets them
STAGES = ("allowed", "aabb", "kdop", "obb", "certificate", "fcl", "containment", "analytic",
          "not checked")
_CODE = {name: i for i, name in enumerate(STAGES)}
_NARROW = -1                     # a pair the broad phase could not decide


def as_pose(transform, name):
    """A rigid 4x4 float matrix, or :class:`InputError` naming the object."""
    if transform is None:
        return np.eye(4)
    try:
        m = np.array(transform, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{name}: transform must be a 4x4 matrix of numbers") from None
    if m.shape != (4, 4):
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
        hits = self._order(np.flatnonzero(self._colliding))
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
        self._stale = np.zeros(0, bool)
        self._allowed = {}                 # (i, j) with i < j -> reason
        self._robots = {}                  # group -> (robot, base pose)
        self._cache = {}                   # (i, j, certify) -> (versions, code, colliding, cert)
        self._packed = None                # hull points of all objects, rebuilt on add()
        self._pair_table = None            # pairs, self-pair and allowed masks

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
        self._packed = self._pair_table = None
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
        self._poses[i] = as_pose(transform, name)
        self._versions[i] += 1
        self._stale[i] = True

    def allow(self, a, b, reason="allowed by user"):
        """Never report the pair ``a``, ``b`` (e.g. links joined by a joint)."""
        i, j = sorted((self._find(a), self._find(b)))
        if i == j:
            raise InputError(f"allow({a!r}, {b!r}): an object cannot collide with itself")
        self._allowed[(i, j)] = str(reason)
        self._pair_table = None

    def allowed(self):
        """``(name_a, name_b, reason)`` for every allowed pair."""
        return [(self._names[i], self._names[j], r) for (i, j), r in sorted(self._allowed.items())]

    # -- robots ---------------------------------------------------------------
    def add_robot(self, robot, joints=None, transform=None, group=None):
        """Add each link of a :class:`~cadpipe.collision.Robot` with geometry, posed by
        ``joints``; the robot's allowed pairs (adjacent links, SRDF) come along.

        Links are named by their link names, in group ``group`` (default: the
        robot's name), so :meth:`set_joints` can move them later.
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
        self._robots[group] = (robot, base)
        return self

    def set_joints(self, group, joints):
        """Re-pose the links of the robot added as ``group``."""
        if group not in self._robots:
            raise InputError(f"no robot in group {group!r}; robots: {', '.join(self._robots)}")
        robot, base = self._robots[group]
        poses = robot.link_poses(joints, base)
        index = [self._index[link] for link in poses]
        self._poses[index] = np.array(list(poses.values()))
        self._versions[index] += 1
        self._stale[index] = True

    # -- bounding volumes -------------------------------------------------------
    def _pack(self):
        """Hull points grouped by size (powers of two, padded by repeating a point),
        so the bounds of many moved objects refresh in a few batched products."""
        if self._packed is None:
            n = len(self._bodies)
            buckets = {}
            for i, body in enumerate(self._bodies):
                size = 1 << max(3, int(np.ceil(np.log2(len(body.hull[0])))))
                buckets.setdefault(size, []).append(i)
            groups = []
            for size, members in sorted(buckets.items()):
                points = np.empty((len(members), 3, size))      # coordinates, then points:
                pad = np.empty((len(members), 1, size))         # reductions run along rows
                for row, i in enumerate(members):
                    p, r = self._bodies[i].hull
                    fill = np.r_[np.arange(len(p)), np.zeros(size - len(p), np.int64)]
                    points[row], pad[row, 0] = p[fill].T, r[fill]
                groups.append((np.array(members), points, pad if pad.any() else None))
            obbs = [body.obb for body in self._bodies]
            self._packed = {
                "groups": groups,
                "centre": np.array([o[0] for o in obbs]), "axes": np.array([o[1] for o in obbs]),
                "half": np.array([o[2] for o in obbs]),
                "kdop": np.zeros((n, 2, 9)), "world_centre": np.zeros((n, 3)),
                "world_axes": np.zeros((n, 3, 3))}
            self._stale[:] = True
        return self._packed

    def _refresh_bounds(self):
        """World 18-DOP (its first three slabs are the AABB) and OBB of every object
        moved since the last call."""
        b = self._pack()
        if not self._stale.any():
            return b
        rot, shift = self._poses[:, :3, :3], self._poses[:, :3, 3]
        for members, points, pad in b["groups"]:
            moved = self._stale[members]
            if not moved.any():
                continue
            ids = members[moved]
            # project the local points on the world directions turned into each frame
            proj = (bounds.KDOP_DIRECTIONS @ rot[ids]) @ points[moved]       # (k, 9, size)
            offset = shift[ids] @ bounds.KDOP_DIRECTIONS.T
            if pad is None:
                low, high = proj.min(axis=2), proj.max(axis=2)
            else:
                low, high = (proj - pad[moved]).min(axis=2), (proj + pad[moved]).max(axis=2)
            b["kdop"][ids, 0], b["kdop"][ids, 1] = low + offset, high + offset
        stale = np.flatnonzero(self._stale)
        b["world_centre"][stale] = (rot[stale] @ b["centre"][stale, :, None])[:, :, 0] \
            + shift[stale]
        b["world_axes"][stale] = rot[stale] @ b["axes"][stale]
        self._stale[:] = False
        return b

    def bounds(self, name):
        """The world AABB of ``name`` as a (2, 3) array."""
        i = self._find(name)
        return self._refresh_bounds()["kdop"][i, :, :3].copy()

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
        n = len(self._names)
        first, second, same, allowed = self._pairs()
        codes = np.full(len(first), _CODE["aabb"], np.int8)
        codes[allowed] = _CODE["allowed"]
        colliding = np.zeros(len(first), bool)
        certificates = {}
        if n >= 2:
            b = self._refresh_bounds()
            k = np.flatnonzero(bounds.overlapping_pairs(b["kdop"][:, 0, :3], b["kdop"][:, 1, :3],
                                                        first, second) & ~allowed)
            i, j = first[k], second[k]
            dop = bounds.boxes_overlap(b["kdop"][i, 0], b["kdop"][i, 1], b["kdop"][j, 0],
                                       b["kdop"][j, 1])
            codes[k[~dop]] = _CODE["kdop"]
            k, i, j = k[dop], i[dop], j[dop]
            if k.size:
                obb = bounds.obb_overlap(b["world_centre"][i], b["world_axes"][i], b["half"][i],
                                         b["world_centre"][j], b["world_axes"][j], b["half"][j])
                codes[k[~obb]] = _CODE["obb"]
                k = k[obb]
            order = k[np.lexsort((second[k], first[k], ~same[k]))]
            stopped = False
            for pair in order:
                if stop_after_self and not same[pair] and colliding[same].any():
                    stopped = True
                    break
                codes[pair], colliding[pair], cert = self._decide(first[pair], second[pair],
                                                                  certify)
                if cert is not None:
                    certificates[pair] = cert
            if stopped:
                rest = ~same & (codes != _CODE["allowed"])
                codes[rest] = _CODE["not checked"]
                colliding[rest] = False
        else:
            stopped = False
        reasons = {k: self._allowed[(first[k], second[k])] for k in np.flatnonzero(allowed)}
        return CollisionReport(tuple(self._names), first, second, same, codes, colliding, reasons,
                               certificates, stopped)

    def _decide(self, i, j, certify):
        """``(code, colliding, certificate)`` of one pair past the broad phase."""
        key = (i, j, certify)
        versions = (self._versions[i], self._versions[j])
        cached = self._cache.get(key)
        if cached is not None and cached[0] == versions:
            return cached[1:]
        cert = None
        if certify:
            from .certificate import find_certificate

            cert = find_certificate(self._bodies[i], self._poses[i], self._bodies[j],
                                    self._poses[j], names=(self._names[i], self._names[j]))
        if cert is not None:
            code, touching = _CODE["certificate"], False
        else:
            touching, stage = narrow.collide(self._bodies[i], self._poses[i], self._bodies[j],
                                             self._poses[j])
            code = _CODE[stage]
        self._cache[key] = (versions, code, touching, cert)
        return code, touching, cert

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
        from .certificate import find_certificate

        i, j = self._find(a), self._find(b)
        options = {} if step_degrees is None else {"step_degrees": step_degrees}
        return find_certificate(self._bodies[i], self._poses[i], self._bodies[j],
                                self._poses[j], names=(a, b), **options)

    def inside(self, pipe_name, points):
        """Virtual fixture: which ``(P, 3)`` world points lie inside the pipe (or other
        ball chain) ``pipe_name``, and where the polyline through them first leaves it.

        Returns a :class:`PipeContainment`.
        """
        from .._validate import as_points
        from .fixture import containment

        i = self._find(pipe_name)
        body = self._bodies[i]
        if body.kind != "chain":
            raise InputError(f"inside({pipe_name!r}): that object is a mesh; inside() needs a "
                             "pipe, sphere or capsule (use distance() for meshes)")
        points = as_points(points, "points")
        return containment(body.chain.moved(self._poses[i]), points)
