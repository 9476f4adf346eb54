"""A robot's joint trajectory as a USD animation, beside its safety pipes.

Every link with collision geometry becomes an Xform prim with one
``xformOp:transform`` (the link's world pose) and the link's mesh below it.
The trajectory is sampled at ``fps`` frames per second -- linearly in joint
space between the waypoints, the motion planners and
:meth:`CollisionWorld.check_motion` mean -- and every link's pose at every
frame is a time sample of its op, static links (and links whose pose is the
identity) included, so a DCC or VR viewer scrubbing the timeline sees the
rigid motion itself: USD interpolates matrices entry by entry, which is not a
rigid motion, so the frames are sampled rather than left to interpolation.
Pipes and other meshes given in ``extras`` stand still beside the robot.
"""

import numpy as np

from cadpipe.errors import InputError
from cadpipe.core.formats import suffix_of
from cadpipe.solids.scene import Scene, ScenePart, as_scene


def trajectory_frames(robot, configurations, times=None, fps=24.0):
    """Joint configurations ``(F, A)`` at each frame, and each frame's time code.

    ``times`` are the waypoints' times in seconds (increasing; one second per
    segment when None); the last frame is the last waypoint.
    """
    robot.joint_array(configurations)                      # shape and limits
    q = np.asarray(configurations, np.float64)
    if len(q) < 2:
        raise InputError("a trajectory needs at least two configurations", key="configurations")
    times = np.arange(len(q), dtype=np.float64) if times is None else \
        np.asarray(times, np.float64)
    if times.shape != (len(q),) or not np.all(np.isfinite(times)) or \
            not np.all(np.diff(times) > 0):
        raise InputError(f"times: expected {len(q)} increasing seconds, one per waypoint",
                         key="times")
    if not fps > 0:
        raise InputError(f"fps must be > 0, got {fps!r}", key="fps")
    frames = np.arange(int(np.ceil((times[-1] - times[0]) * fps - 1e-9)) + 1)
    at = np.minimum(times[0] + frames / fps, times[-1])
    segment = np.clip(np.searchsorted(times, at, side="right") - 1, 0, len(q) - 2)
    fraction = (at - times[segment]) / (times[segment + 1] - times[segment])
    return q[segment] + fraction[:, None] * (q[segment + 1] - q[segment]), frames


def write_trajectory_usd(path, robot, configurations, times=None, fps=24.0, extras=None,
                         base=None, name=None):
    """Write a joint trajectory as an animated .usda/.usdc/.usdz, atomically.

    Parameters
    ----------
    path : path
        Output file; its suffix picks the USD flavour.
    robot : Robot
    configurations : (C, A) array
        Waypoints over ``robot.actuated``.
    times : (C,) array, optional
        Seconds at each waypoint (one second per segment by default).
    fps : float
        Frames per second of the samples (``timeCodesPerSecond``).
    extras : mapping of name -> Mesh or Pipe, optional
        Static geometry to show beside the robot (a safety pipe, obstacles).
    base : (4, 4) array, optional
        Where the robot's base stands.
    name : str, optional
        The root prim's name (the robot's name by default).

    Returns
    -------
    int
        The number of frames written.
    """
    from pxr import Gf, Usd, UsdGeom

    from cadpipe.io.usd import build_stage, save_stage

    if suffix_of(path) not in ("usda", "usdc", "usdz"):
        raise InputError("an animation is written as .usda, .usdc or .usdz",
                         key="path", file=path)
    q, codes = trajectory_frames(robot, configurations, times, fps)
    poses = robot.link_pose_array(q, base)                        # (F, L, 4, 4)
    parts = [ScenePart(link, mesh, transform=poses[0, k])
             for k, (link, mesh) in enumerate(robot.link_meshes.items())]
    for label, obj in (extras or {}).items():
        extra = as_scene(obj).parts[0]
        parts.append(ScenePart(str(label), extra.mesh, attributes=extra.attributes))
    stage = build_stage(Scene(name=name or robot.name, parts=tuple(parts)))
    stage.SetStartTimeCode(float(codes[0]))
    stage.SetEndTimeCode(float(codes[-1]))
    stage.SetTimeCodesPerSecond(float(fps))
    stage.SetFramesPerSecond(float(fps))
    # build_stage defines the materials scope, then one Xform per part, in order
    links = [p for p in stage.GetDefaultPrim().GetChildren() if p.IsA(UsdGeom.Xform)]
    for k, prim in enumerate(links[:len(robot.link_meshes)]):
        op = UsdGeom.Xformable(prim).GetOrderedXformOps()[0]
        op.GetAttr().Clear()
        for f, code in enumerate(codes):
            op.Set(Gf.Matrix4d(poses[f, k].T.tolist()), Usd.TimeCode(float(code)))
    save_stage(stage, path)
    return len(codes)
