"""Regenerate the parts of the docs that cadpipe itself produces.

    .venv/bin/python docs/make_docs.py           # write docs/cli.md and docs/figures/*

- ``docs/cli.md``: the option tables come from the ``cadpipe`` command's own
  argparse parsers (:func:`cadpipe.cli.build_parser`), so the reference cannot
  drift from the command; what a parser cannot say (exit codes, examples) is in
  :data:`COMMANDS` below. ``tests/test_docs.py`` fails when the committed file
  differs from :func:`cli_reference` and runs every example.
- ``docs/figures/``: the pictures in ``docs/algorithms.md``, drawn from cadpipe's
  own pipes, splices and certificates (:func:`figures`).
"""

import argparse
import sys
from pathlib import Path as FilePath

import numpy as np

import cadpipe
from cadpipe.cli import build_parser

DOCS = FilePath(__file__).resolve().parent

# -- the CLI reference -------------------------------------------------------------------
#: exit codes every subcommand shares (cadpipe/cli.py)
EXIT_CODES = {0: "success",
              1: "bad input (a cadpipe error or an unreadable/unwritable file): one line "
                 "`cadpipe COMMAND: error: ...` on stderr, no traceback, no partial output file",
              2: "bad usage (unknown option, missing argument): argparse's message on stderr",
              130: "interrupted (Ctrl-C)",
              141: "stdout closed by the reader (`| head`): exits quietly"}

#: what the parsers cannot say. ``exit`` overrides or adds to :data:`EXIT_CODES`; every
#: example runs from the repository root (tests/test_docs.py runs them, in this order)
COMMANDS = {
    "demo": {
        "about": "Runs the built-in welding cell end to end: a weld seam fitted as a spline, "
                 "safety pipes with 6-, 8- and 12-gon mouths spliced through LCM transitions, "
                 "a hollow printable tee, a posed six-axis arm, the collision report with a "
                 "separation certificate. Writes `scene.usda`, `scene.usdz`, `parts.stl` and "
                 "`parts.3mf` (laid out for printing, STL in millimetres), `scene.glb`, "
                 "`report.json`, `preview.png`, `preview.html` and "
                 "`certificate.svg` to the folder and prints a short summary. "
                 "`make demo` runs `cadpipe demo -o out/demo`.",
        "examples": ["cadpipe demo -o out/demo"],
    },
    "build": {
        "about": "Reads a spec file ([spec.md](spec.md)), builds every part, combines them and "
                 "writes the outputs. Everything that can be checked before writing is "
                 "checked first (spec, parts, booleans, output formats); then each file is "
                 "written whole or not at all. The format follows the suffix "
                 "([export.md](export.md)). Progress names the stage running, with counts: "
                 "reading, meshing N parts, union of N solids in K groups (solids united "
                 "so far; a group of 64 or more is united in batches, then their join is "
                 "its own stage), writing each file, summing up; a bar on stderr on a "
                 "terminal, else one plain line per stage on stdout. Parts whose boxes "
                 "overlap nothing skip the booleans. Ctrl-C ends the build within a second "
                 "and leaves no partial file (exit 130).",
        "examples": ["cadpipe build assets/examples/tee.toml -o out/tee.stl -o out/tee.usda",
                     "cadpipe build assets/examples/manifold.toml -o out/manifold.glb "
                     "--mode parts -q"],
    },
    "check": {
        "about": "Loads a mesh file and reports whether it is a closed, outward, "
                 "non-self-intersecting solid: triangle and vertex counts, volume, area, "
                 "bounds, bodies and the problems found ([export.md](export.md)). Faces "
                 "that touch within the file's coordinate precision (float32, or 3MF's and "
                 "OBJ's decimals of float32) do not count as crossing.",
        "exit": {0: "the file is a valid closed solid",
                 1: "it is not (the report says why), or it cannot be read"},
        "examples": ["cadpipe check out/tee.stl", "cadpipe check out/tee.stl --json"],
    },
    "collide": {
        "about": "Reads a spec file ([spec.md](spec.md)) and checks every pair of its added "
                 "parts and its robot's links: self-collision of the links first, then "
                 "bounding volumes, then exact tests ([collision.md](collision.md)). Prints "
                 "each colliding pair with the stage that decided it and a count per stage.",
        "exit": {0: "the check ran; colliding pairs are reported, not signalled by the exit "
                    "code"},
        "examples": ["cadpipe collide assets/examples/robot_cell.toml",
                     "cadpipe collide assets/examples/robot_cell.toml --json --svg out/certificates"],
    },
    "batch": {
        "about": "Reads a JOBS file ([batch.md](batch.md)): spec builds, spec templates filled "
                 "from a grid or CSV rows of parameters, and robot trajectories to check in a "
                 "cell and wrap in a safety pipe. Runs them on a Dask cluster of one process "
                 "per core (or `--scheduler`'s cluster), each job writing into `OUT/<job>/`, "
                 "and writes `summary.json` and `summary.html` (a row per job: verdict, first "
                 "collision and its time, clearance, files, error). A failing job is recorded "
                 "and the batch goes on; a re-run skips the jobs whose outputs are complete. "
                 "On a terminal a bar shows jobs done / failed / running; otherwise one line "
                 "per job goes to stderr.",
        "exit": {0: "every job ran (collisions are verdicts, not failures)",
                 1: "bad input (the JOBS file, a spec or trajectory it names): nothing ran",
                 3: "the batch ran but some jobs failed; their errors are in the summary"},
        "examples": ["cadpipe batch assets/examples/batch/jobs.toml -o out/batch --workers 0"],
    },
    "view": {
        "about": "Renders `preview.png` (offscreen, no display or GPU needed) and writes "
                 "`preview.html`, a self-contained page that shows the mesh in 3D and opens "
                 "without network access.",
        "examples": ["cadpipe view out/tee.stl -o out/preview",
                     "cadpipe view out/tee.stl -o out/preview --view top"],
    },
}


def _subparsers(parser):
    """``{name: parser}`` of the subcommands, in the order they were registered."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    return {}


def _is_limit(action):
    from cadpipe import limits

    return action.dest in limits.CLI_FLAGS


def _options(parser, which=lambda action: not _is_limit(action)):
    """The parser's arguments, positionals first, as argparse shows them; the limit
    flags every command shares are listed once (``which=_is_limit``)."""
    actions = [a for a in parser._actions if not isinstance(a, argparse._SubParsersAction)
               and which(a)]
    return [a for a in actions if not a.option_strings] + [a for a in actions if a.option_strings]


def _value(action):
    """What follows the option on the command line (empty for a flag or a positional)."""
    if action.nargs == 0 or not action.option_strings:
        return ""
    if action.choices is not None:
        return " \\| ".join(f"`{c}`" for c in action.choices)
    return f"`{action.metavar or action.dest.upper()}`"


def _default(action):
    if not action.option_strings:
        return "required"
    if action.nargs == 0 or action.default in (None, [], argparse.SUPPRESS):
        return ""
    return f"`{action.default}`"


def _usage_word(action):
    if not action.option_strings:
        return action.metavar or action.dest
    flag = action.option_strings[0]
    if action.nargs == 0:
        return f"[{flag}]"
    metavar = "{" + ",".join(action.choices) + "}" if action.choices else \
        action.metavar or action.dest.upper()
    return f"[{flag} {metavar}]"


def _usage(prog, parser):
    """A one-line usage, options before positionals, as argparse writes it."""
    ordered = sorted(_options(parser), key=lambda a: not a.option_strings)   # stable
    return " ".join([prog, *map(_usage_word, ordered)])


def _table(parser, which=lambda action: not _is_limit(action)):
    rows = ["| argument | value | default | meaning |", "| --- | --- | --- | --- |"]
    for action in _options(parser, which):
        name = ", ".join(f"`{s}`" for s in action.option_strings) or \
            f"`{action.metavar or action.dest}`"
        meaning = (action.help or "") % {**vars(action), "prog": parser.prog}
        meaning = meaning.replace("|", "\\|")                       # inside a table cell
        rows.append(f"| {name} | {_value(action)} | {_default(action)} | {meaning} |")
    return rows


def _exit_table(codes):
    return ["| exit | meaning |", "| --- | --- |"] + \
        [f"| {code} | {text} |" for code, text in sorted(codes.items())]


def cli_reference():
    """The text of ``docs/cli.md``."""
    from cadpipe.cli import commands  # noqa: F401  (registers the subcommands)

    parser = build_parser()
    found = _subparsers(parser)
    if set(found) != set(COMMANDS):
        raise SystemExit(f"docs/make_docs.py: COMMANDS lists {', '.join(COMMANDS)} but the "
                         f"command has {', '.join(found)}; describe each subcommand there "
                         "(what it does, exit codes, examples)")
    subcommands = {name: found[name] for name in COMMANDS}     # pipeline order
    lines = ["# The `cadpipe` command",
             "",
             "<!-- generated by docs/make_docs.py from cadpipe.cli.build_parser(); "
             "edit that script, not this file -->",
             "",
             parser.description,
             "Installed by `pip install` (or `make demo` / `make test`, which set up `.venv/`) "
             "as the `cadpipe` console script; `python -m cadpipe` is the same command.",
             "",
             "```",
             _usage("cadpipe", parser) + " COMMAND ...",
             "```",
             "",
             *_table(parser),
             "",
             "| command | what it does |",
             "| --- | --- |"]
    lines += [f"| [`{name}`](#cadpipe-{name}) | {sub.description} |"
              for name, sub in subcommands.items()]
    lines += ["", "Exit codes, the same for every command unless its section says otherwise:",
              "", *_exit_table(EXIT_CODES), "",
              "Limits: every command takes one flag per safety limit (docs/spec.md, *Limits*); "
              "a value given here wins over the spec's key of the same name. Work that would "
              "exceed a limit is refused before it starts, with a message naming the flag.",
              "", *_table(next(iter(subcommands.values())), _is_limit), ""]
    for name, sub in subcommands.items():
        extra = COMMANDS[name]
        lines += [f"## cadpipe {name}", "", sub.description, "", extra["about"], "",
                  "```", _usage(f"cadpipe {name}", sub), "```", "", *_table(sub), "",
                  "and the limit flags, each followed by a number (see *Limits* above): " + ", ".join(
                      f"`{a.option_strings[0]}`" for a in _options(sub, _is_limit)), ""]
        if "exit" in extra:
            lines += [*_exit_table({**EXIT_CODES, **extra["exit"]}), ""]
        lines += ["Examples (from the repository root):", "", "```sh", *extra["examples"],
                  "```", ""]
    return "\n".join(lines)


# -- figures -----------------------------------------------------------------------------
def _svg_colour(rgb):
    return "#%02x%02x%02x" % tuple(int(c) for c in np.round(np.clip(rgb, 0.0, 1.0) * 255))


def fin(pipe, width):
    """A strip from each ring's centre towards its vertex 0: the frame made visible."""
    p, n = pipe.path.points, pipe.normals
    k = len(p)
    i = np.arange(k - 1)
    faces = np.concatenate([np.column_stack([i, i + 1, i + k]),
                            np.column_stack([i + 1, i + k + 1, i + k])])
    return cadpipe.Mesh(np.concatenate([p, p + width * n]), faces)


def frames_figure(path):
    """Rotation-minimizing vs patent frames on a helix beside the origin, rendered by cadpipe."""
    from cadpipe.io.preview import render_png
    from cadpipe.core.color import parse_color
    from cadpipe.solids.scene import Scene, ScenePart

    t = np.linspace(0.0, 4 * np.pi, 240)
    helix = cadpipe.Path(np.column_stack([0.5 * np.cos(t) + 0.8, 0.5 * np.sin(t), 0.15 * t]))
    fins, tubes, origins = [], [], []
    for k, frame in enumerate(("rmf", "patent")):
        shift = np.eye(4)
        shift[0, 3] = 2.6 * k
        pipe = cadpipe.Pipe(helix, 0.03, 12, frame=frame)
        fins.append(fin(pipe, 0.25).transformed(shift))
        tubes.append(pipe.mesh().transformed(shift).with_parts(("path",)))
        origins.append(cadpipe.primitives.sphere(0.06).transformed(shift).with_parts(("origin O",)))
    parts = (ScenePart("rotation-minimizing (default)", fins[0], parse_color("#4e79a7")),
             ScenePart("patent: unit(OP x L)", fins[1], parse_color("#f28e2b")),
             ScenePart("path", cadpipe.Mesh.concatenate(tubes), parse_color("#8a8a8a")),
             ScenePart("origin O", cadpipe.Mesh.concatenate(origins), parse_color("#222222")))
    return render_png(Scene("the same helix, two frame rules", parts), path, size=(900, 520),
                      view="front")


def wireframe_svg(mesh, view, labels, width=900):
    """``mesh`` as an SVG of its front faces, each outlined and filled with its part's colour.

    Faces are projected orthographically and painted far to near (enough for a tube
    seen from the side). ``labels`` maps part names to legend text.
    """
    from cadpipe.io.preview import AMBIENT, DIFFUSE, LIGHT, PALETTE, view_rotation

    camera = mesh.vertices @ view_rotation(view).T
    corners = camera[mesh.faces]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    front = np.flatnonzero(normals[:, 2] > 1e-9)
    front = front[np.argsort(corners[front, :, 2].mean(axis=1), kind="stable")]
    lo, hi = camera[:, :2].min(axis=0), camera[:, :2].max(axis=0)
    pad = 0.04 * float((hi - lo).max())
    scale = width / float(hi[0] - lo[0] + 2 * pad)
    legend = 22 * len(labels) + 10
    height = float(hi[1] - lo[1] + 2 * pad) * scale + legend
    xy = np.column_stack([(camera[:, 0] - lo[0] + pad) * scale,
                          height - (camera[:, 1] - lo[1] + pad) * scale])
    light = AMBIENT + DIFFUSE * np.clip(normals @ LIGHT, 0.0, 1.0)
    palette = np.array(PALETTE)
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height:.0f}" '
           f'viewBox="0 0 {width} {height:.1f}" font-family="sans-serif" font-size="14">',
           f'<rect width="{width}" height="{height:.1f}" fill="#ffffff"/>']
    for f in front:
        points = " ".join(f"{x:.1f},{y:.1f}" for x, y in xy[mesh.faces[f]])
        colour = _svg_colour(palette[mesh.face_part[f]] * light[f])
        out.append(f'<polygon points="{points}" fill="{colour}" stroke="#1a1a1a" '
                   'stroke-width="0.7" stroke-linejoin="round"/>')
    for row, name in enumerate(mesh.part_names):
        y = 10 + 22 * row
        out.append(f'<rect x="10" y="{y}" width="14" height="14" '
                   f'fill="{_svg_colour(palette[row])}" stroke="#1a1a1a"/>')
        out.append(f'<text x="32" y="{y + 12}">{labels[name]}</text>')
    out.append("</svg>")
    return "\n".join(out) + "\n"


def splice_figure(path):
    """A 4-gon pipe spliced to a 6-gon pipe through 12-gon transition rings."""
    square = cadpipe.Pipe([[0, 0, 0], [0.5, 0, 0], [1, 0, 0]], 0.25, sides=4)
    hexagon = cadpipe.Pipe([[2.2, 0, 0], [2.7, 0, 0], [3.2, 0, 0]], 0.3, sides=6)
    mesh = cadpipe.splice(square, hexagon, transition="lcm")
    labels = {"pipe0": "pipe0: 4-gon rings",
              "transition0": "transition0: 12-gon rings, lcm(4, 6), stitched 3-to-1 and 2-to-1",
              "pipe1": "pipe1: 6-gon rings"}
    path.write_text(wireframe_svg(mesh, (-70.0, 25.0), labels), encoding="utf-8")
    return path


def hooks():
    """Two pipes whose bounding boxes overlap, hooked so that no straight cut parts them."""
    return {"duct": cadpipe.Pipe([[0, 1.5, 0], [0, 0, 0], [2, 0, 0], [2, 1.2, 0], [1.5, 1.2, 0]],
                                 0.15, 16, caps="round"),
            "cable": cadpipe.Pipe([[1, 0.4, 0], [1, 2, 0], [3, 2, 0], [3, 0.5, 0]], 0.15, 16,
                                  caps="round")}


def certificate_figures(svg_path, png_path):
    """The separating chain for :func:`hooks` and the pipes it separates, seen from above."""
    from cadpipe.collision.certificate_svg import COLOURS
    from cadpipe.io.preview import render_png
    from cadpipe.core.color import parse_color
    from cadpipe.solids.scene import Scene, ScenePart

    pipes = hooks()
    world = cadpipe.CollisionWorld()
    for name, pipe in pipes.items():
        world.add(name, pipe)
    cert = world.separate("duct", "cable")
    if cert is None or cert.kind != "chain" or not cert.verify():
        raise SystemExit("docs/make_docs.py: the hooks no longer give a verified chain "
                         "certificate; adjust hooks()")
    cert.save_svg(svg_path)
    parts = tuple(ScenePart(name, pipes[name].mesh(), parse_color(colour))
                  for name, colour in zip(cert.names, COLOURS))
    render_png(Scene("duct and cable", parts), png_path, size=(640, 420), view="top")
    return svg_path, png_path


def figures(folder):
    """Draw every figure into ``folder``; return the paths written."""
    folder = FilePath(folder)
    folder.mkdir(parents=True, exist_ok=True)
    return [frames_figure(folder / "frames.png"),
            splice_figure(folder / "lcm_splice.svg"),
            *certificate_figures(folder / "certificate.svg", folder / "certificate_scene.png")]


def main():
    (DOCS / "cli.md").write_text(cli_reference(), encoding="utf-8")
    print(f"wrote {DOCS / 'cli.md'}")
    for written in figures(DOCS / "figures"):
        print(f"wrote {written}")


if __name__ == "__main__":
    sys.exit(main())
