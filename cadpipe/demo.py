"""The built-in example: a weld path fitted as a spline, made into a safety pipe."""

import numpy as np

from .exporters import ensure_folder
from .path import Path
from .pipe import Pipe

#: control points of the example weld seam (metres)
WELD_SEAM = np.array([[0.30, -0.20, 0.10], [0.45, -0.05, 0.18], [0.50, 0.15, 0.25],
                      [0.40, 0.30, 0.30], [0.25, 0.35, 0.28]])


def run_demo(folder, echo=print):
    """Build the example into ``folder`` and return the paths written."""
    ensure_folder(folder)
    path = Path.spline(WELD_SEAM, step=0.005)
    pipe = Pipe(path, radius=0.02, sides=12, caps="round", envelope=True)
    mesh = pipe.mesh()
    stl = mesh.export(folder / "parts.stl")
    echo(f"safety pipe: {len(path)} path points, {len(mesh.vertices)} vertices, "
         f"watertight={mesh.is_watertight}, volume={mesh.volume * 1e6:.1f} cm^3")
    echo(f"wrote {stl}")
    return [stl]
