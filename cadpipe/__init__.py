"""cadpipe: watertight tube meshes along 3D paths.

The pipeline, top to bottom: :class:`Path` (step S1) -> frames and rings ->
:class:`Pipe` (S2-S4) -> :func:`splice` (S5) -> :class:`Mesh`, then
:class:`Assembly` (booleans) and files; :class:`CollisionWorld` beside it.

The public API is what ``__all__`` names here (plus ``cadpipe.primitives``,
``cadpipe.batch``, ``cadpipe.spec`` and ``cadpipe.collision.__all__``). The
subpackages' other modules are the layout of the implementation (see
docs/architecture.md) and may change while cadpipe is 0.x.
"""

# USD's libraries are loaded here, in the importing thread: loading them releases the GIL
# inside the dynamic loader, and a second thread loading any extension module meanwhile
# waits for the loader's lock holding the GIL (8 threads started right after import hung
# in 3 of 5 runs). 0.1 s of CPU.
from pxr import Gf, Sdf, Tf, Usd, UsdGeom, UsdShade, Vt  # noqa: F401

from cadpipe import io, limits  # noqa: F401  (cadpipe.limits; io registers the file formats)
from cadpipe.collision import CollisionWorld
from cadpipe.errors import (CadpipeError, ExportError, GeometryError, InputError, LimitError,
                            MeshError, SpecError)
from cadpipe.geometry.mesh import Mesh
from cadpipe.geometry.path import Path
from cadpipe.geometry.pipe import Pipe
from cadpipe.geometry.splice import splice
from cadpipe.spec import load
from cadpipe.solids import primitives  # noqa: F401  (cadpipe.primitives.box, ...)
from cadpipe.solids.assembly import Assembly
from cadpipe.solids.hollow import HollowChain, HollowPipe, Junction
from cadpipe.solids.validity import check_mesh

__version__ = "0.1.0"

__all__ = ["CadpipeError", "CollisionWorld", "ExportError", "GeometryError", "InputError",
           "Mesh", "MeshError", "Path", "Pipe", "SpecError", "__version__", "check_mesh",
           "splice"]
__all__ += ["Assembly", "HollowChain", "HollowPipe", "Junction", "LimitError", "batch", "limits",
            "load"]


def __getattr__(name):
    """``cadpipe.batch`` on first use: Dask and the job engine cost a fifth of a second
    at import, which a script that never runs a batch need not pay."""
    if name == "batch":
        import importlib

        return importlib.import_module("cadpipe.batch")
    raise AttributeError(f"module 'cadpipe' has no attribute {name!r}")

