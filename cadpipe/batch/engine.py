"""Running a batch: skip what is complete, run the rest on Dask (or in this process), report.

With no scheduler address, a :class:`distributed.LocalCluster` of single-threaded worker
processes uses this machine's cores; with one, the jobs go to that cluster. Jobs travel
as :class:`~cadpipe.batch.jobs.Job` data and come back as small records; the workers
write the files. A worker that dies is replaced and its job run again by Dask (up to the
scheduler's ``distributed.scheduler.allowed-failures``, then it is recorded as failed);
each job has one future and one row, so none is counted twice. Ctrl-C cancels what is
left, closes the cluster and still writes the summary of what finished.
"""

import logging
import os
import uuid
from contextlib import ExitStack
from dataclasses import dataclass, fields
from pathlib import Path as FilePath

from cadpipe import limits
from cadpipe.batch import summary as report
from cadpipe.batch.jobs import Job, read_jobs
from cadpipe.batch.work import execute, row
from cadpipe.errors import InputError
from cadpipe.io.files import ensure_folder


@dataclass(frozen=True)
class Summary:
    """What :func:`run` returns: one record per job (in the jobs' order, as
    ``summary.json`` lists them) and the summary files written."""

    jobs: tuple
    files: tuple

    @property
    def counts(self):
        """``{"ok": n, "failed": n, "not run": n, "reused": n}``."""
        return report.counts(self.jobs)


class Tally:
    """Jobs done, failed and running so far, for a progress display."""

    def __init__(self, total):
        self.total, self.ok, self.failed, self.reused, self.running = total, 0, 0, 0, 0

    def add(self, record):
        if record["status"] == "ok":
            self.ok += 1
            self.reused += bool((record.get("run") or {}).get("reused"))
        else:
            self.failed += 1

    @property
    def done(self):
        return self.ok + self.failed


def _needs_dask():
    try:
        import distributed
    except ImportError:
        raise InputError("running jobs in parallel needs Dask: pip install 'cadpipe[batch]' "
                         "(or run them one after another with --workers 0)",
                         key="workers") from None
    return distributed


def _client(stack, workers, scheduler):
    """A Dask client on ``scheduler``'s cluster, or on a new local one of ``workers``
    processes (default: one per core); closed with ``stack``."""
    distributed = _needs_dask()
    if scheduler is not None:
        try:
            return stack.enter_context(distributed.Client(scheduler, timeout="10s"))
        except (OSError, TimeoutError, ValueError) as exc:
            raise InputError(f"cannot reach the Dask scheduler at {scheduler!r} ({exc})",
                             key="scheduler") from None
    count = (os.cpu_count() or 1) if workers is None else workers
    cluster = stack.enter_context(distributed.LocalCluster(
        n_workers=count, threads_per_worker=1, processes=True, dashboard_address=None,
        silence_logs=logging.ERROR))
    return stack.enter_context(distributed.Client(cluster))


def _lost(job, exc):
    """The record of a job whose future failed outside the job itself."""
    if type(exc).__name__ == "KilledWorker":
        text = "the worker process died each time it ran this job (a crash or running out " \
               "of memory); not retried further"
    else:
        text = f"{type(exc).__name__}: {exc}".splitlines()[0]
    return row(job, "failed", text)


def _distributed(client, jobs, out, finish, tally):
    """Run ``jobs`` on ``client``'s cluster, calling ``finish(record)`` as each completes."""
    from distributed import as_completed

    slots = max(1, sum(client.nthreads().values()))
    token = uuid.uuid4().hex[:8]
    now, default = limits.current(), limits.Limits()
    budgets = {f.name: getattr(now, f.name) for f in fields(now)
               if getattr(now, f.name) != getattr(default, f.name)}
    futures = {client.submit(execute, job, str(out), budgets, key=f"cadpipe-{token}-{job.name}"):
               job for job in jobs}
    left = set(futures)
    tally.running = min(len(left), slots)
    try:
        for future in as_completed(futures):
            job = futures[future]
            try:
                record = future.result()
            except Exception as exc:          # noqa: BLE001  (recorded, the batch goes on)
                record = _lost(job, exc)
            # released, so a worker dying with this result in memory does not run it again
            future.release()
            left.discard(future)
            tally.running = min(len(left), slots)
            finish(record)
    finally:
        client.cancel(list(left))           # after Ctrl-C: nothing more is started


def run(jobs, out, *, workers=None, scheduler=None, force=False, progress=None):
    """Run a batch of jobs into the folder ``out``; returns a :class:`Summary`.

    Parameters
    ----------
    jobs : path-like, list of dict, or list of Job
        A JOBS file (TOML/JSON, ``docs/batch.md``), its job tables, or
        :func:`~cadpipe.batch.read_jobs`' values.
    out : path-like
        Output folder: ``out/<job name>/`` per job, ``summary.json`` and
        ``summary.html``. On a cluster it must be a filesystem every worker shares.
    workers : int, optional
        Worker processes of a local cluster (default: one per core); 0 runs the jobs
        one after another in this process, without Dask.
    scheduler : str, optional
        Address of a running Dask scheduler (``tcp://host:8786``) to use instead.
    force : bool
        Run every job, even those complete from an earlier run.
    progress : callable, optional
        ``progress(record, tally)`` after each job (``record`` None once at the start);
        ``tally`` has ``total``, ``ok``, ``failed``, ``reused``, ``running``, ``done``.

    Raises
    ------
    SpecError, InputError
        For bad jobs, before anything runs.
    KeyboardInterrupt
        After writing the summary of the jobs that finished.
    """
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int)
                                or workers < 0):
        raise InputError(f"expected a whole number >= 0, got {workers!r}", key="workers")
    batch = list(jobs) if isinstance(jobs, (list, tuple)) and \
        all(isinstance(j, Job) for j in jobs) and jobs else read_jobs(jobs)
    names = [job.name for job in batch]
    if len(set(names)) != len(names):
        twice = next(n for n in names if names.count(n) > 1)
        raise InputError(f"two jobs are named {twice!r}; each job needs its own folder",
                         key="jobs")
    if workers is not None and scheduler is not None:
        raise InputError("give workers or a scheduler, not both: a cluster brings its own "
                         "workers", key="workers")
    out = FilePath(out).resolve()
    serial = workers == 0
    if not serial:
        _needs_dask()           # the same answer whether or not anything is left to run
    started = report.now()
    tally, records = Tally(len(batch)), {}
    notify = progress or (lambda record, tally: None)

    def finish(record):
        records[record["name"]] = record
        tally.add(record)
        notify(record, tally)

    done = {job.name: None if force else report.completed(job, out) for job in batch}
    todo = [job for job in batch if done[job.name] is None]
    engine = "serial" if serial else f"dask scheduler {scheduler}" if scheduler else \
        f"dask local cluster of {workers or os.cpu_count()} processes"
    with ExitStack() as stack:
        client = _client(stack, workers, scheduler) if todo and not serial else None
        ensure_folder(out)
        for job in batch:
            if done[job.name] is not None:
                previous = done[job.name]
                finish({**previous, "run": {**(previous.get("run") or {}), "reused": True}})
        notify(None, tally)
        interrupted = False
        try:
            if serial:
                for job in todo:
                    tally.running = 1
                    finish(execute(job, out))
                tally.running = 0
            elif todo:
                _distributed(client, todo, out, finish, tally)
        except KeyboardInterrupt:
            interrupted = True
            raise
        finally:
            rows = tuple(records.get(job.name) or row(job, "not run") for job in batch)
            files = report.write(out, list(rows), engine=engine, interrupted=interrupted,
                                 started=started)
    return Summary(rows, tuple(files))
