"""Batch jobs: what one unit of work is, read from a JOBS file (TOML or JSON) or from tables.

A job is a spec to build, or a robot cell plus a trajectory to check; either spec may be a
template whose ``${name}`` placeholders are filled from parameter sets
(:mod:`cadpipe.batch.params`). Reading a JOBS file validates every key, reads every spec
and trajectory file and fills every template before anything runs, so bad input is one
error up front. A :class:`Job` holds only data -- the filled-in spec table, arrays --
so it travels to worker processes by pickle; its :attr:`Job.hash` identifies its content
(spec text, parameters, trajectory values, options, cadpipe's version) so that a re-run
can skip it. The file format is in ``docs/batch.md``.
"""

import glob
import hashlib
import json
import re
from dataclasses import dataclass, field, replace
from pathlib import Path as FilePath

import numpy as np

from cadpipe import limits
from cadpipe.batch.params import check_names, csv_rows, fill, parameter_sets, placeholders
from cadpipe.batch.summary import SUMMARY_HTML, SUMMARY_JSON
from cadpipe.errors import CadpipeError, InputError, SpecError
from cadpipe.spec import Number, SpecContext, parse

KINDS = ("build", "trajectory")
#: a job's name is its output folder's name
NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.+=-]{0,119}")
#: names of what the batch itself writes into OUT beside the job folders, in lower case
#: (on a case-insensitive disk ``Summary.json`` is the same file)
RESERVED = (SUMMARY_JSON, SUMMARY_HTML)
#: the stand-in file name of job tables given directly (relative to the current folder)
TABLES = "jobs"
#: trajectory columns that hold the time (seconds) rather than a joint value
TIME_COLUMNS = ("time", "t")


@dataclass(frozen=True, eq=False)
class Job:
    """One unit of a batch; plain data, so it pickles to a worker.

    Attributes
    ----------
    name : str
        Unique within the batch; the job's output folder ``OUT/<name>/``.
    kind : {"build", "trajectory"}
    spec : pathlib.Path
        The spec (build) or robot cell spec (trajectory) file; files it names resolve
        relative to its folder.
    table : dict
        The spec's table with the parameters filled in.
    params : dict
        The parameter values of this job.
    outputs : tuple of str
        Build: file names to write into the job's folder (empty: the spec's outputs).
    trajectory : pathlib.Path or None
        The trajectory file.
    columns : tuple of str or None
        Joint names of the trajectory's columns (None: the robot's actuated order).
    configurations : (C, K) float or None
        Joint values of the C waypoints, radians or metres.
    times : (C,) float or None
        Seconds from the start at each waypoint (None: not known).
    tool : str or None
        Link whose frame the safety pipe follows (None: the deepest link with geometry).
    tcp : (3,) tuple of float
        The tool point in the tool link's frame, metres.
    step : float
        Largest joint change between checked configurations (radians or metres).
    between : bool
        Certify the motion between the waypoints as well
        (:meth:`cadpipe.collision.CollisionWorld.check_path` with ``between=True``).
    tolerance : float or None
        The motion check's clearance counted as contact (None: its default).
    margin : float
        The motion check's padding: "clear" proves this clearance all along.
    pipe : dict
        Options of the safety pipe (:class:`cadpipe.Pipe` keywords).
    hash : str
        SHA-256 of the job's content (see :func:`content_hash`).
    """

    name: str
    kind: str
    spec: FilePath
    table: dict
    params: dict = field(default_factory=dict)
    outputs: tuple = ()
    trajectory: FilePath = None
    columns: tuple = None
    configurations: np.ndarray = None
    times: np.ndarray = None
    tool: str = None
    tcp: tuple = (0.0, 0.0, 0.0)
    step: float = 0.01
    between: bool = False
    tolerance: float = None
    margin: float = 0.0
    pipe: dict = field(default_factory=dict)
    hash: str = ""


def content_hash(spec_bytes, table, job_fields):
    """SHA-256 (hex) of what decides a job's outputs: the spec file's bytes, the filled-in
    table, the job's options and arrays, and cadpipe's version. Files the spec itself
    names (URDF, meshes, CSV paths) are not read here; see ``docs/batch.md``."""
    from cadpipe import __version__

    digest = hashlib.sha256()
    digest.update(f"cadpipe {__version__}\n".encode())
    digest.update(hashlib.sha256(spec_bytes).digest())
    digest.update(json.dumps(table, sort_keys=True).encode())
    for name, value in sorted(job_fields.items()):
        digest.update(name.encode())
        if isinstance(value, np.ndarray):
            digest.update(repr(value.shape).encode() + np.ascontiguousarray(value).tobytes())
        else:
            digest.update(json.dumps(value, sort_keys=True, default=str).encode())
    return digest.hexdigest()


def read_trajectory(file, dt=None):
    """``(columns, configurations, times)`` of a trajectory file.

    A ``.npy`` file holds a ``(C, K)`` float array of joint values. A CSV file holds one
    waypoint per row; its optional header names the columns: joint names, and
    ``time`` (or ``t``, seconds) if the rows are timed. Without a time column, ``dt``
    (seconds between waypoints) gives the times; with neither, times are None.

    Returns
    -------
    columns : tuple of str or None
        The joint columns' names (None without a header).
    configurations : (C, K) float
    times : (C,) float or None
    """
    file = FilePath(file)
    columns = None
    if file.suffix.lower() == ".npy":
        try:
            values = np.load(file, allow_pickle=False)
        except (OSError, ValueError) as exc:
            raise InputError(f"not a readable .npy array ({exc})", file=file) from None
        if values.dtype.kind not in "iuf":
            raise InputError(f"expected numbers, got an array of {values.dtype}", file=file)
        values = values.astype(np.float64)
    elif file.suffix.lower() == ".csv":
        columns, values = _csv_table(file)
    else:
        raise InputError("unknown trajectory format; use .csv or .npy", file=file)
    if values.ndim != 2 or len(values) == 0 or values.shape[1] == 0:
        raise InputError(f"expected (waypoints, joints) values, got shape {values.shape}",
                         file=file)
    if not np.isfinite(values).all():
        row = int(np.argmax(~np.isfinite(values).all(axis=1)))
        raise InputError(f"waypoint {row} has a NaN or infinite value", file=file, index=row)
    times = None
    if columns is not None and any(c in TIME_COLUMNS for c in columns):
        at = [i for i, c in enumerate(columns) if c in TIME_COLUMNS]
        if len(at) > 1 or dt is not None:
            raise InputError("give the time once: one time column, or dt in the job, "
                             "not both", file=file)
        times = values[:, at[0]]
        keep = [i for i in range(len(columns)) if i != at[0]]
        columns, values = tuple(columns[i] for i in keep), values[:, keep]
    elif dt is not None:
        if not dt > 0:
            raise InputError(f"must be > 0, got {dt!r}", key="dt")
        times = np.arange(len(values)) * float(dt)
    if times is not None and (np.diff(times) < 0).any():
        row = int(np.argmax(np.diff(times) < 0)) + 1
        raise InputError(f"time goes backwards at waypoint {row}", file=file, index=row)
    return columns, values, times


def _csv_table(file):
    """``(header or None, (R, K) values)`` of a numeric CSV file."""
    try:
        text = file.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise InputError("not a text file; expected rows of joint values", file=file) from None
    rows = [line for line in text.splitlines() if line.strip() and not line.startswith("#")]
    header = None
    if rows and re.search(r"[A-Za-df-z_]", rows[0].replace("e", "")):
        header = tuple(name.strip() for name in rows[0].split(","))
        if len(set(header)) != len(header) or "" in header:
            raise InputError(f"header: every column needs its own name, got {rows[0]!r}",
                             file=file)
        rows = rows[1:]
    try:
        values = np.loadtxt(rows, delimiter=",", ndmin=2)
    except ValueError as exc:
        raise InputError(f"expected rows of numbers ({exc})", file=file) from None
    if header is not None and values.size and values.shape[1] != len(header):
        raise InputError(f"{values.shape[1]} values per row for {len(header)} columns",
                         file=file)
    return header, values


def _pipe(ctx, *, radius: Number = 0.05, sides: int | None = None, caps: str = "round",
          tolerance: Number | None = None):
    """``pipe = {radius = ..., sides = ...}``: the safety pipe of a trajectory job."""
    if not radius > 0 or radius == float("inf"):
        raise InputError(f"must be a number > 0, got {radius!r}", key="radius")
    return {"radius": radius, "sides": sides, "caps": caps, "tolerance": tolerance}


def _entry(ctx, *, name: str | None = None, spec: str | None = None, cell: str | None = None,
           params: dict | None = None, grid: dict | None = None, rows: str | list | None = None,
           outputs: list | None = None, trajectory: str | None = None,
           trajectories: str | None = None, dt: Number | None = None, tool: str | None = None,
           tcp: list | None = None, step: Number = 0.01, between: bool | None = None,
           tolerance: Number | None = None, margin: Number | None = None,
           pipe: dict | None = None):
    """One table of ``jobs``: the :class:`Job` values it expands to."""
    from cadpipe.collision.motion import motion_settings

    if (spec is None) == (cell is None):
        raise InputError("give spec (a spec to build) or cell (a robot cell with a "
                         "trajectory to check): exactly one", key="cell" if spec else "spec")
    kind = "build" if spec is not None else "trajectory"
    source = ctx.file_path(spec if spec is not None else cell, "spec" if spec else "cell")
    if kind == "build":
        for key, value in (("trajectory", trajectory), ("trajectories", trajectories),
                           ("dt", dt), ("tool", tool), ("tcp", tcp), ("pipe", pipe),
                           ("between", between), ("tolerance", tolerance), ("margin", margin)):
            if value is not None:
                raise InputError("only a trajectory job (cell = ...) has it", key=key)
        files = [None]
    else:
        if outputs is not None:
            raise InputError("a trajectory job writes its safety pipe and report; outputs is "
                             "for spec jobs", key="outputs")
        files = _trajectory_files(ctx, trajectory, trajectories)
    if not step > 0:
        raise InputError(f"must be > 0, got {step!r}", key="step")
    if tcp is not None and (len(tcp) != 3 or not all(isinstance(v, (int, float))
                                                      and not isinstance(v, bool) for v in tcp)):
        raise InputError(f"expected [x, y, z] in metres, got {tcp!r}", key="tcp")
    if not between and (tolerance is not None or margin is not None):
        raise InputError("only a motion check (between = true) has it",
                         key="tolerance" if tolerance is not None else "margin")
    tolerance, margin = motion_settings(tolerance, margin or 0.0)
    made = _outputs(outputs) if outputs is not None else ()
    spec_bytes = source.read_bytes()
    template = parse(source)
    sets = parameter_sets(params, grid, csv_rows(ctx.file_path(rows, "rows"))
                          if isinstance(rows, str) else rows)
    used = placeholders(template) | placeholders(name or "")
    where = "grid" if grid is not None else "rows" if rows is not None else "params"
    options = {"outputs": made, "tool": tool, "step": float(step),
               "tcp": tuple(map(float, tcp or (0, 0, 0))), "between": bool(between),
               "tolerance": tolerance, "margin": margin,
               "pipe": ctx.call(_pipe, pipe or {}, "pipe")}
    limits.check("max_jobs", len(sets) * len(files),
                 f"{len(sets):,} parameter sets x {len(files):,} trajectories", key=where)
    jobs = []
    for values in sets:
        check_names(used, values, where)
        table = fill(template, values)
        for file in files:
            arrays = {}
            if file is not None:
                columns, q, times = read_trajectory(file, dt)
                arrays = {"trajectory": file, "columns": columns, "configurations": q,
                          "times": times}
            label = fill(name, values, "name") if name is not None else \
                (file or source).stem
            hashed = {**options, "kind": kind, "params": values,
                      **{k: v for k, v in arrays.items() if k != "trajectory"}}
            jobs.append(Job(str(label), kind, source.resolve(), table, values, **options,
                            **arrays, hash=content_hash(spec_bytes, table, hashed)))
    return _numbered(jobs)


def _trajectory_files(ctx, trajectory, trajectories):
    if (trajectory is None) == (trajectories is None):
        raise InputError("give trajectory (one file) or trajectories (a glob pattern such as "
                         "\"programs/*.csv\"): exactly one", key="trajectory")
    if trajectory is not None:
        return [ctx.file_path(trajectory, "trajectory")]
    pattern = FilePath(trajectories)
    confined = ctx.file != FilePath(TABLES)         # a JOBS file, not tables from Python
    if confined and (pattern.is_absolute() or ".." in pattern.parts):
        raise InputError(f"{trajectories!r} reaches outside the JOBS file's folder; give a "
                         "pattern inside it (\"programs/*.csv\") or one trajectory = file",
                         key="trajectories")
    folder = ctx.folder.resolve()
    found = sorted(FilePath(p) for p in glob.glob(str(ctx.folder / pattern), recursive=True))
    files = [p for p in found if p.is_file() and
             (not confined or p.resolve().is_relative_to(folder))]
    if not files:
        raise InputError(f"no file matches {trajectories!r} in {ctx.folder}",
                         key="trajectories")
    return files


def _outputs(outputs):
    """The ``outputs`` of a spec job: plain file names with a known format."""
    from cadpipe.core.formats import writer_for

    names = []
    for i, entry in enumerate(outputs):
        if not isinstance(entry, str) or FilePath(entry).name != entry or entry in (".", ".."):
            raise InputError(f"expected a file name (no folder: files go into the job's "
                             f"folder), got {entry!r}", key=f"outputs[{i}]")
        try:
            writer_for(entry)
        except InputError as exc:
            raise InputError(exc.message, key=f"outputs[{i}]") from None
        names.append(entry)
    return tuple(names)


def _numbered(jobs):
    """``jobs``, names made unique within one entry by a ``-1``, ``-2``, ... suffix."""
    names = [j.name for j in jobs]
    if len(set(names)) == len(names):
        return jobs
    width = len(str(len(jobs)))
    return [replace(j, name=f"{j.name}-{k:0{width}d}") for k, j in enumerate(jobs, start=1)]


def _jobs_table(ctx, *, jobs: list, defaults: dict | None = None, max_jobs: int | None = None):
    """The top level of a JOBS file: ``jobs`` (a list of tables), shared ``defaults`` and
    the ``max_jobs`` budget (:mod:`cadpipe.limits`)."""
    if max_jobs is not None:
        with limits.using(max_jobs=max_jobs):
            return _jobs_table(ctx, jobs=jobs, defaults=defaults)
    if not jobs:
        raise InputError("expected at least one job table", key="jobs")
    made, seen = [], {}
    for i, entry in enumerate(jobs):
        if not isinstance(entry, dict):
            raise ctx.error(f"jobs[{i}]", f"expected a table, got {entry!r}")
        for job in ctx.call(_entry, {**(defaults or {}), **entry}, f"jobs[{i}]"):
            if not NAME.fullmatch(job.name):
                raise ctx.error(f"jobs[{i}].name", f"{job.name!r} cannot name a folder: use "
                                "letters, digits and _ . + = - (at most 120), starting with "
                                "a letter or digit")
            if job.name.lower() in RESERVED:
                raise ctx.error(f"jobs[{i}].name", f"{job.name!r} is the name of the batch's "
                                f"own {job.name.lower()} in the output folder; give the job "
                                "another name")
            if job.name in seen:
                raise ctx.error(f"jobs[{i}].name", f"{job.name!r} is also the name of a job "
                                f"of jobs[{seen[job.name]}]; give each job its own name")
            seen[job.name] = i
            made.append(job)
        limits.check("max_jobs", len(made), f"jobs[0] to jobs[{i}]", key=f"jobs[{i}]")
    return made


def read_jobs(source):
    """The :class:`Job` values of a JOBS file, or of its ``jobs`` tables given directly.

    Parameters
    ----------
    source : path-like or list of dict
        A ``.toml``/``.json`` JOBS file (files it names resolve relative to its folder),
        or a list of job tables (relative to the current folder).

    Returns
    -------
    list of Job
        In the order given, grids and rows expanded.

    Raises
    ------
    SpecError
        Naming the file, the key (``jobs[2].grid.radius``) and what was expected.
    """
    if isinstance(source, (list, tuple)):
        return SpecContext(FilePath(TABLES)).call(_jobs_table, {"jobs": list(source)})
    file = FilePath(source)
    if not file.is_file():
        raise SpecError("is a folder, not a JOBS file" if file.is_dir() else
                        "no such JOBS file", file=file)
    try:
        return SpecContext(file).call(_jobs_table, parse(file))
    except CadpipeError as exc:
        raise exc.at(file=file) from exc.__cause__
