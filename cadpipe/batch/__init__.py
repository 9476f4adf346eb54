"""Batches of jobs beyond one process: every core here, a Dask cluster for more.

A job builds a spec (optionally a template filled from a grid or CSV rows of parameter
values) or checks a robot trajectory against a cell and wraps the tool's path in a
safety pipe. :func:`run` takes a JOBS file (``docs/batch.md``), runs what is not already
complete, writes each job's files into its own folder and one summary at the end::

    summary = cadpipe.batch.run("jobs.toml", "out/batch")      # a local cluster
    summary.counts                                              # {"ok": 12, "failed": 1, ...}

The pipeline: :mod:`~cadpipe.batch.params` (templates) -> :mod:`~cadpipe.batch.jobs`
(the JOBS file) -> :mod:`~cadpipe.batch.engine` (Dask) -> :mod:`~cadpipe.batch.work` (one
job, on a worker) -> :mod:`~cadpipe.batch.summary` (the report).
"""

from cadpipe.batch.engine import Summary, run
from cadpipe.batch.jobs import Job, read_jobs

__all__ = ["Job", "Summary", "read_jobs", "run"]
