"""``cadpipe view``: preview.png and preview.html for a mesh or scene file."""

from dataclasses import replace
from pathlib import Path as FilePath

from cadpipe.cli import command
from cadpipe.core.formats import load_scene
from cadpipe.io.files import ensure_folder
from cadpipe.io.preview import VIEWS, render_png, write_html


def _arguments(parser):
    parser.add_argument("file", metavar="FILE",
                        help="a mesh or scene file (STL, OBJ, PLY, GLB, 3MF, USD/USDA/USDC/USDZ)")
    parser.add_argument("-o", "--output", default=".", metavar="DIR",
                        help="folder for preview.png and preview.html (default: here)")
    parser.add_argument("--highlight", action="append", default=[], metavar="PART",
                        help="draw this part in the highlight colour (repeatable)")
    parser.add_argument("--view", default="iso", choices=list(VIEWS),
                        help="camera direction (default: iso)")


@command("view", "Write preview.png and preview.html for a mesh or scene file.", _arguments)
def view(args):
    scene = replace(load_scene(args.file), name=FilePath(args.file).name)
    folder = ensure_folder(args.output)
    for written in (render_png(scene, folder / "preview.png", highlight=args.highlight,
                               view=args.view),
                    write_html(scene, folder / "preview.html", highlight=args.highlight,
                               view=args.view)):
        print(f"wrote {written}")
