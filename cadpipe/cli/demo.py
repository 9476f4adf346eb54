"""``cadpipe demo``: run the built-in example end to end."""

from pathlib import Path as FilePath

from cadpipe.cli import command
from cadpipe.cli.welding_cell import run_demo


def _arguments(parser):
    parser.add_argument("-o", "--output", default="out/demo", metavar="DIR",
                        help="folder for the demo's files (default: out/demo)")


@command("demo", "Build the built-in example and write its files.", _arguments)
def demo(args):
    run_demo(FilePath(args.output))
