"""``cadpipe check FILE``: is a mesh file a valid closed solid?"""

import json

from cadpipe.cli import command
from cadpipe.solids.validity import check_mesh
from cadpipe.geometry.mesh import Mesh


def _arguments(parser):
    parser.add_argument("file", metavar="FILE",
                        help="mesh file in any format trimesh reads (STL, 3MF, OBJ, PLY, GLB, ...)")
    parser.add_argument("--json", action="store_true",
                        help="print the report as one JSON object (for scripts)")


@command("check", "Check that a mesh file is a closed, outward, non-self-intersecting solid "
                  "(exit 0) or say why not (exit 1).", _arguments)
def check(args):
    report = check_mesh(Mesh.load(args.file))
    if args.json:
        print(json.dumps({"file": args.file, **report}))
    else:
        print(format_report(args.file, report))
    return 0 if report["valid"] else 1


def format_report(name, report):
    """The report as aligned, human-readable lines."""
    def yes(flag):
        return "yes" if flag else "NO"

    low, high = report["bounds"]
    verdict = "valid closed solid" if report["valid"] else "NOT a valid closed solid"
    rows = [
        ("triangles", f"{report['triangles']:,}"),
        ("vertices", f"{report['vertices']:,}"),
        ("watertight", yes(report["watertight"])),
        ("winding consistent", yes(report["winding_consistent"])),
        ("outward", yes(report["outward"])),
        ("volume", f"{report['volume']:.6g}"),
        ("area", f"{report['area']:.6g}"),
        ("bounds", "[" + ", ".join(f"{v:.6g}" for v in low) + "] .. ["
         + ", ".join(f"{v:.6g}" for v in high) + "]"),
        ("bodies", str(report["bodies"])),
        ("intersecting faces", str(report["intersecting_face_pairs"])),
    ]
    lines = [f"{name}: {verdict}"] + [f"  {key:<20}{value}" for key, value in rows]
    lines += [f"  problem: {p}" for p in report["problems"]]
    return "\n".join(lines)
