"""cadpipe: watertight tube meshes along 3D paths.

The pipeline, top to bottom: :class:`Path` (step S1) -> frames and rings ->
:class:`Pipe` (S2-S4) -> :func:`splice` (S5) -> :class:`Mesh`, then export.
"""

from cadpipe import batch  # noqa: F401  (cadpipe.batch.run)
from cadpipe.solids import primitives  # noqa: F401  (cadpipe.primitives.box, ...)
from cadpipe.solids.assembly import Assembly
from cadpipe.collision import CollisionWorld
from cadpipe.errors import CadpipeError, ExportError, GeometryError, InputError, MeshError, SpecError
from cadpipe.solids.hollow import HollowChain, HollowPipe, Junction
from cadpipe.solids.validity import check_mesh
from cadpipe.geometry.mesh import Mesh
from cadpipe.geometry.path import Path
from cadpipe.geometry.pipe import Pipe
from cadpipe.io.spec import load
from cadpipe.geometry.splice import splice

__version__ = "0.1.0"

__all__ = ["CadpipeError", "CollisionWorld", "ExportError", "GeometryError", "InputError",
           "Mesh", "MeshError", "Path", "Pipe", "SpecError", "__version__", "check_mesh",
           "splice"]
__all__ += ["Assembly", "HollowChain", "HollowPipe", "Junction", "load"]

from cadpipe import limits  # noqa: E402,F401  (cadpipe.limits.using(max_triangles=...))
from cadpipe.errors import LimitError  # noqa: E402

__all__ += ["LimitError", "limits"]

from cadpipe import _moved

_moved.install()
