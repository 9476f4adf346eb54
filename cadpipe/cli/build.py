"""``cadpipe build SPEC [-o OUT ...]``: read a spec, combine its assembly, write its outputs.

Everything that can be checked before writing is: the spec, every part, the
boolean, every output's format. Only then are files written, each atomically.
"""

from pathlib import Path as FilePath

from cadpipe import limits
from cadpipe.cli import command
from cadpipe.errors import CadpipeError, InputError


def _arguments(parser):
    parser.add_argument("spec", metavar="SPEC", help="assembly spec file (.toml or .json)")
    parser.add_argument("-o", "--output", action="append", default=[], metavar="OUT",
                        help="file to write (format by suffix; repeatable); "
                             "default: the spec's outputs")
    parser.add_argument("--mode", choices=("solid", "parts"),
                        help="write the unioned solid or each part (default: solid for "
                             "STL/3MF/OBJ/PLY/OFF, parts for USD/GLB)")
    parser.add_argument("-q", "--quiet", action="store_true",
                        help="print nothing but errors")


@command("build", "Build the assembly a spec describes and write its files.", _arguments)
def build(args):
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from cadpipe.io.files import check_target, ensure_folder, exporters, suffix_of
    from cadpipe.io.spec import read

    spec = read(args.spec)
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
    report = Console(quiet=args.quiet, soft_wrap=True, highlight=False, markup=False)
    columns = (TextColumn("{task.description:<24}"), BarColumn(),
               TextColumn("{task.completed}/{task.total}"), TimeElapsedColumn())
    bar = Console(stderr=True)
    with Progress(*columns, console=bar, transient=True,
                  disable=args.quiet or not bar.is_terminal) as progress:
        task = progress.add_task("parts", total=len(assembly.parts) + 1 + len(outputs))
        step = lambda label: progress.update(task, advance=1, description=label)  # noqa: E731
        try:
            with limits.using(**spec.budgets):
                solid = assembly.union(progress=step)
        except CadpipeError as exc:           # at the part's key, as reading errors are
            raise spec.locate(exc) from exc.__cause__
        for path, mode in outputs:
            progress.update(task, description=f"writing {path.name}")
            ensure_folder(path.parent)
            assembly.export(path, mode)
            step(f"wrote {path.name}")
    report.print(f"{assembly.name}: {len(assembly.parts)} parts, {len(solid.faces)} triangles, "
                  f"{solid.n_bodies} bodies, volume {solid.volume:.6g} {assembly.units}^3, "
                  f"watertight={solid.is_watertight}")
    for path, _ in outputs:
        report.print(f"wrote {path}")
