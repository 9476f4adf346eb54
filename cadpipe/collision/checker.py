"""Decides the pairs of a collision scene: bounds, funnel, narrow phase, certificates.

Everything the checker keeps -- the packed bounding volumes, the pair table, each
object's placed bounds, each pair's last answer -- is stored with the scene versions it
was computed at and reused only while they still match, so nothing is invalidated by
hand and nothing can go stale. A pair whose two objects have not moved since it was
decided is not decided again: after ``set_joints``, ``check()`` decides the robot's
pairs and reuses every obstacle-obstacle answer.
"""

from functools import cached_property

import numpy as np

from cadpipe.collision import bounds, funnel, narrow, packed
from cadpipe.collision.reports import (STAGE_CODE, Clearance, CollisionReport, CollisionReports,
                                       PairTable)
from cadpipe.core.kernels import native
from cadpipe.errors import InputError


#: configurations per pass of the broad phase (bounds the entry arrays' memory)
CONFIGURATION_CHUNK = 2048


#: the first chunk of ``check_path(first_hit=True)``, doubled each pass after it
FIRST_CHUNK = 16


# stage codes the kernels write are the reports' codes, and so is the refusal code
if (STAGE_CODE["aabb"], STAGE_CODE["kdop"], STAGE_CODE["obb"], STAGE_CODE["hull"],
        STAGE_CODE["allowed"], STAGE_CODE["not checked"], STAGE_CODE["fcl"],
        STAGE_CODE["containment"], STAGE_CODE["analytic"]) != (
        funnel.AABB, funnel.KDOP, funnel.OBB, funnel.HULL, funnel.ALLOWED, funnel.NOT_CHECKED,
        narrow.FCL, narrow.CONTAINMENT, narrow.ANALYTIC):
    raise ImportError("cadpipe's stage codes differ between the kernels and the reports")

#: what ``native.collide_pose`` returns for a pose :func:`as_pose` refuses; it is the
#: compiled ``settle`` (:mod:`cadpipe.collision.narrow`) of objects ``i`` and ``j`` of the
#: packed world at (4, 4) float64 poses, each first checked as :func:`as_pose` checks it,
#: in one call: ``(code, touching)``. Per pose, the two checks as calls of their own cost
#: 1.6 us of the 9 us a pipe-mesh pose took.
_REFUSED = -2
if native.collision_constants()["REFUSED"] != _REFUSED:
    raise ImportError("cadpipe's pose kernels were built with another refusal code than "
                      "cadpipe.collision.checker holds")


# -- the checker ---------------------------------------------------------------------
class Layout:
    """What the checker derives from a scene's layout (its objects and allowed
    pairs, not their poses): the pair table and the packed bounding volumes."""

    def __init__(self, scene):
        names, groups_of = scene.names, scene.groups
        n = len(names)
        first, second = np.triu_indices(n, k=1)
        ids = {g: k for k, g in enumerate(dict.fromkeys(groups_of))}
        groups = np.array([-1 if g is None else ids[g] for g in groups_of], np.int64)
        same = (groups[first] == groups[second]) & (groups[first] != -1)
        allowed = np.zeros(len(first), bool)
        reasons = {}
        for (i, j), reason in scene.allowed_index.items():
            k = bounds.pair_index(i, j, n)
            allowed[k], reasons[k] = True, reason
        self.table = PairTable(names, first, second, same, allowed, reasons)
        self.groups = np.array(groups_of, object)
        bodies = scene.bodies
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
        self.bodies = bodies
        self.chain = np.array([b.kind == "chain" for b in bodies], bool)
        self.closed = np.array([b.closed for b in bodies], bool)

    @cached_property
    def pieces(self):
        """Every object's convex pieces (:class:`cadpipe.collision.convex.Pieces`)."""
        from cadpipe.collision.convex import Pieces

        return Pieces(self.bodies)

    @cached_property
    def trees(self):
        """The arrays of the exact chain tests inside the funnel kernel
        (:func:`cadpipe.collision.narrow.packed_arrays`): triangle trees only for
        meshes in a pair with a chain that is not allowed."""
        table = self.table
        paired = ~table.allowed & (self.chain[table.first] != self.chain[table.second])
        near_chain = np.zeros(len(self.chain), bool)
        near_chain[table.first[paired]] = near_chain[table.second[paired]] = True
        return narrow.packed_arrays(self.bodies, near_chain & ~self.chain)

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
            self._layout = Layout(self.scene)
            self._layout_key = self.scene.layout_version
            self._records.clear()
            self._placed = Placed(self._layout)
        return self._layout

    def placed(self):
        """Bounds of every object where it stands (see :meth:`Layout.place`),
        placed again for the objects whose pose version changed."""
        layout = self.layout
        return self._placed.current(self.scene.poses, self.scene.pose_versions, layout)

    def bounds(self, name):
        """The world AABB of ``name`` as a (2, 3) array."""
        i = self.scene.index(name)
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
            stale = [k for k in answers.certificates
                     if answers.code[k] != STAGE_CODE["certificate"]]
            for k in stale:
                del answers.certificates[k]          # pairs the boxes have decided since
            certificates = {k: c for k, c in answers.certificates.items()
                            if codes[k] == STAGE_CODE["certificate"]}
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
        versions, bodies, poses = scene.pose_versions, self.layout.bodies, scene.poses
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
                code = STAGE_CODE["containment" if contained else "fcl"]
            else:
                found, hit, certs = self._settle(i, j, poses[i][None], poses[j][None], certify)
                code, touching, certificate = found[0], bool(hit[0]), certs.get(0)
            answers.store(pair, code, touching, versions, table, certificate)
            codes[pair], colliding[pair] = code, touching
            if own:
                hit_self |= touching
            else:
                hit_other |= touching
        stopped = stop_after_self and hit_self
        if stopped:                                  # a self-collision stops the other pairs
            codes[~table.same & ~table.allowed] = STAGE_CODE["not checked"]
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
            answers = Answers(count)
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
                poses=scene.poses, versions=scene.pose_versions, placed_at=placed.at,
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
        layout, n = self.layout, len(self.scene.names)
        table = layout.table
        count = len(poses)
        moving = np.zeros(n, bool)
        moving[ids] = True
        standing_pairs = ~moving[table.first] & ~moving[table.second]
        codes = np.full((count, len(table)), STAGE_CODE["allowed"], np.int8)
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
                codes[after, ~table.allowed] = STAGE_CODE["not checked"]
                colliding[after] = False
                certificates = {key: c for key, c in certificates.items() if key[0] <= hit[0]}
                break
        stopped = np.zeros(count, bool)
        if stop_after_self:
            stopped = colliding[:, table.same].any(axis=1)
            rest = ~table.same & ~table.allowed
            codes[np.ix_(stopped, rest)] = STAGE_CODE["not checked"]
            colliding[np.ix_(stopped, rest)] = False
        return CollisionReports(table, codes, colliding, certificates, stopped)

    def _moving_pairs(self, ids, poses, pairs, codes, colliding, certify):
        """Decide ``pairs`` (each with a moving object) in each configuration of
        ``poses`` (C, m, 4, 4) into ``codes``, ``colliding`` (C, P); returns the
        certificates by (configuration, pair)."""
        layout, scene = self.layout, self.scene
        table, n = layout.table, len(layout.table.names)
        count, m = poses.shape[:2]
        # slot[c, i]: the row of object i's placed bounds in configuration c: its
        # standing row (< n), or one of the C * m rows placed for the movers
        slot = np.broadcast_to(np.arange(n), (count, n)).copy()
        slot[:, ids] = n + np.arange(count * m).reshape(count, m)
        moved = layout.place(np.tile(ids, count), poses.reshape(-1, 4, 4))
        kdop, centre, axes = (np.concatenate([a, b]) for a, b in zip(self.placed(), moved))
        obj = np.r_[np.arange(n), np.tile(ids, count)]
        slot_poses = np.concatenate([scene.poses, poses.reshape(-1, 4, 4)])
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
        layout = self.layout
        body_a, body_b = layout.bodies[i], layout.bodies[j]
        certificates = {}
        if certify:
            from cadpipe.collision.certificate import find_certificate

            for e in range(len(poses_a)):
                cert = find_certificate(body_a, poses_a[e], body_b, poses_b[e],
                                        names=(layout.table.names[i], layout.table.names[j]))
                if cert is not None:
                    certificates[e] = cert
        exact = STAGE_CODE["analytic" if body_a.kind == body_b.kind == "chain" else "fcl"]
        if not certificates:
            touching, contained = narrow.collide(body_a, poses_a, body_b, poses_b)
            codes = np.where(contained, STAGE_CODE["containment"], exact).astype(np.int8)
            return codes, touching, {}
        todo = np.ones(len(poses_a), bool)
        todo[list(certificates)] = False
        codes = np.full(len(poses_a), STAGE_CODE["certificate"], np.int8)
        touching = np.zeros(len(poses_a), bool)
        if todo.any():
            hit, contained = narrow.collide(body_a, poses_a[todo], body_b, poses_b[todo])
            codes[todo] = np.where(contained, STAGE_CODE["containment"], exact)
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
        bodies = self.layout.bodies
        return bool(narrow.collide(bodies[i], pose_i[None], bodies[j], pose_j[None])[0][0])

    def distance(self, a, b):
        """Clearance between ``a`` and ``b`` with the closest points (a
        :class:`Clearance`); 0 when they touch or one contains the other."""
        scene = self.scene
        i, j = scene.index(a), scene.index(b)
        dist, pa, pb, stage = narrow.distance(scene.bodies[i], scene.poses[i], scene.bodies[j],
                                              scene.poses[j])
        return Clearance(float(dist), pa, pb, dist <= 0, stage)

    def separate(self, a, b, step_degrees=None):
        """The source's separation certificate for ``a`` and ``b``, or None.

        A returned :class:`~cadpipe.collision.certificate.Certificate` has passed
        its independent verifier: it proves the pair does not touch.
        """
        from cadpipe.collision.certificate import find_certificate

        scene = self.scene
        i, j = scene.index(a), scene.index(b)
        options = {} if step_degrees is None else {"step_degrees": step_degrees}
        return find_certificate(scene.bodies[i], scene.poses[i], scene.bodies[j],
                                scene.poses[j], names=(a, b), **options)

    def inside(self, pipe_name, points):
        """Virtual fixture: which ``(P, 3)`` world points lie inside the pipe (or other
        ball chain) ``pipe_name``, and where the polyline through them first leaves it.

        Returns a :class:`PipeContainment`.
        """
        from cadpipe._validate import as_points
        from cadpipe.collision.fixture import containment

        i = self.scene.index(pipe_name)
        body = self.scene.bodies[i]
        if body.kind != "chain":
            raise InputError(f"inside({pipe_name!r}): that object is a mesh; inside() needs a "
                             "pipe, sphere or capsule (use distance() for meshes)",
                             part=pipe_name)
        points = as_points(points, "points")
        return containment(body.chain.moved(self.scene.poses[i]), points)


class Placed:
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


class Answers:
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


