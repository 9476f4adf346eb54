"""The ``cadpipe`` command: a thin layer over the Python API.

Each subcommand parses its arguments, calls the API and prints the result. Any
failure ends in one line on stderr and a non-zero exit, never a traceback: a
:class:`~cadpipe.errors.CadpipeError` or an OS error exits 1 with its message, a
failure cadpipe did not foresee exits 1 naming the exception ("internal error")
; bad usage exits 2 (argparse's convention); Ctrl-C exits 130 at once; a closed
stdout (``cadpipe collide --json | head``) exits quietly (141). Ctrl-C stops
as soon as Python regains control; the budgets of :mod:`cadpipe.limits` keep
every single library call short, and files are written whole or not at all. Warnings from numpy
and the libraries below are not printed: what matters reaches the user as an
error.
"""

import argparse
import os
import sys
import warnings

from cadpipe.errors import CadpipeError, one_line

COMMANDS = {}


def command(name, help, arguments):
    """Register ``func(args)`` as subcommand ``name``; ``arguments(parser)`` adds its options."""

    def wrap(func):
        COMMANDS[name] = (func, help, arguments)
        return func

    return wrap


def budgets(args):
    """The limits set on the command line ({name: value}, only those given), as
    :func:`cadpipe.limits.using` and :func:`cadpipe.spec.read` take them."""
    from cadpipe import limits

    given = {name: getattr(args, name, None) for name in limits.CLI_FLAGS}
    return {name: value for name, value in given.items() if value is not None}


def _limit_flags(parser):
    """One flag per budget of :mod:`cadpipe.limits` (``--max-triangles N``), as slicers
    and compilers take one option per setting; a value given wins over the spec's key."""
    from cadpipe import limits

    group = parser.add_argument_group("limits (see docs/spec.md, Limits)")
    for name in limits.CLI_FLAGS:
        number = float if isinstance(getattr(limits.Limits(), name), float) else int
        group.add_argument(limits.flag(name), type=number, metavar="N",
                           help=limits.describe(name))


def build_parser():
    from cadpipe import __version__

    parser = argparse.ArgumentParser(
        prog="cadpipe",
        description="Watertight tube meshes along 3D paths: build, check, collide, export.")
    parser.add_argument("--version", action="version", version=f"cadpipe {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name, (func, help, arguments) in COMMANDS.items():
        p = sub.add_parser(name, help=help, description=help)
        arguments(p)
        _limit_flags(p)
        p.set_defaults(func=func)
    return parser


def main(argv=None):
    """Entry point of the ``cadpipe`` console script and ``python -m cadpipe``."""
    from cadpipe import limits
    from cadpipe.cli import commands  # noqa: F401  (registers the subcommands)

    args = build_parser().parse_args(argv)
    name = f"cadpipe {args.command}"
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            with limits.using(**budgets(args)):
                code = args.func(args) or 0
        sys.stdout.flush()
        return code
    except BrokenPipeError:
        return _quiet_broken_pipe()
    except (CadpipeError, OSError) as exc:
        return _fail(name, exc)
    except KeyboardInterrupt:
        _line(f"{name}: interrupted")
        return 130
    except MemoryError:
        return _fail(name, "out of memory; lower the work asked for (see --max-triangles)")
    except RecursionError:
        return _fail(name, "input nested too deeply to process")
    except Exception as exc:                  # noqa: BLE001 (the one place that catches all)
        return _fail(name, f"internal error ({type(exc).__name__}: {exc}); please report it")


def _line(text):
    """One line on stderr, whatever ``text`` holds."""
    text = one_line(str(text))
    try:
        print(text if len(text) <= 2000 else text[:1996] + " ...", file=sys.stderr, flush=True)
    except (OSError, ValueError):
        pass


def _fail(name, exc):
    _line(f"{name}: error: {exc}")
    return 1


def _quiet_broken_pipe():
    """stdout was closed by the reader (``| head``): exit quietly, as Unix tools do."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):
        pass
    return 141                               # 128 + SIGPIPE, as a shell reports it
