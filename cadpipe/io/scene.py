"""What exporters write: named, coloured parts with their transforms and units.

An :class:`~cadpipe.Assembly` turns itself into a :class:`Scene` (``to_scene()``);
a lone Mesh or Pipe becomes a one-part scene. Exporters take a Scene, so every
format sees the same parts, names, colours and units.
"""

from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

from cadpipe.errors import InputError

#: length units a scene can be in, as metres per unit
UNITS = MappingProxyType({"m": 1.0, "cm": 0.01, "mm": 0.001, "in": 0.0254, "ft": 0.3048})


def meters_per_unit(units):
    try:
        return UNITS[units]
    except KeyError:
        raise InputError(f"units: expected one of {', '.join(UNITS)}, got {units!r}") from None


def parse_color(color):
    """An RGB triple of floats in [0, 1] from ``"#rrggbb"``, ``"#rgb"`` or three numbers."""
    if isinstance(color, str):
        text = color.strip().lstrip("#")
        if len(text) == 3:
            text = "".join(c * 2 for c in text)
        if len(text) != 6:
            raise InputError(f"expected '#rrggbb', got {color!r}", key="color")
        try:
            return tuple(int(text[i:i + 2], 16) / 255.0 for i in (0, 2, 4))
        except ValueError:
            raise InputError(f"expected '#rrggbb', got {color!r}", key="color") from None
    try:
        rgb = tuple(float(c) for c in color)
    except (TypeError, ValueError):
        raise InputError(f"expected '#rrggbb' or 3 numbers, got {color!r}",
                         key="color") from None
    if len(rgb) != 3 or not all(0.0 <= c <= 1.0 for c in rgb):
        raise InputError(f"expected 3 numbers in [0, 1], got {color!r}", key="color")
    return rgb


@dataclass(frozen=True)
class ScenePart:
    """One named part: its mesh in local coordinates and where it sits."""

    name: str
    mesh: object
    color: tuple = None
    transform: np.ndarray = None
    attributes: MappingProxyType = field(default_factory=lambda: MappingProxyType({}))

    def world_mesh(self):
        return self.mesh if self.transform is None else self.mesh.transformed(self.transform)


@dataclass(frozen=True)
class Scene:
    """Parts to write, the scene's name (the USD root prim) and its length unit.

    ``colors`` maps part names to colours for meshes whose faces carry part labels
    (a unioned assembly), so per-part colours survive a boolean.
    """

    name: str
    parts: tuple
    units: str = "m"
    up_axis: str = "Z"
    colors: MappingProxyType = field(default_factory=lambda: MappingProxyType({}))

    @property
    def meters_per_unit(self):
        return meters_per_unit(self.units)


def as_scene(obj, name="cadpipe"):
    """A :class:`Scene` from a Scene, anything with ``to_scene()``, a Mesh or a Pipe."""
    from cadpipe.geometry.mesh import Mesh

    if isinstance(obj, Scene):
        return obj
    if callable(getattr(obj, "to_scene", None)):
        return obj.to_scene()
    mesh = obj if isinstance(obj, Mesh) else getattr(obj, "mesh", None)
    if callable(mesh):
        mesh = mesh()
    if not isinstance(mesh, Mesh):
        raise InputError(f"cannot export a {type(obj).__name__}; expected a Mesh, Pipe, "
                         "Assembly or Scene")
    part = mesh.attributes.get("kind", "mesh")
    return Scene(name=name, parts=(ScenePart(part, mesh, attributes=mesh.attributes),))
