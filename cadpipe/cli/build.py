"""``cadpipe build SPEC [-o OUT ...]``: read a spec, combine its assembly, write its outputs.

Everything that can be checked before writing is: the spec, every part, the
boolean, every output's format. Only then are files written, each atomically.
Progress names the stage running (meshing each part, the union, each file):
a bar on stderr when it is a terminal, else one plain line per stage on stdout
(so an error stays the one line on stderr).
"""

from pathlib import Path as FilePath

from cadpipe import limits
from cadpipe.cli import budgets, command
from cadpipe.errors import CadpipeError, InputError
from cadpipe.io.files import LAYOUTS
from cadpipe.io.scene import UNITS


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
    parser.add_argument("--layout", choices=LAYOUTS, default="scene",
                        help="'print': every body on z = 0, side by side (a build plate)")
    parser.add_argument("-q", "--quiet", action="store_true",
                        help="print nothing but errors")


@command("build", "Build the assembly a spec describes and write its files.", _arguments)
def build(args):
    from rich.console import Console

    from cadpipe.io.files import check_target, ensure_folder, exporters, suffix_of
    from cadpipe.io.spec import read

    spec = read(args.spec, **budgets(args))
    outputs = [(FilePath(o), args.mode) for o in args.output] or \
        [(path, args.mode or mode) for path, mode in spec.outputs]
    if not outputs:
        raise InputError("nothing to write; pass -o FILE or list outputs in the spec",
                         file=args.spec)
    for path, _ in outputs:
        if suffix_of(path) not in exporters:
            raise InputError("unknown output format; supported: "
                             f"{', '.join('.' + n for n in exporters.names())}", file=path)
        check_target(path)

    assembly = spec.assembly
    options = {"layout": args.layout}
    if args.units:
        options["units"] = args.units
    report = Console(quiet=args.quiet, soft_wrap=True, highlight=False, markup=False)
    with _Stages(args.quiet) as stage:
        count = len(assembly.parts)
        stage(f"meshing {count} part{'s' * (count != 1)}", 0, count)
        done = iter(range(1, count + 1))

        def step(label):                  # called after each part, then after the union
            if label == "boolean":
                return
            k = next(done)
            if k < count:
                stage(f"meshing {label}", k, count)
            else:
                stage(f"union of {count} part{'s' * (count != 1)}", 0, 1)

        try:
            with limits.using(**spec.budgets):
                solid = assembly.union(progress=step)
        except CadpipeError as exc:           # at the part's key, as reading errors are
            raise spec.locate(exc) from exc.__cause__
        for k, (path, mode) in enumerate(outputs, start=1):
            stage(f"writing {path.name}", k, len(outputs))
            ensure_folder(path.parent)
            assembly.export(path, mode, **options)
    report.print(f"{assembly.name}: {len(assembly.parts)} parts, {len(solid.faces)} triangles, "
                  f"{solid.n_bodies} bodies, volume {solid.volume:.6g} {assembly.units}^3, "
                  f"watertight={solid.is_watertight}")
    for path, _ in outputs:
        report.print(f"wrote {path}")


class _Stages:
    """``stage(text, done, total)``: a bar on a terminal, a line per new stage elsewhere
    (on stdout: stderr holds only an error)."""

    def __init__(self, quiet):
        from rich.console import Console
        from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

        self.console = Console(stderr=True)
        self.quiet = quiet
        self.bar = None
        self.last = None
        if not quiet and self.console.is_terminal:
            self.bar = Progress(TextColumn("{task.description:<32}"), BarColumn(),
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
        kind = text.split()[0]
        if kind != self.last:        # a plain line per stage, not per part
            print(f"cadpipe build: {text}" + (f" ({done}/{total})" if kind == "writing" else ""),
                  flush=True)
            self.last = kind if kind != "writing" else text
