"""cadpipe: watertight tube meshes along 3D paths.

The pipeline, top to bottom: :class:`Path` (step S1) -> frames and rings ->
:class:`Pipe` (S2-S4) -> :func:`splice` (S5) -> :class:`Mesh`, then export.
"""

from . import primitives  # noqa: F401  (cadpipe.primitives.box, ...)
from .assembly import Assembly
from .collision import CollisionWorld
from .errors import CadpipeError, ExportError, GeometryError, InputError, MeshError, SpecError
from .hollow import HollowChain, HollowPipe, Junction
from .inspect import check_mesh
from .mesh import Mesh
from .path import Path
from .pipe import Pipe
from .spec import load
from .splice import splice

__version__ = "0.1.0"

__all__ = ["CadpipeError", "CollisionWorld", "ExportError", "GeometryError", "InputError",
           "Mesh", "MeshError", "Path", "Pipe", "SpecError", "__version__", "check_mesh",
           "splice"]
__all__ += ["Assembly", "HollowChain", "HollowPipe", "Junction", "load"]
