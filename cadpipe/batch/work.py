"""One batch job, run where it lands (a Dask worker process or this one).

:func:`execute` builds a spec or checks a trajectory, writes the job's files into
``OUT/<name>/`` (each atomically), writes ``job.json`` last -- with the job's content
hash, the mark that its outputs are complete -- and returns the same small record. A
job run twice (Dask recomputes a result lost with its worker) writes the same bytes
again, so a folder never mixes two versions of a job. A job that raises is
recorded as failed with its one-line error; nothing escapes to stop the batch. The
worker keeps the last few robot cells it built (the world, its bounds), since a batch
usually checks many trajectories in one cell.
"""

import json
import os
import socket
import time
from collections import OrderedDict
from pathlib import Path as FilePath

import numpy as np

from cadpipe import limits
from cadpipe.errors import CadpipeError, InputError, LimitError
from cadpipe.io.files import atomic_path, ensure_folder

#: the record a finished job leaves in its folder (written last)
RECORD = "job.json"
#: checked configurations per trajectory, at most (memory of the broad phase)
MAX_CONFIGURATIONS = 1_000_000
#: robot cells a worker keeps built
CELLS_KEPT = 4
_cells = OrderedDict()


def one_line(exc):
    """An exception as the one line a summary row shows."""
    text = str(exc) if isinstance(exc, CadpipeError) else f"{type(exc).__name__}: {exc}"
    line = text.strip().splitlines()[0] if text.strip() else type(exc).__name__
    return line if len(line) <= 500 else line[:497] + "..."


def write_json(path, value):
    """``value`` as indented JSON at ``path``, whole or not at all."""
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(value, indent=2) + "\n", encoding="utf-8")
    return FilePath(path)


def execute(job, out, budgets=None):
    """Run ``job`` (a :class:`~cadpipe.batch.jobs.Job`), writing into ``out/<job.name>/``,
    with ``budgets`` (the caller's changed :mod:`cadpipe.limits` as a dict, which a
    context variable does not carry to another process) in force.

    Returns
    -------
    dict
        The job's record: ``name``, ``kind``, ``hash``, ``spec``, ``trajectory``,
        ``params``, ``status`` ("ok" or "failed"), ``verdict`` ("built", "clear",
        "collision" or "error"), ``error`` (one line or None), ``first_collision``,
        ``clearance``, ``solid``, ``files`` (name -> bytes, in the job's folder) and
        ``run`` (seconds, worker), as ``job.json`` holds it.
    """
    start = time.perf_counter()
    folder = FilePath(out) / job.name
    record = row(job, "ok")
    try:
        ensure_folder(folder)
        with limits.using(**(budgets or {})):
            record.update(build(job, folder) if job.kind == "build" else check(job, folder))
    except Exception as exc:        # noqa: BLE001  (a failing job is recorded, the batch goes on)
        record.update(status="failed", verdict="error", error=one_line(exc), files={})
    record["run"] = {"seconds": round(time.perf_counter() - start, 4),
                     "worker": f"{socket.gethostname()}:{os.getpid()}"}
    if folder.is_dir():
        try:
            write_json(folder / RECORD, record)
        except CadpipeError as exc:
            record.update(status="failed", verdict="error", error=one_line(exc))
    return record


def row(job, status, error=None):
    """A record of ``job`` with nothing in it yet but its identity and ``status``
    ("ok", "failed", or "not run" for a job an interrupted batch did not get to)."""
    return {"name": job.name, "kind": job.kind, "hash": job.hash, "spec": str(job.spec),
            "trajectory": None if job.trajectory is None else str(job.trajectory),
            "params": job.params, "status": status,
            "verdict": "error" if status == "failed" else None, "error": error,
            "first_collision": None, "clearance": None, "solid": None, "files": {},
            "run": None}


def _sizes(folder, names):
    return {name: (folder / name).stat().st_size for name in names}


# -- spec jobs --------------------------------------------------------------------------
def build(job, folder):
    """Build a spec job's assembly and write its outputs; returns the record's fields."""
    from cadpipe.spec import read

    spec = read(job.spec, data=job.table)
    targets = [(name, None, {}) for name in job.outputs] or \
        [(path.name, mode, options) for path, mode, options in spec.outputs]
    if not targets:
        raise InputError('nothing to write: the spec lists no outputs; give the job '
                         'outputs = ["part.stl"]', key="outputs")
    names = [name for name, _, _ in targets]
    if len(set(names)) != len(names):
        raise InputError(f"two outputs are named {next(n for n in names if names.count(n) > 1)!r}"
                         " in the job's folder; rename one", key="outputs")
    solid = spec.assembly.union()
    for name, mode, options in targets:
        spec.assembly.export(folder / name, mode, **options)
    return {"verdict": "built", "files": _sizes(folder, names),
            "solid": {"parts": len(spec.assembly.parts), "triangles": len(solid.faces),
                      "bodies": solid.n_bodies, "volume": solid.volume,
                      "units": spec.assembly.units, "watertight": solid.is_watertight}}


# -- trajectory jobs --------------------------------------------------------------------
def cell(spec_file, table):
    """``(world, posed robot, check options, link hull vertices)`` of a robot cell spec,
    built once per worker for the last few cells."""
    from cadpipe.spec import world_from_spec
    from cadpipe.spec import read

    key = (str(spec_file), json.dumps(table, sort_keys=True))
    if key in _cells:
        _cells.move_to_end(key)
        return _cells[key]
    spec = read(spec_file, data=table)
    if spec.cell.robot is None:
        raise InputError("the cell spec has no [robot] table; a trajectory job needs a robot",
                         key="robot")
    posed = spec.cell.robot
    hulls = {link: mesh.vertices[_hull(mesh.vertices)]
             for link, mesh in posed.robot.link_meshes.items()}
    _cells[key] = (world_from_spec(spec), posed, dict(spec.cell.check), hulls)
    while len(_cells) > CELLS_KEPT:
        _cells.popitem(last=False)
    return _cells[key]


def _hull(points):
    """Indices of the convex hull's vertices (all points if they span no volume)."""
    from scipy.spatial import ConvexHull, QhullError

    try:
        return ConvexHull(points).vertices
    except (QhullError, ValueError):
        return np.arange(len(points))


def configurations(job, posed):
    """The job's ``(C, A)`` waypoints over the robot's actuated joints; joints the
    trajectory's header leaves out keep the cell's pose."""
    robot, q = posed.robot, job.configurations
    if job.columns is None:
        if q.shape[1] != len(robot.actuated):
            raise InputError(f"{q.shape[1]} values per waypoint, but robot {robot.name} has "
                             f"{len(robot.actuated)} joints ({', '.join(robot.actuated)}); "
                             "name the columns in a header row to give fewer",
                             file=job.trajectory)
        return q
    unknown = [c for c in job.columns if c not in robot.actuated]
    if unknown:
        raise InputError(f"column {unknown[0]!r} is not a joint of robot {robot.name} "
                         f"({', '.join(robot.actuated)}, or time)", file=job.trajectory)
    full = np.tile([posed.joints[name] for name in robot.actuated], (len(q), 1))
    full[:, [robot.actuated.index(c) for c in job.columns]] = q
    return full


def densify(q, step):
    """Waypoints with configurations added between them, no joint moving more than
    ``step`` from one to the next.

    Parameters
    ----------
    q : (C, A) float
        Waypoints.
    step : float
        Largest change of any joint between neighbours, radians or metres.

    Returns
    -------
    dense : (D, A) float
        The configurations to check, the waypoints among them, in order.
    at : (D,) float
        Position of each along the waypoints: ``k + f`` is ``f`` of the way from
        waypoint ``k`` to ``k + 1``.
    """
    if len(q) == 1:
        return q, np.zeros(1)
    counts = np.maximum(1, np.ceil(np.abs(np.diff(q, axis=0)).max(axis=1) / step)).astype(int)
    if counts.sum() + 1 > MAX_CONFIGURATIONS:
        raise LimitError(f"the trajectory needs {counts.sum() + 1} configurations at step "
                         f"{step:g}, more than {MAX_CONFIGURATIONS}; use a larger step",
                         key="step")
    segment = np.repeat(np.arange(len(q) - 1), counts)
    fraction = (np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)) \
        / np.repeat(counts, counts)
    dense = q[segment] + fraction[:, None] * (q[segment + 1] - q[segment])
    return np.vstack([dense, q[-1:]]), np.r_[segment + fraction, len(q) - 1.0]


def _moment(job, at):
    """``{"waypoint": ..., "time": ...}`` of a position along the waypoints."""
    time_s = None if job.times is None else \
        float(np.interp(at, np.arange(len(job.times)), job.times))
    return {"waypoint": round(float(at), 9), "time": time_s}


def clearance(world, posed, hulls, dense, at):
    """Smallest distance between the robot and the cell's other objects over the
    configurations ``dense``, pairs allowed in the world left out.

    Box gaps bound every (configuration, link, object) distance from below; exact
    distances are taken in order of those bounds until the next bound exceeds the best
    distance found, so only the few closest candidates are measured.

    Returns ``(distance, link, object, index into dense)``, or None with no pair to measure.
    """
    robot, group = posed.robot, posed.group
    links = list(robot.link_meshes)
    others = [n for n in world.names if world.group(n) != group]
    allowed = {frozenset(p[:2]) for p in world.allowed}
    pairs = [(i, j) for i, a in enumerate(links) for j, b in enumerate(others)
             if frozenset((a, b)) not in allowed]
    if not pairs:
        return None
    poses = robot.link_pose_array(dense, posed.transform)              # (D, L, 4, 4)
    lo, hi = (np.empty((len(dense), len(links), 3)) for _ in range(2))
    for i, link in enumerate(links):
        moved = hulls[link] @ poses[:, i, :3, :3].transpose(0, 2, 1) + poses[:, i, None, :3, 3]
        lo[:, i], hi[:, i] = moved.min(axis=1), moved.max(axis=1)
    boxes = np.array([world.bounds(b) for b in others])                 # (O, 2, 3)
    li, oj = np.array(pairs).T
    gap = np.maximum(0.0, np.maximum(boxes[oj, 0][None] - hi[:, li],
                                     lo[:, li] - boxes[oj, 1][None]))
    bound = np.linalg.norm(gap, axis=2).ravel()                         # (D * pairs,)
    best = (np.inf, None, None, None)
    for e in np.argsort(bound, kind="stable"):
        if bound[e] >= best[0]:
            break
        d, p = divmod(int(e), len(pairs))
        world.set_joints(group, dense[d])
        a, b = links[li[p]], others[oj[p]]
        found = world.distance(a, b).distance
        if found < best[0]:
            best = (found, a, b, d)
    return best


def _motion(job, world, posed, q):
    """The certificate of the motion through the waypoints (a
    :class:`~cadpipe.collision.motion.MotionCheck`), or None unless the job asks for it
    (``between``) and the robot moves."""
    if not job.between or len(q) < 2:
        return None
    return world.check_path(posed.group, q, between=True, tolerance=job.tolerance,
                            margin=job.margin)


def _tool(robot, tool):
    """The tool frame: ``tool`` (any frame of the robot, with or without geometry), or
    the link with geometry deepest in the tree."""
    if tool is not None:
        if tool not in robot.frames:
            raise InputError(f"{tool!r} is not a frame of robot {robot.name} "
                             f"({', '.join(robot.frames)})", key="tool")
        return tool
    depth = {robot.base: 0}
    for joint in robot.joints:                   # parents come before children
        depth[joint.child] = depth[joint.parent] + 1
    return max(robot.link_meshes, key=lambda link: depth[link])


#: the safety pipe's path follows the tool point within this fraction of its radius
SAMPLING = 0.05


def safety_pipe(job, posed, q):
    """``(tool frame, pipe)``: the safety pipe around the tool point's path over the
    waypoints ``q`` (:func:`~cadpipe.collision.trajectory.trajectory_points`, within
    ``SAMPLING r`` of the true motion), its radius widened by that much so the whole
    motion lies ``r`` inside its flats; pipe None when the tool stands still."""
    from cadpipe.collision.trajectory import trajectory_points
    from cadpipe.geometry.path import Path
    from cadpipe.geometry.pipe import Pipe

    tool = _tool(posed.robot, job.tool)
    options = {k: v for k, v in job.pipe.items() if v is not None}
    if len(q) < 2:
        return tool, None
    follows = SAMPLING * options["radius"]
    points, _ = trajectory_points(posed.robot, q, tool, 2 * follows, posed.transform, job.tcp)
    if np.ptp(points, axis=0).max() <= 1e-9:
        return tool, None
    options["radius"] += follows
    return tool, Pipe(Path(points), envelope=True, **options)


def check(job, folder):
    """Check a trajectory job against its cell and write its safety pipe and report;
    returns the record's fields."""
    world, posed, options, hulls = cell(job.spec, job.table)
    q = configurations(job, posed)
    posed.robot.joint_array(q)        # within the joint limits (so is every move between)
    dense, at = densify(q, job.step)
    # every pair at every configuration: [check]'s first_hit and only do not apply here
    reports = world.check_path(posed.group, dense, stop_after_self=options["stop_after_self"],
                               certify=options["certify"])
    names = world.names
    first_of, second_of = np.triu_indices(len(names), k=1)
    hits = reports.pair_colliding
    collisions = [{"a": names[first_of[p]], "b": names[second_of[p]],
                   **_moment(job, at[int(np.argmax(hits[:, p]))]),
                   "configurations": int(hits[:, p].sum())}
                  for p in np.flatnonzero(hits.any(axis=0))]
    first = None
    if reports.colliding.any():
        f = int(np.argmax(reports.colliding))
        first = {**_moment(job, at[f]),
                 "pairs": [[a, b] for a, b, _ in reports[f].collisions]}
    motion = _motion(job, world, posed, q)
    moved = None
    if motion is not None and not motion.free:
        moved = {**_moment(job, motion.segment + motion.time), "pair": list(motion.pair),
                 "clearance": motion.clearance}
        contact = motion.margin == 0
        if contact and (first is None or moved["waypoint"] < first["waypoint"]):
            first = {**_moment(job, moved["waypoint"]), "pairs": [moved["pair"]]}
        if contact and set(moved["pair"]) not in [{c["a"], c["b"]} for c in collisions]:
            collisions.append({"a": moved["pair"][0], "b": moved["pair"][1],
                               **_moment(job, moved["waypoint"]), "configurations": 0})
    if first is not None:
        verdict = "collision"
        gap = {"distance": 0.0, "a": first["pairs"][0][0], "b": first["pairs"][0][1],
               **_moment(job, first["waypoint"])}
    else:
        verdict = "clear" if moved is None else "too close"
        found = clearance(world, posed, hulls, dense, at)
        gap = None if found is None else {"distance": float(found[0]), "a": found[1],
                                          "b": found[2], **_moment(job, at[found[3]])}
    tool, pipe = safety_pipe(job, posed, q)
    files = []
    pipe_report = None
    if pipe is not None:
        mesh = pipe.mesh()
        mesh.export(folder / "safety_pipe.stl")
        files.append("safety_pipe.stl")
        pipe_report = {"file": "safety_pipe.stl", "radius": job.pipe["radius"],
                       "sides": pipe.sides, "triangles": len(mesh.faces), "volume_m3": mesh.volume,
                       "watertight": mesh.is_watertight}
    write_json(folder / "report.json", {
        "verdict": verdict, "waypoints": len(q), "checked": len(dense), "step": job.step,
        "motion": None if motion is None else {
            "free": motion.free, "tolerance": motion.tolerance, "margin": motion.margin,
            "states": motion.states, "distance_calls": motion.distance_calls,
            "refused_at": moved},
        "first_collision": first, "clearance": gap, "collisions": collisions,
        "tool": tool, "tcp": list(job.tcp), "safety_pipe": pipe_report})
    files.append("report.json")
    return {"verdict": verdict, "first_collision": first, "clearance": gap,
            "files": _sizes(folder, files)}
