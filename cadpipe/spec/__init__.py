"""Spec files: assemblies and robot cells written as TOML or JSON, read into the same
API calls a script makes (``docs/spec.md``).

The loader builds every kind of object -- pipes, hollow parts, primitives, imported
meshes, robots, collision worlds -- so it sits above all of them, beside
:mod:`cadpipe.batch`, and none of them imports it.
"""

from cadpipe.spec import parts  # noqa: F401  (registers cadpipe's own part kinds)
from cadpipe.spec.cell import world_from_spec
from cadpipe.spec.reader import Number, Spec, SpecContext, load, parse, part_kinds, read

__all__ = ["Number", "Spec", "SpecContext", "load", "parse", "part_kinds", "read",
           "world_from_spec"]
