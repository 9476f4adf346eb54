"""``cadpipe batch JOBS -o OUT``: run a JOBS file's jobs on a Dask cluster (docs/batch.md).

A thin layer over :func:`cadpipe.batch.run`: a progress bar on a terminal (jobs done,
failed, running), a plain line per job otherwise, the counts at the end.
"""

import sys

from cadpipe.cli import command

#: exit code when the batch ran but some jobs failed (their errors are in the summary)
JOBS_FAILED = 3


def _arguments(parser):
    parser.add_argument("jobs", metavar="JOBS", help="JOBS file (.toml or .json)")
    parser.add_argument("-o", "--output", required=True, metavar="OUT",
                        help="output folder: a folder per job, summary.json and summary.html")
    parser.add_argument("--workers", type=int, metavar="N",
                        help="worker processes of the local cluster (default: one per core); "
                             "0: run the jobs one after another in this process")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="run on an existing Dask cluster (tcp://host:8786) instead; OUT "
                             "must be on a filesystem its workers share")
    parser.add_argument("--force", action="store_true",
                        help="run every job again, also those complete from an earlier run")
    parser.add_argument("-q", "--quiet", action="store_true",
                        help="print nothing but errors and the final counts")


def describe(record):
    """One line about a finished job."""
    if record["status"] != "ok":
        return f"FAILED {record['name']}: {record['error']}"
    first = record["first_collision"]
    if first is not None:
        at = f"t={first['time']:.3f} s" if first["time"] is not None else \
            f"waypoint {first['waypoint']:g}"
        what = f"collision {' '.join('<->'.join(p) for p in first['pairs'])} at {at}"
    elif record["clearance"] is not None:
        gap = record["clearance"]
        what = f"{record['verdict']}, clearance {gap['distance'] * 1000:.1f} mm " \
            f"({gap['a']} <-> {gap['b']})"
    else:
        what = record["verdict"]
    run = record.get("run") or {}
    took = "reused" if run.get("reused") else f"{run.get('seconds', 0):.2f} s"
    return f"ok {record['name']}: {what} ({took})"


@command("batch", "Run a batch of spec builds and trajectory checks on every core or a Dask "
                  "cluster.", _arguments)
def batch(args):
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from cadpipe.batch import run

    bar = Console(stderr=True)
    columns = (TextColumn("jobs"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
               TextColumn("{task.fields[state]}"), TimeElapsedColumn())
    live = bar.is_terminal and not args.quiet
    with Progress(*columns, console=bar, transient=True, disable=not live) as progress:
        task = progress.add_task("jobs", total=None, state="")

        def show(record, tally):
            state = f"ok {tally.ok}  failed {tally.failed}  running {tally.running}"
            progress.update(task, total=tally.total, completed=tally.done, state=state)
            if record is None or args.quiet:
                return
            line = f"[{tally.done}/{tally.total}] {describe(record)}"
            if not live:
                print(line, file=sys.stderr, flush=True)
            elif record["status"] != "ok":
                progress.console.print(line, markup=False, highlight=False)

        summary = run(args.jobs, args.output, workers=args.workers, scheduler=args.scheduler,
                      force=args.force, progress=show)
    c = summary.counts
    print(f"{len(summary.jobs)} jobs: {c['ok']} ok ({c['reused']} reused), {c['failed']} failed; "
          f"wrote {summary.files[0]} and {summary.files[1]}")
    if c["failed"]:
        print(f"cadpipe batch: {c['failed']} of {len(summary.jobs)} jobs failed; their errors "
              f"are in {summary.files[1]}", file=sys.stderr)
        return JOBS_FAILED
    return 0
