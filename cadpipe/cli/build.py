"""``cadpipe build SPEC [-o OUT ...]``: read a spec, combine its assembly, write its outputs.

Everything that can be checked before writing is: the spec, every part, the
boolean, every output's format and options. Only then are files written, each
atomically. Progress names the stage running (reading the spec, meshing the
parts, the union of each group of overlapping solids, each file, the summary)
with counts: a bar on stderr when it is a terminal, else one plain line per
stage on stdout (so an error stays the one line on stderr).

Ctrl-C stops at once at any point. manifold3d holds the interpreter while it
works (seconds to minutes for a large union), so no Python handler could run:
while the spec is read and the solid computed (and summed up), with no file
open, SIGINT keeps the system's default and ends the process (the shell reports
130). While files are written, each writer runs in a worker thread and the main
thread waits for it, so an interrupt is seen within a tenth of a second: the
unfinished temporary file is removed and the command exits 130 (files already
written stay whole).
"""

import os
import signal
import sys
import threading
from contextlib import contextmanager
from pathlib import Path as FilePath

from cadpipe import limits
from cadpipe.cli import budgets, command
from cadpipe.errors import CadpipeError, InputError
from cadpipe.solids.scene import LAYOUTS
from cadpipe.core.units import UNITS


def _arguments(parser):
    parser.add_argument("spec", metavar="SPEC", help="assembly spec file (.toml or .json)")
    parser.add_argument("-o", "--output", action="append", default=[], metavar="OUT",
                        help="file to write (format by suffix; repeatable); "
                             "default: the spec's outputs")
    parser.add_argument("--mode", choices=("solid", "parts"),
                        help="write the unioned solid or each part (default: solid for "
                             "STL/3MF/OBJ/PLY/OFF, parts for USD/GLB)")
    parser.add_argument("--units", choices=tuple(UNITS),
                        help="length unit of the files written (default: each format's "
                             "own: STL mm, OBJ/PLY/GLB m, 3MF/USD the spec's)")
    parser.add_argument("--layout", choices=LAYOUTS,
                        help="'print': every body on z = 0, side by side (a build plate); "
                             "default: the spec output's layout, else 'scene'")
    parser.add_argument("-q", "--quiet", action="store_true",
                        help="print nothing but errors")


@command("build", "Build the assembly a spec describes and write its files.", _arguments)
def build(args):
    from rich.console import Console

    from cadpipe.io.files import ensure_folder
    from cadpipe.spec import read

    with _Stages(args.quiet) as stage:
        stage(f"reading {FilePath(args.spec).name}", 0, 1)
        with _ended_by_interrupt():
            spec = read(args.spec, **budgets(args))
        outputs = _outputs(args, spec)
        assembly = spec.assembly
        try:
            with limits.using(**spec.budgets), _ended_by_interrupt():
                solid = assembly.union(progress=stage)
        except CadpipeError as exc:           # at the part's key, as reading errors are
            raise spec.locate(exc) from exc.__cause__
        for k, (path, mode, options) in enumerate(outputs):
            stage(f"writing {path.name}", k, len(outputs))
            ensure_folder(path.parent)
            _in_worker(assembly.export, path, mode, **options)
        stage(f"summing up {len(solid.faces):,} triangles", 0, 1)
        with _ended_by_interrupt():
            summary = _summary(assembly, solid)
    report = Console(quiet=args.quiet, soft_wrap=True, highlight=False, markup=False)
    report.print(summary)
    for path, _, _ in outputs:
        report.print(f"wrote {path}")


def _summary(assembly, solid):
    """The line printed at the end: parts, triangles, bodies, volume, watertightness
    (compiled passes of a few bytes a triangle, ``geometry.topology``: at any size)."""
    return (f"{assembly.name}: {len(assembly.parts)} parts, {len(solid.faces)} triangles, "
            f"{solid.n_bodies} bodies, volume {solid.volume:.6g} {assembly.units}^3, "
            f"watertight={solid.is_watertight}")


def _outputs(args, spec):
    """``(path, mode, options)`` of each file to write: ``-o`` or the spec's outputs, their
    formats and options checked before any work, the command line's over the spec's."""
    from cadpipe.core.formats import writer_for
    from cadpipe.io.files import check_target
    from cadpipe.solids.assembly import export_options

    given = {k: v for k, v in (("layout", args.layout), ("units", args.units)) if v}
    outputs = [(FilePath(o), args.mode, {}) for o in args.output] or \
        [(path, args.mode or mode, options) for path, mode, options in spec.outputs]
    if not outputs:
        raise InputError("nothing to write; pass -o FILE or list outputs in the spec",
                         file=args.spec)
    for path, _, _ in outputs:
        writer_for(path)                  # an unknown suffix: the formats there are
        check_target(path)
    return [(path, mode, export_options(path, {**options, **given}))
            for path, mode, options in outputs]


@contextmanager
def _ended_by_interrupt():
    """SIGINT ends the process at once inside: nothing is being written there, and a
    long manifold3d call would keep a Python handler from running until it returns."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_DFL)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def _in_worker(func, *args, **kwargs):
    """``func(*args, **kwargs)`` in a worker thread, the main thread waiting for it so an
    interrupt is handled at once: the unfinished temporary file is removed and the
    process exits 130."""
    from cadpipe.io.files import abandon_writes

    outcome = {}

    def run():
        try:
            outcome["value"] = func(*args, **kwargs)
        except BaseException as exc:          # noqa: BLE001 (raised again in the caller)
            outcome["error"] = exc

    worker = threading.Thread(target=run, name="cadpipe-writer", daemon=True)
    worker.start()
    try:
        while worker.is_alive():
            worker.join(0.1)
    except KeyboardInterrupt:
        abandon_writes()
        print("cadpipe build: interrupted", file=sys.stderr, flush=True)
        sys.stdout.flush()
        os._exit(130)                         # the worker may be inside a long C call
    if "error" in outcome:
        raise outcome["error"]
    return outcome.get("value")


class _Stages:
    """``stage(text, done, total)``: a bar on a terminal, a line per new stage elsewhere
    (on stdout: stderr holds only an error)."""

    def __init__(self, quiet):
        from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

        self.console = _stderr_console()
        self.quiet = quiet
        self.bar = None
        self.last = None
        if not quiet and self.console.is_terminal:
            self.bar = Progress(TextColumn("{task.description:<40}"), BarColumn(),
                                TextColumn("{task.completed}/{task.total}"),
                                TimeElapsedColumn(), console=self.console, transient=True)

    def __enter__(self):
        if self.bar is not None:
            self.bar.__enter__()
            self.task = self.bar.add_task("", total=1)
        return self

    def __exit__(self, *exc):
        if self.bar is not None:
            self.bar.__exit__(*exc)

    def __call__(self, text, done, total):
        if self.quiet:
            return
        if self.bar is not None:
            self.bar.update(self.task, description=text, completed=done, total=total)
            return
        kind = text.split()[0] if text.startswith("meshing") else text
        if kind == self.last or text == "meshing done":
            return
        self.last = kind
        if kind == "meshing":                 # a line for the stage, not one per part
            line = f"meshing {total} part{'s' * (total != 1)}"
        elif kind.startswith("writing"):
            line = f"{text} ({done + 1}/{total})"
        else:
            line = text
        print(f"cadpipe build: {line}", flush=True)


def _stderr_console():
    """stderr's console, never hiding the cursor: an interrupt may end the process while
    the bar is shown, and the terminal must keep its cursor."""
    from rich.console import Console

    class KeepCursor(Console):
        def show_cursor(self, show=True):
            return False

    return KeepCursor(stderr=True)
