"""The collision world: a :class:`~cadpipe.collision.scene.Scene` of named objects with
the queries of its :class:`~cadpipe.collision.checker.Checker` as methods.

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

from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from cadpipe.collision import narrow
from cadpipe.collision.checker import Checker
from cadpipe.collision.reports import Clearance, CollisionReport, CollisionReports
from cadpipe.collision.scene import Scene, as_pose, as_poses, plain_pose
from cadpipe.errors import InputError

if TYPE_CHECKING:                       # the answer types of the optional queries
    from cadpipe.collision.certificate import Certificate
    from cadpipe.collision.fixture import PipeContainment
    from cadpipe.collision.motion import MotionCheck


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
        robot, base, ids = self.robot_links(group)
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
        ids = np.array([self.index(name) for name in poses])
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
        return float(narrow.distance(self.body(a), pose_a, self.body(b), pose_b,
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
        i, j = self.index(a), self.index(b)
        # float64 4x4 arrays go to the kernel as they are (it checks them); anything
        # else, and any pose it refuses, through as_pose (which converts or says why)
        found = self.checker.collide_at(i, pose_a, j, pose_b) \
            if plain_pose(pose_a) and plain_pose(pose_b) else None
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
