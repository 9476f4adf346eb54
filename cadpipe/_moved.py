"""Module paths of cadpipe 0.1, importable for one more release with a DeprecationWarning.

0.2 grouped the flat modules into the pipeline's stages (``geometry``, ``solids``,
``io``, ``collision``, ``cli``). An import of an old path, say ``cadpipe.pipe``,
is answered with the module now at ``cadpipe.geometry.pipe`` (the same object,
so state and ``isinstance`` agree) and a warning naming the new path.
``cadpipe.splice`` is not aliased: that name is the function.
"""

import importlib
import importlib.abc
import importlib.util
import sys
import warnings

OLD_PATHS = {
    "cadpipe.assembly": "cadpipe.solids.assembly",
    "cadpipe.booleans": "cadpipe.solids.booleans",
    "cadpipe.clearance": "cadpipe.geometry.clearance",
    "cadpipe.commands": "cadpipe.cli.commands",
    "cadpipe.commands.build": "cadpipe.cli.build",
    "cadpipe.commands.check": "cadpipe.cli.check",
    "cadpipe.commands.collide": "cadpipe.cli.collide",
    "cadpipe.commands.demo": "cadpipe.cli.demo",
    "cadpipe.commands.view": "cadpipe.cli.view",
    "cadpipe.demo": "cadpipe.cli.welding_cell",
    "cadpipe.exporters": "cadpipe.io.files",
    "cadpipe.exporters.flatten": "cadpipe.io.flatten",
    "cadpipe.exporters.normals": "cadpipe.io.normals",
    "cadpipe.exporters.stl": "cadpipe.io.stl",
    "cadpipe.exporters.text": "cadpipe.io.text",
    "cadpipe.exporters.threemf": "cadpipe.io.threemf",
    "cadpipe.exporters.trimesh_formats": "cadpipe.io.trimesh_formats",
    "cadpipe.exporters.usd": "cadpipe.io.usd",
    "cadpipe.frames": "cadpipe.geometry.frames",
    "cadpipe.hollow": "cadpipe.solids.hollow",
    "cadpipe.inspect": "cadpipe.solids.validity",
    "cadpipe.intersect": "cadpipe.solids.intersect",
    "cadpipe.loft": "cadpipe.geometry.loft",
    "cadpipe.mesh": "cadpipe.geometry.mesh",
    "cadpipe.parts": "cadpipe.io.parts",
    "cadpipe.path": "cadpipe.geometry.path",
    "cadpipe.pipe": "cadpipe.geometry.pipe",
    "cadpipe.preview": "cadpipe.io.preview",
    "cadpipe.primitives": "cadpipe.solids.primitives",
    "cadpipe.ragged": "cadpipe.geometry.ragged",
    "cadpipe.raster": "cadpipe.io.raster",
    "cadpipe.registry": "cadpipe.io.registry",
    "cadpipe.scene": "cadpipe.io.scene",
    "cadpipe.spec": "cadpipe.io.spec",
    "cadpipe.transform": "cadpipe.core.transform",
    "cadpipe.tubes": "cadpipe.geometry.rings",
}


class _Alias(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    def find_spec(self, name, path=None, target=None):
        if name not in OLD_PATHS:
            return None
        return importlib.util.spec_from_loader(name, self)

    def create_module(self, spec):
        warnings.warn(f"{spec.name} moved to {OLD_PATHS[spec.name]}; the old path goes in "
                      "cadpipe 0.3", DeprecationWarning, stacklevel=4)
        return importlib.import_module(OLD_PATHS[spec.name])

    def exec_module(self, module):
        """Nothing to run: the module is the one at the new path."""


def install():
    """Answer the old module paths (idempotent)."""
    if not any(isinstance(f, _Alias) for f in sys.meta_path):
        sys.meta_path.append(_Alias())
