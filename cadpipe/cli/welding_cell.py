"""The built-in example: a welding cell, run through the whole pipeline.

A weld seam on a workpiece is fitted as a spline; safety pipes of three mouth
shapes follow it and are spliced through LCM transitions; a hollow, printable
coolant tee stands beside it; a six-axis arm (``assets/robots/arm6``) is posed
with its torch at the seam. The cell is checked for collisions (with a separation
certificate for a pair whose boxes overlap) and written as USD, STL, GLB, a JSON
report and two previews.
"""

import json
from dataclasses import dataclass
from pathlib import Path as FilePath

import numpy as np

from cadpipe.solids.assembly import Assembly
from cadpipe.collision import CollisionWorld
from cadpipe.collision.robot import Robot
from cadpipe.errors import ExportError
from cadpipe.io.files import atomic_path, ensure_folder
from cadpipe.solids.hollow import HollowPipe, Junction
from cadpipe.geometry.path import Path
from cadpipe.geometry.pipe import Pipe
from cadpipe.io.preview import render_png, write_html
from cadpipe.solids.primitives import box
from cadpipe.geometry.splice import splice

ASSETS = FilePath(__file__).resolve().parents[2] / "assets"
ARM = ASSETS / "robots" / "arm6" / "arm6.urdf"

#: the weld seam's control points on top of the workpiece (metres)
WELD_SEAM = np.array([[0.48, -0.16, 0.125], [0.58, -0.10, 0.125], [0.64, 0.0, 0.125],
                      [0.60, 0.10, 0.125], [0.50, 0.17, 0.125]])
#: the arm's joint values: torch tip at the seam, and (too) deep
ARM_POSE = [0.0, 0.95, 1.25, 0.0, 0.9, 0.0]
#: the safety pipes' mouths along the seam: sides of each section
MOUTHS = (6, 8, 12)

FILES = ("scene.usda", "scene.usdz", "parts.stl", "scene.glb", "report.json", "preview.png",
         "preview.html")


def weld_sections(path, count, gap):
    """``count`` pieces of ``path``, each separated from the next by ``gap`` of arc length."""
    piece = (path.length - gap * (count - 1)) / count
    starts = np.arange(count) * (piece + gap)
    return [path.trimmed(s, max(path.length - s - piece, 0.0)) for s in starts]


@dataclass(frozen=True)
class Cell:
    """Everything the demo builds, for the report and for tests."""

    assembly: Assembly
    printable: Assembly
    world: CollisionWorld
    seam: Path
    safety: object


def build_cell():
    """The demo cell: the scene, the printable parts, the collision world."""
    seam = Path.spline(WELD_SEAM, step=0.005)
    pipes = [Pipe(section, 0.02, sides=n, caps="round", envelope=True)
             for section, n in zip(weld_sections(seam, len(MOUTHS), 0.04), MOUTHS)]
    safety = splice(*pipes, transition="lcm")

    workpiece = box([0.36, 0.5, 0.12])
    workpiece_at = np.eye(4)
    workpiece_at[:3, 3] = [0.56, 0.0, 0.06]

    def leg(points):
        return HollowPipe(Pipe(points, 0.03, sides=24), wall=0.004, ends="open")

    coolant = Junction(leg([[0.25, -0.45, 0.20], [0.25, 0.15, 0.20]]),
                       leg([[0.25, 0.0, 0.20], [0.25, 0.0, 0.40]]))

    arm = Robot.from_urdf(ARM)
    scene = Assembly(units="m", name="weld_cell")
    scene.add("workpiece", workpiece, transform=workpiece_at, color="#9ca3af")
    scene.add("safety_pipe", safety, color="#3b82f6")
    scene.add("coolant_tee", coolant, color="#f59e0b")
    poses = arm.link_poses(ARM_POSE)
    for link, mesh in arm.link_meshes.items():
        scene.add(link, mesh, transform=poses[link], color="#64748b")

    printable = Assembly(units="m", name="printable")
    printable.add("safety_pipe", safety, color="#3b82f6")
    printable.add("coolant_tee", coolant, color="#f59e0b")

    world = CollisionWorld()
    world.add_robot(arm, joints=ARM_POSE, group="arm6")
    world.add("workpiece", workpiece, transform=workpiece_at)
    world.add("coolant_tee", coolant.mesh())
    world.add("safety_pipe", safety)
    world.allow("workpiece", "safety_pipe", reason="the safety pipe follows the seam on it")
    world.allow("tool", "safety_pipe", reason="the torch works inside its safety pipe")
    return Cell(scene, printable, world, seam, safety)


def separation_certificate(world, report):
    """A verified certificate for the first pair whose axis-aligned boxes overlap but
    that is apart (decided by a finer test than the boxes)."""
    for pair in report.pairs:
        if not pair.colliding and pair.decided_by not in ("allowed", "aabb", "not checked"):
            certificate = world.separate(pair.a, pair.b)
            if certificate is not None:
                return certificate
    return None


def summarize(cell, report, certificate):
    """The demo's report: what was built, what collides, and the proof of one clearance."""
    solid = cell.printable.union()
    torch_inside = cell.safety.contains(cell.seam.points)
    out = {
        "seam": {"points": len(cell.seam), "length_m": cell.seam.length},
        "safety_pipe": {"mouths": list(MOUTHS), "transition": "lcm",
                        "triangles": len(cell.safety.faces),
                        "watertight": cell.safety.is_watertight,
                        "torch_path_inside": bool(torch_inside.all())},
        "printable": {"triangles": len(solid.faces), "watertight": solid.is_watertight,
                      "bodies": solid.n_bodies, "volume_cm3": solid.volume * 1e6},
        "collision": {k: v for k, v in report.to_dict().items() if k != "pairs"},
        "certificate": None,
    }
    if certificate is not None:
        out["certificate"] = {"a": certificate.names[0], "b": certificate.names[1],
                              "kind": certificate.kind, "verified": certificate.verify(),
                              "plane_axes": "xyz"[certificate.axes[0]] + "xyz"[certificate.axes[1]],
                              "chain": certificate.chain.tolist()}
    return out


def run_demo(folder, echo=print):
    """Build the demo cell into ``folder``; return the paths written."""
    if not ARM.is_file():
        raise ExportError(f"{ARM}: the demo's assets are missing; run the demo from a "
                          "cadpipe checkout (make demo)")
    folder = ensure_folder(folder)
    cell = build_cell()
    report = cell.world.check()
    certificate = separation_certificate(cell.world, report)
    summary = summarize(cell, report, certificate)
    highlight = sorted({name for a, b, _ in report.collisions for name in (a, b)})

    written = [cell.assembly.export(folder / "scene.usda"),
               cell.assembly.export(folder / "scene.usdz"),
               cell.printable.export(folder / "parts.stl"),
               cell.assembly.export(folder / "scene.glb")]
    with atomic_path(folder / "report.json") as tmp:
        tmp.write_text(json.dumps(summary, indent=2), encoding="utf-8")
    written.append(folder / "report.json")
    render_png(cell.assembly, folder / "preview.png", highlight=highlight)
    write_html(cell.assembly, folder / "preview.html", report=summary, highlight=highlight)
    written += [folder / "preview.png", folder / "preview.html"]
    if certificate is not None:
        written.append(certificate.save_svg(folder / "certificate.svg"))

    seam, pipe, solid = summary["seam"], summary["safety_pipe"], summary["printable"]
    echo(f"weld seam: spline of {seam['points']} points, {seam['length_m']:.3f} m")
    echo(f"safety pipe: {'/'.join(map(str, MOUTHS))}-gon mouths spliced through LCM "
         f"transitions, {pipe['triangles']:,} triangles, watertight={pipe['watertight']}, "
         f"torch path inside={pipe['torch_path_inside']}")
    echo(f"printable parts (parts.stl): {solid['triangles']:,} triangles, "
         f"watertight={solid['watertight']}, volume {solid['volume_cm3']:.1f} cm^3")
    for a, b, detail in report.collisions:
        echo(f"COLLISION  {a} <-> {b}  (decided by {detail.decided_by})")
    if certificate is not None:
        echo(f"apart      {certificate.names[0]} <-> {certificate.names[1]}: boxes overlap, "
             f"separation certificate ({certificate.kind}) verified")
    echo(f"wrote {len(written)} files to {folder}/: " + ", ".join(p.name for p in written))
    return written
