"""``cadpipe check FILE``: is each solid in a mesh or scene file a valid closed solid?"""

import json

from cadpipe.cli import command
from cadpipe.core.formats import load_scene
from cadpipe.solids.validity import check_mesh

#: extents (in the unit a unitless file is read in) that suggest another unit
_SUSPECT = {"mm": (lambda extent: extent < 2.0, "metres"),
            "m": (lambda extent: extent > 100.0, "millimetres")}


def _arguments(parser):
    parser.add_argument("file", metavar="FILE",
                        help="mesh or scene file (STL, 3MF, OBJ, PLY, GLB, USD/USDA/USDC/USDZ, "
                             "...)")
    parser.add_argument("--json", action="store_true",
                        help="print the report as one JSON object (for scripts)")


@command("check", "Check that each part of a mesh file is a closed, outward, "
                  "non-self-intersecting solid (exit 0) or say why not (exit 1).", _arguments)
def check(args):
    report = check_file(args.file)
    if args.json:
        print(json.dumps({"file": args.file, **report}))
    else:
        print(format_report(args.file, report))
    return 0 if report["valid"] else 1


def check_file(path):
    """:func:`~cadpipe.solids.validity.check_mesh` of a file: of its one part, or of each
    part of a scene (``parts``: name and report each; ``valid`` when all are), with
    ``units`` and ``warnings`` (a unitless file whose size suggests another unit)."""
    scene = load_scene(path)
    reports = [(part.name, check_mesh(part.world_mesh())) for part in scene.parts]
    if len(reports) == 1:
        report = dict(reports[0][1])
    else:
        report = {"valid": all(r["valid"] for _, r in reports),
                  "problems": [f"part {name!r}: {p}" for name, r in reports
                               for p in r["problems"]],
                  "triangles": sum(r["triangles"] for _, r in reports),
                  "vertices": sum(r["vertices"] for _, r in reports),
                  "parts": [{"name": name, **r} for name, r in reports]}
    report["units"] = scene.units
    report["warnings"] = unit_warnings(scene)
    return report


def unit_warnings(scene):
    """Sentences for a file without units whose extent suggests another unit than assumed."""
    first = scene.parts[0].mesh.attributes
    if not first.get("units_assumed") or scene.units not in _SUSPECT:
        return []
    bounds = [part.world_mesh().bounds for part in scene.parts]
    extent = max(float((b[1] - b[0]).max()) for b in bounds)
    suspect, other = _SUSPECT[scene.units]
    if not suspect(extent):
        return []
    return [f"the file has no units and is read in {scene.units}; its largest extent, "
            f"{extent:.6g} {scene.units}, suggests it was written in {other} "
            f"(write it with units=\"{scene.units}\", --units {scene.units})"]


def format_report(name, report):
    """The report as aligned, human-readable lines."""
    if "parts" in report:
        verdict = "every part a valid closed solid" if report["valid"] else \
            "NOT every part a valid closed solid"
        lines = [f"{name}: {verdict} ({len(report['parts'])} parts, units {report['units']})"]
        for part in report["parts"]:
            lines.append(_part_line(part))
        lines += [f"  problem: {p}" for p in report["problems"]]
        lines += [f"  warning: {w}" for w in report["warnings"]]
        return "\n".join(lines)

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
        ("units", report["units"]),
        ("bodies", str(report["bodies"])),
        ("intersecting faces", str(report["intersecting_face_pairs"])),
        ("nested shells", str(report["nested_shells"])),
    ]
    lines = [f"{name}: {verdict}"] + [f"  {key:<20}{value}" for key, value in rows]
    lines += [f"  problem: {p}" for p in report["problems"]]
    lines += [f"  warning: {w}" for w in report["warnings"]]
    return "\n".join(lines)


def _part_line(part):
    state = "valid" if part["valid"] else "NOT valid"
    return (f"  {part['name']:<24}{state:<10}{part['triangles']:>10,} triangles  "
            f"volume {part['volume']:.6g}  bodies {part['bodies']}")
