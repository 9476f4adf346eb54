"""The ``cadpipe`` command: a thin layer over the Python API.

Each subcommand parses its arguments, calls the API and prints the result. A
:class:`~cadpipe.errors.CadpipeError` becomes one readable line on stderr and
exit code 1; bad usage exits 2 (argparse's convention); success exits 0.
"""

import argparse
import sys

from cadpipe.errors import CadpipeError

COMMANDS = {}


def command(name, help, arguments):
    """Register ``func(args)`` as subcommand ``name``; ``arguments(parser)`` adds its options."""

    def wrap(func):
        COMMANDS[name] = (func, help, arguments)
        return func

    return wrap


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
        p.set_defaults(func=func)
    return parser


def main(argv=None):
    """Entry point of the ``cadpipe`` console script and ``python -m cadpipe``."""
    from cadpipe.cli import commands  # noqa: F401  (registers the subcommands)

    args = build_parser().parse_args(argv)
    try:
        return args.func(args) or 0
    except (CadpipeError, OSError) as exc:
        print(f"cadpipe {args.command}: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"cadpipe {args.command}: interrupted", file=sys.stderr)
        return 130
