"""The Cartesian path a robot frame sweeps along a joint trajectory.

A trajectory is a sequence of joint configurations with the straight
joint-space motion between them (as planners and
:meth:`CollisionWorld.check_motion` mean it). The frame's origin moves on a
curve, not on the chords between the waypoints' positions, so each segment
is sampled densely enough that the polyline follows it: with a bound ``V`` of
the origin's speed all along the segment (:func:`cadpipe.collision.motion.frame_speeds`,
the motion check's bound), samples ``dt <= step / V`` apart in the segment
parameter are at most ``step`` apart along the curve, so every point of the
curve is within ``step / 2`` of the nearer sample. A pipe of radius ``r``
around the polyline built with ``envelope=True`` (its polygon's flats at
``r``) therefore holds the ``r - step / 2`` neighbourhood of the true curve.

A point fixed in the frame at ``p`` from its origin (a tool centre point)
moves at most ``|p| W`` faster than the origin, ``W`` the sum of the
revolute joints' changes on the frame's chain (a bound of how fast the frame
turns), so its bound is ``V + |p| W`` (``frame_speeds(..., reach=|p|)``).
"""

import numpy as np

from cadpipe.collision.motion import frame_speeds
from cadpipe.errors import InputError

#: most samples per segment (a guard against a step far below the motion's size)
MAX_SAMPLES = 100_000


def trajectory_points(robot, configurations, frame, step, base=None, point=None):
    """Points along the path of ``frame``'s origin (or of a ``point`` fixed in
    it) over a joint trajectory.

    Parameters
    ----------
    robot : Robot
    configurations : (C, A) array
        Waypoints over ``robot.actuated`` (radians, metres), C >= 2.
    frame : str
        Any frame of the robot (``robot.frames``), with or without geometry.
    step : float
        Largest distance from any point of the true path to the nearer of the
        returned samples around it, doubled (length units).
    base : (4, 4) array, optional
        Where the robot's base stands.
    point : (3,) array, optional
        The point followed, in ``frame``'s coordinates (default its origin).

    Returns
    -------
    (N, 3) array of points, the waypoints' positions among them; and the
    ``(N,)`` time of each point (waypoint ``k`` at time ``k``).
    """
    try:
        step = float(step)
    except (TypeError, ValueError):
        step = float("nan")
    if not step > 0 or not np.isfinite(step):
        raise InputError(f"step must be a positive number, got {step!r}", key="step")
    if frame not in robot.frames:
        raise InputError(f"frame {frame!r}: robot {robot.name} has no such link; frames: "
                         + ", ".join(robot.frames), key="frame")
    values = robot.joint_array(configurations)
    if len(values) < 2:
        raise InputError("a trajectory needs at least two configurations",
                         key="configurations")
    point = np.zeros(3) if point is None else np.asarray(point, np.float64)
    if point.shape != (3,) or not np.isfinite(point).all():
        raise InputError(f"point must be [x, y, z], got {point.tolist()!r}", key="point")
    q = np.asarray(configurations, np.float64)
    speeds = frame_speeds(robot, frame, values, reach=np.linalg.norm(point))
    counts = np.maximum(1, np.ceil(speeds / step)).astype(np.int64)
    if counts.max() > MAX_SAMPLES:
        raise InputError(f"step {step:g} would need {int(counts.max())} samples on one "
                         f"segment; use a step of at least {speeds.max() / MAX_SAMPLES:.3g}",
                         key="step")
    segment = np.repeat(np.arange(len(counts)), counts)
    fraction = np.concatenate([np.arange(n) / n for n in counts])
    times = np.append(segment + fraction, len(counts))
    samples = np.concatenate([q[segment] + fraction[:, None] * (q[segment + 1] - q[segment]),
                              q[-1:]])
    poses = robot.frame_poses(samples, frame, base)
    return poses[:, :3, :3] @ point + poses[:, :3, 3], times


def path_from_trajectory(robot, configurations, frame, step, base=None, point=None):
    """The :class:`~cadpipe.Path` of ``frame``'s origin (or ``point``) over a
    joint trajectory; see :func:`trajectory_points` (repeated points of a pause
    are dropped)."""
    from cadpipe.geometry.path import Path

    points, _ = trajectory_points(robot, configurations, frame, step, base, point)
    return Path(points)
