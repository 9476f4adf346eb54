"""Plan the Panda around a cable duct and through a window with OMPL, check the
planned motion continuously, and write the safety pipe of its hand.

Run: python examples/plan_panda.py [OUT_FOLDER]
"""

import sys
from pathlib import Path as FilePath

import numpy as np

from cadpipe import CollisionWorld, Path, Pipe
from cadpipe.collision import Box, Robot
from cadpipe.planning import Counter, plan

PANDA = FilePath(__file__).resolve().parent.parent / "assets" / "robots" / "panda"


def shifted(x, y, z):
    pose = np.eye(4)
    pose[:3, 3] = x, y, z
    return pose


def obstacles():
    """A wall with a window (four boxes around a 0.4 m square opening, its sill 0.3 m
    up) and a cable duct (a pipe) across the Panda's workspace: name -> (shape, pose)."""
    x, t = 0.55, 0.02
    duct = Path([[-0.5, 0.45, 0.15], [0.0, 0.5, 0.55], [0.3, 0.6, 0.4]])
    return {"wall_bottom": (Box((t, 1.4, 0.3)), shifted(x, 0.0, 0.15)),
            "wall_top": (Box((t, 1.4, 0.4)), shifted(x, 0.0, 0.9)),
            "wall_left": (Box((t, 0.5, 0.4)), shifted(x, 0.45, 0.5)),
            "wall_right": (Box((t, 0.5, 0.4)), shifted(x, -0.45, 0.5)),
            "duct": (Pipe(duct, radius=0.04), np.eye(4))}


def window_cell(robot):
    """The Panda in the :func:`obstacles` scene (the wall's pieces may touch)."""
    world = CollisionWorld()
    world.add_robot(robot)
    for name, (shape, pose) in obstacles().items():
        world.add(name, shape, transform=pose)
    for a, b in (("wall_bottom", "wall_left"), ("wall_bottom", "wall_right"),
                 ("wall_top", "wall_left"), ("wall_top", "wall_right")):
        world.allow(a, b, reason="one wall")
    return world


START = np.array([1.2, -0.3, 0.0, -2.4, 0.0, 2.1, 0.8, 0.02])      # hand beside the duct
GOAL = np.array([0.0, 0.45, 0.0, -1.2, 0.0, 1.65, 0.8, 0.02])      # hand through the window


def main(out=None):
    robot = Robot.from_urdf(PANDA / "panda.urdf", srdf=PANDA / "panda.srdf")
    world = window_cell(robot)
    counter = Counter()
    path = plan(world, robot.name, START, GOAL, seconds=60.0, counter=counter,
                step=0.5)
    check = world.check_path(robot.name, path, between=True)
    print(f"{len(path)} waypoints, {counter.states} states and {counter.motions} motions "
          f"checked; the planned motion is {'free' if check.free else 'NOT free'}")
    if out is not None:
        from cadpipe.io.usd_animation import write_trajectory_usd

        out = FilePath(out)
        out.mkdir(parents=True, exist_ok=True)
        tcp = robot.frame_path(path, frame="panda_hand_tcp", step=0.01)
        # envelope=True: the polygon's flats at the radius, so the pipe holds every
        # point within 0.06 - 0.01 / 2 of the hand's true motion
        pipe = Pipe(tcp, radius=0.06, envelope=True)
        pipe.mesh().export(out / "tcp_pipe.stl")
        write_trajectory_usd(out / "panda_motion.usda", robot, path, extras={"tcp_pipe": pipe})
        print(f"wrote {out / 'tcp_pipe.stl'} and {out / 'panda_motion.usda'}")
    return path


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else None)
