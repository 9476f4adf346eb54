"""What a collision check answers: per pair, which stage decided it and whether it touches.

Reports hold their answers as arrays over the pair table (every pair ``i < j`` of the
world's objects, in ``np.triu_indices`` order) and build the per-pair records only when
asked for, so a planner asking ``bool(report)`` per state pays for none of them.
"""

import operator
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np


#: stages that can decide a pair, in the order a pair meets them
STAGES = ("allowed", "aabb", "kdop", "obb", "hull", "certificate", "fcl", "containment", "analytic",
          "not checked")


#: each stage's code, its index in :data:`STAGES`
STAGE_CODE = {name: i for i, name in enumerate(STAGES)}


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


def stage_counts(codes):
    """{stage: count} of the (any shape) stage ``codes``, stages with none left out."""
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
        return stage_counts(self.decided_by)

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
                        if at in (-1, c) and self.decided_by[c, k] == STAGE_CODE["certificate"]}
        return CollisionReport(self.table, self.decided_by[c], self.pair_colliding[c],
                               certificates, self.stopped_after_self[c])

    @cached_property
    def colliding(self):
        """(C,) bool: whether each configuration has any collision."""
        return self.pair_colliding.any(axis=1)

    def counts(self):
        """How many (configuration, pair) entries each stage decided."""
        return stage_counts(self.decided_by)


