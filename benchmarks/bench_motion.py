"""Motion checks, OMPL planning and fixture queries: cadpipe against the glue a user
writes with python-fcl, OMPL's own validator, trimesh and a KD-tree.

Part 1, motions: the Panda in the window cell of ``examples/plan_panda.py`` (a wall
with a window, a cable duct), random motions of RRTConnect's size (0.5 rad joint-space
steps from free states) and longer ones (1.5 rad). cadpipe's ``check_motion`` (a proof)
against the python-fcl loop of ``bench_collision.py`` run at every state OMPL's
discrete validator would check (MoveIt's default resolution, 1% of the joint space's
extent), and at the states the proof posed the robot at (``proof_states``). Two
readings: (a) per state evaluated, cadpipe against the FCL loop over those same
states; (b) the whole proof against the FCL loop at OMPL's resolution (the stricter
one). Also how many motions each calls free that collide at one of 2,000
interpolated states.

Part 2, planning: RRTConnect (range 0.5) from the example's start to its goal, with
cadpipe's validators (exact, and with a ``--margin`` padding) against the FCL loop as
state validity checker and OMPL's discrete motion validator. Reported: plans per
second, wall and CPU time per plan (medians: RRTConnect is randomized), validity and
motion calls, and the fraction of planned paths that collide between their states
when re-checked at 400 states per segment (cadpipe must be 0).

Part 3, fixture queries: 500,000 points around a 300-point helix pipe: cadpipe's
``locate`` (inside, wall distance, nearest centreline point, arc length, tangent; exact)
against a KD-tree + segment projection baseline (8 candidate segments, unverified) and
trimesh's ``proximity.signed_distance`` on the pipe's mesh (on 2,000 of the points).

Timings are medians of ``--repeat`` interleaved runs (A B A B ...) after a warm-up.

Run: .venv/bin/python benchmarks/bench_motion.py [--motions N] [--plans N] [--repeat R]
"""

import argparse
import sys
import time
from pathlib import Path as FilePath

import numpy as np

ROOT = FilePath(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "examples"))
sys.path.insert(0, str(ROOT / "benchmarks"))

import plan_panda  # noqa: E402
from _common import FclLoop, interleaved, kdtree_baseline  # noqa: E402

from cadpipe import Path, Pipe  # noqa: E402
from cadpipe.collision import Robot  # noqa: E402
from cadpipe.collision.fixture import locate  # noqa: E402
from cadpipe.collision.motion import proof_states, robot_collides  # noqa: E402

#: OMPL's default longest valid segment: this fraction of the state space's extent
RESOLUTION = 0.01
DENSE = 2000


def cell():
    robot = Robot.from_urdf(plan_panda.PANDA / "panda.urdf", srdf=plan_panda.PANDA / "panda.srdf")
    world = plan_panda.window_cell(robot)
    allowed = {frozenset((a, b)) for a, b, _ in world.allowed}
    return robot, world, FclLoop(robot, plan_panda.obstacles(), allowed)


def extent(robot):
    lower, upper = robot.limits
    return float(np.linalg.norm(upper - lower))


def sampled_states(robot, q_a, q_b):
    """The states OMPL's discrete motion validator checks between two states."""
    n = max(1, int(np.ceil(np.linalg.norm(q_b - q_a) / (RESOLUTION * extent(robot)))))
    t = np.arange(1, n + 1) / n
    return q_a + t[:, None] * (q_b - q_a)


def motions(robot, world, count, rng, step=0.5):
    """``count`` motions of joint-space length ``step`` between free states."""
    lower, upper = robot.limits
    found = []
    while len(found) < count:
        q_a = rng.uniform(lower, upper)
        direction = rng.normal(size=len(q_a))
        q_b = np.clip(q_a + step * direction / np.linalg.norm(direction), lower, upper)
        if not robot_collides(world, robot.name, np.stack([q_a, q_b])).any():
            found.append((q_a, q_b))
    return found


def part_motions(robot, world, loop, count, repeat, step):
    rng = np.random.default_rng(0)
    pairs = motions(robot, world, count, rng, step)
    t = np.linspace(0.0, 1.0, DENSE)
    truth = [robot_collides(world, robot.name, a + t[:, None] * (b - a)).any() for a, b in pairs]
    states = [sampled_states(robot, a, b) for a, b in pairs]
    posed = [proof_states(world, robot.name, np.stack([a, b])) for a, b in pairs]

    def cadpipe():
        return [not world.check_motion(robot.name, a, b).free for a, b in pairs]

    def fcl_sampled():
        return [any(loop(q[None]) for q in s) for s in states]

    def fcl_posed():                  # the FCL loop at the states the proof posed the robot at
        return [any(loop(q[None]) for q in s) for s in posed]

    runs = {"cadpipe": cadpipe, "fcl": fcl_sampled, "fcl_posed": fcl_posed}
    wall, results = interleaved(runs, repeat)
    cpu, _ = interleaved(runs, repeat, clock=time.process_time)
    sampled, proof = sum(len(s) for s in states), sum(len(s) for s in posed)
    truth = np.array(truth)
    print(f"Part 1: {count} motions of {step} rad in the window cell ({int(truth.sum())} collide "
          f"between their free ends at one of {DENSE} states); medians of {repeat} interleaved "
          "runs, wall and CPU time")
    for name, label, per in (("cadpipe", "cadpipe check_motion (proof)", proof),
                             ("fcl", "python-fcl loop at OMPL's resolution", sampled),
                             ("fcl_posed", "python-fcl loop at the proof's states", proof)):
        # the proof's states end where it found contact: FCL there has no miss to count
        said = np.array(results[name])
        missed = "" if name == "fcl_posed" else \
            f"  missed {int((truth & ~said).sum())}/{int(truth.sum())}"
        print(f"  {label:40s} {wall[name] / count * 1e3:7.3f} ms/motion wall "
              f"{cpu[name] / count * 1e3:7.3f} ms CPU  {per / count:6.1f} states/motion"
              + missed)
    print(f"  (a) per state evaluated, CPU: cadpipe {cpu['cadpipe'] / proof * 1e6:.1f} us, "
          f"the FCL loop at those states {cpu['fcl_posed'] / proof * 1e6:.1f} us "
          f"(cadpipe/FCL {cpu['cadpipe'] / cpu['fcl_posed']:.3f}x)")
    print(f"  (b) the whole proof against the FCL loop at OMPL's resolution: wall "
          f"{wall['cadpipe'] / wall['fcl']:.3f}x, CPU {cpu['cadpipe'] / cpu['fcl']:.3f}x")
    few = pairs[:5]                   # the python-fcl loop at the dense states (no proof yet)
    start = time.process_time()
    for a, b in few:
        any(loop(q[None]) for q in a + t[:, None] * (b - a))
    dense = (time.process_time() - start) / len(few)
    print(f"  python-fcl loop at all {DENSE} dense states: {dense * 1e3:.0f} ms CPU/motion "
          f"(cadpipe {cpu['cadpipe'] / count / dense:.4f}x of it)")


def plan_with(robot, world, loop, validators, seconds=60.0):
    """``(path, states, motions, wall seconds, CPU seconds)`` of one RRTConnect plan;
    ``validators`` is "fcl" or "cadpipe" with an optional ":MARGIN"."""
    from ompl import geometric

    from cadpipe import planning

    counter = planning.Counter()
    start, cpu = time.perf_counter(), time.process_time()
    if validators.startswith("cadpipe"):
        margin = float(validators.partition(":")[2] or 0.0)
        try:
            path = planning.plan(world, robot.name, plan_panda.START, plan_panda.GOAL, seconds,
                                 counter=counter, step=0.5, margin=margin)
        except planning.PlanningError:
            path = None
        return (path, counter.states, counter.motions, time.perf_counter() - start,
                time.process_time() - cpu)
    space, bounds = planning.joint_space(robot)
    simple = geometric.SimpleSetup(space)
    simple._keep = bounds                         # OMPL holds it by reference
    count = len(robot.actuated)

    def valid(state):
        counter.states += 1
        return not loop(np.array([state[k] for k in range(count)])[None])

    simple.setStateValidityChecker(valid)          # OMPL's discrete motion validator stays
    information = simple.getSpaceInformation()
    information.setStateValidityCheckingResolution(RESOLUTION)
    planner = geometric.RRTConnect(information)
    planner.setRange(0.5)
    simple.setPlanner(planner)
    space = simple.getStateSpace()
    ends = []
    for q in (plan_panda.START, plan_panda.GOAL):
        s = space.allocState()
        for k, v in enumerate(q):
            s[k] = float(v)
        ends.append(s)
    simple.setStartAndGoalStates(*ends)
    solved = simple.solve(seconds)
    path = None
    if solved:
        simple.simplifySolution()
        path = np.array([[s[k] for k in range(count)]
                         for s in simple.getSolutionPath().getStates()])
    return path, counter.states, 0, time.perf_counter() - start, time.process_time() - cpu


def part_planning(robot, world, loop, plans, margin):
    t = np.linspace(0.0, 1.0, 400)
    rows = {"cadpipe": [], f"cadpipe:{margin:g}": [], "fcl": []}
    print(f"Part 2: RRTConnect (range 0.5), start -> goal through the window, {plans} plans "
          "each, interleaved; medians")
    for _ in range(plans):
        for name in rows:
            path, states, moves, wall, cpu = plan_with(robot, world, loop, name)
            bad = None
            if path is not None:
                dense = np.concatenate([a + t[:, None] * (b - a) for a, b in
                                        zip(path[:-1], path[1:])])
                bad = bool(robot_collides(world, robot.name, dense).any())
            rows[name].append((wall, cpu, states, moves, bad))
    labels = {"cadpipe": "cadpipe validators (certified motions)",
              f"cadpipe:{margin:g}": f"cadpipe, margin {margin:g} m",
              "fcl": "FCL loop + OMPL's discrete validator"}
    for name, r in rows.items():
        solved = [x for x in r if x[4] is not None]
        wall, cpu = np.median([x[0] for x in r]), np.median([x[1] for x in r])
        print(f"  {labels[name]:40s} {len(solved)}/{len(r)} solved  "
              f"{len(solved) / sum(x[0] for x in r):6.3f} plans/s wall  "
              f"median {wall:6.3f} s wall {cpu:6.3f} s CPU  "
              f"validity calls {np.median([x[2] for x in r]):6.0f}  "
              f"motion calls {np.median([x[3] for x in r]):6.0f}  "
              f"colliding between states {sum(x[4] for x in solved)}/{len(solved)}")
    cpu = {name: np.median([x[1] for x in r]) for name, r in rows.items()}
    print(f"  median CPU per plan, cadpipe/FCL: {cpu['cadpipe'] / cpu['fcl']:.2f}x; with the "
          f"margin {cpu[f'cadpipe:{margin:g}'] / cpu['fcl']:.2f}x")


def part_fixture(repeat):
    import trimesh
    from scipy.spatial import cKDTree

    t = np.linspace(0, 6 * np.pi, 300)
    centres = np.stack([np.cos(t), np.sin(t), 0.1 * t], axis=1)
    pipe = Pipe(Path(centres), radius=0.1)
    rng = np.random.default_rng(0)
    near = centres[rng.integers(0, 300, 500_000)] + rng.normal(0, 0.08, (500_000, 3))
    box = rng.uniform([-1.3, -1.3, -0.2], [1.3, 1.3, 2.1], (500_000, 3))
    a, b = centres[:-1], centres[1:]
    tree = cKDTree(0.5 * (a + b))
    radius = float(pipe.ring_radii[0])
    mesh = pipe.mesh().to_trimesh() if hasattr(pipe.mesh(), "to_trimesh") else \
        trimesh.Trimesh(pipe.mesh().vertices, pipe.mesh().faces)
    print(f"Part 3: fixture queries, 500,000 points, 300-point helix pipe; medians of {repeat}")
    for label, points in (("near the pipe", near), ("in its bounding box", box)):
        runs = {"cadpipe": lambda points=points: locate(pipe, points),
                "kdtree": lambda points=points: kdtree_baseline(tree, a, b, points, radius)}
        seconds, results = interleaved(runs, repeat)
        wrong = np.abs(results["kdtree"] - results["cadpipe"].signed_distance) > 1e-9
        rate = {name: len(points) / s for name, s in seconds.items()}
        print(f"  {label}:")
        print(f"    cadpipe locate (5 answers, exact)         {rate['cadpipe']:10.0f} points/s")
        print(f"    KD-tree + projection (distance only)      {rate['kdtree']:10.0f} points/s  "
              f"wrong distance at {int(wrong.sum())} points")
    sub = near[:2000]
    start = time.perf_counter()
    trimesh.proximity.signed_distance(mesh, sub)
    seconds = time.perf_counter() - start
    print(f"    trimesh proximity.signed_distance (mesh)  {len(sub) / seconds:10.0f} points/s")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--motions", type=int, default=100)
    parser.add_argument("--plans", type=int, default=9)
    parser.add_argument("--margin", type=float, default=0.002)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--parts", default="123")
    args = parser.parse_args()
    robot, world, loop = cell()
    if "1" in args.parts:
        for step in (0.5, 1.5):
            part_motions(robot, world, loop, args.motions, args.repeat, step)
    if "2" in args.parts:
        part_planning(robot, world, loop, args.plans, args.margin)
    if "3" in args.parts:
        part_fixture(args.repeat)


if __name__ == "__main__":
    main()
