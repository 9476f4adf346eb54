"""``cadpipe collide``: check the robot cell a spec file describes for collisions."""

import json
import re

from cadpipe.cli import budgets, command


def _arguments(parser):
    parser.add_argument("spec", metavar="SPEC", help="spec file of the cell (.toml or .json)")
    parser.add_argument("--json", action="store_true", help="print the report as JSON")
    parser.add_argument("--svg", metavar="DIR",
                        help="write a separation certificate (SVG) for every pair whose boxes "
                             "overlap but which do not touch")


def _safe(name):
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name)


@command("collide", "Check the parts and robot of a spec file (TOML/JSON) for collisions.",
         _arguments)
def collide(args):
    from cadpipe.spec import world_from_spec
    from cadpipe.io.files import ensure_folder
    from cadpipe.spec import read

    spec = read(args.spec, **budgets(args))
    world, options = world_from_spec(spec), dict(spec.cell.check)
    if args.svg:
        options["certify"] = True
    report = world.check(**options)
    written = []
    if args.svg:
        folder = ensure_folder(args.svg)
        for pair in report.pairs:
            if pair.certificate is not None:
                target = folder / f"{_safe(pair.a)}__{_safe(pair.b)}.svg"
                written.append(str(pair.certificate.save_svg(target)))
    if args.json:
        print(json.dumps({**report.to_dict(), "svg": written}, indent=2))
        return 0
    for a, b, detail in report.collisions:
        print(f"COLLISION  {a} <-> {b}  ({detail.phase}, decided by {detail.decided_by})")
    if report.stopped_after_self:
        print("stopped after self-collision: robot-vs-world pairs were not checked")
    counts = ", ".join(f"{n} {stage}" for stage, n in report.counts().items())
    print(f"{len(report.collisions)} colliding pair(s) among {len(report.pairs)} "
          f"({counts})")
    for path in written:
        print(f"wrote {path}")
    return 0
