"""Assemblies: named parts placed in space and combined by booleans into one solid.

An :class:`Assembly` records parts (pipes, hollow pipes and junctions, primitives,
imported meshes) with an operation each: *add*, *subtract* or *intersect*. Its
solid is::

    (union of added solids - union of subtracted solids and of every bore) & each intersected solid

A hollow part adds its outer solids and cuts its bores from the whole assembly, so
pipes stay open where they meet other parts and their bores never plug each
other. The order of calls does not matter. Every output triangle keeps the name of
the part it came from (manifold3d's original ids), so exports can colour and name
surfaces per part.
"""

from dataclasses import dataclass
from types import MappingProxyType

import numpy as np

from cadpipe._validate import as_choice
from cadpipe.solids.booleans import as_solid, combine, is_void, reserve_ids, snap
from cadpipe.errors import CadpipeError, GeometryError, InputError
from cadpipe.geometry.mesh import Mesh
from cadpipe.io.scene import Scene, ScenePart, meters_per_unit, parse_color
from cadpipe.solids.transform import as_matrix

OPERATIONS = ("add", "subtract", "intersect")

#: formats whose default export is the one unioned solid (printing); others get the parts
SOLID_FORMATS = frozenset({"stl", "3mf", "obj", "ply", "off"})
EXPORT_MODES = ("solid", "parts")


@dataclass(frozen=True)
class Part:
    """One entry of an assembly: what it is, where it sits and how it combines."""

    name: str
    obj: object
    op: str = "add"
    transform: np.ndarray = None
    color: tuple = None

    def shapes(self):
        """``(solids, bores)`` as meshes in the part's own coordinates.

        Hollow parts (anything with ``solids()``) give both; a :class:`Mesh` is
        welded first (:func:`cadpipe.solids.booleans.snap`), since it may come from a file;
        anything else with ``mesh()`` (a Pipe) gives its mesh.
        """
        if callable(getattr(self.obj, "solids", None)):
            return self.obj.solids()
        if isinstance(self.obj, Mesh):
            return [snap(self.obj)], []
        return [self.obj.mesh()], []

    @property
    def attributes(self):
        """Read-only mapping of the parameters that made the part's object."""
        return MappingProxyType(dict(getattr(self.obj, "attributes", {})))


class Assembly:
    """Named parts combined into one watertight solid.

    Parameters
    ----------
    units : str
        Length unit of every coordinate ("m", "cm", "mm", "in", "ft"); exporters
        write it (USD ``metersPerUnit``).
    name : str
        The assembly's name (USD root prim, default part name of the solid).
    """

    def __init__(self, units="m", name="assembly"):
        meters_per_unit(units)
        if not isinstance(name, str) or not name:
            raise InputError(f"name: expected a non-empty string, got {name!r}")
        self.units = units
        self.name = name
        self._parts = {}         # name -> Part, in the order given
        self._solids = None      # per part: (solids, bores) as manifold3d objects, world frame
        self._operands = None    # (adds, cuts, clips) gathered from _solids
        self._union = None

    def __repr__(self):
        return f"<cadpipe.Assembly {self.name!r}, {len(self._parts)} parts, units {self.units}>"

    @property
    def parts(self):
        """The parts in the order they were given."""
        return tuple(self._parts.values())

    # -- building -------------------------------------------------------------
    def add(self, name, obj, transform=None, color=None):
        """Add a solid: a Pipe, HollowPipe, Junction, Mesh (e.g. a primitive or a loaded file).

        ``transform`` is a 4x4 matrix placing it (see :func:`cadpipe.solids.transform.placement`);
        ``color`` is ``"#rrggbb"`` or three numbers in [0, 1].
        """
        return self._put(name, obj, "add", transform, color)

    def subtract(self, name, obj, transform=None, color=None):
        """Remove ``obj`` from the added solids; its cut faces keep ``name`` and ``color``."""
        return self._put(name, obj, "subtract", transform, color)

    def intersect(self, name, obj, transform=None, color=None):
        """Keep only what lies inside ``obj``."""
        return self._put(name, obj, "intersect", transform, color)

    def _put(self, name, obj, op, transform, color):
        if not isinstance(name, str) or not name:
            raise InputError(f"name: expected a non-empty string, got {name!r}")
        if name in self._parts:
            raise InputError(f"name: a part named {name!r} is already in the assembly; "
                             "part names must be unique")
        if not (isinstance(obj, Mesh) or callable(getattr(obj, "mesh", None))
                or callable(getattr(obj, "solids", None))):
            raise InputError(f"{name}: expected a Mesh, Pipe, HollowPipe or Junction, "
                             f"got {type(obj).__name__}")
        matrix = None
        if transform is not None:
            matrix = as_matrix(transform, f"{name}: transform")
            if np.array_equal(matrix, np.eye(4)):
                matrix = None
        rgb = None if color is None else parse_color(color)
        self._parts[name] = Part(name, obj, op, matrix, rgb)
        self._solids = self._union = None
        return self

    # -- combining ------------------------------------------------------------
    def _prepare(self, progress=None):
        """Validate and place every part's solids and bores as manifold3d objects, once."""
        if self._solids is not None:
            return
        placed_parts, names = [], {}
        for part in self._parts.values():
            try:
                shapes = part.shapes()
            except CadpipeError as exc:       # e.g. a pipe that intersects itself
                raise type(exc)(f"{part.name}: {exc}") from None
            ids = iter(reserve_ids(sum(map(len, shapes))))
            placed = []
            for kind, meshes in zip(("solid", "bore"), shapes):
                group = []
                for i, mesh in enumerate(meshes):
                    original = next(ids)
                    names[original] = part.name
                    label = part.name if len(meshes) == 1 and kind == "solid" else \
                        f"{part.name} ({kind} {i})"
                    solid = as_solid(mesh, label, original)
                    group.append(solid if part.transform is None else
                                 solid.transform(part.transform[:3]))
                placed.append(group)
            placed_parts.append(tuple(placed))
            if progress is not None:
                progress(part.name)
        self._solids, self._names = placed_parts, names
        self._operands = self._collect()

    def _collect(self):
        """``(adds, cuts, clips)``: every added solid; every bore and subtracted part; every
        intersected part (hollow ones as their own outer-minus-bore solid)."""
        import manifold3d

        adds, cuts, clips = [], [], []
        for part, (solids, bores) in zip(self._parts.values(), self._solids):
            if part.op == "add":
                adds += solids
                cuts += bores
            else:
                whole = combine(solids, bores) if bores else \
                    manifold3d.Manifold.batch_boolean(solids, manifold3d.OpType.Add)
                (cuts if part.op == "subtract" else clips).append(whole)
        return adds, cuts, clips

    def union(self, progress=None):
        """Combine every part into one watertight :class:`Mesh` (computed once, then cached).

        Each face's part is in ``face_part``/``part_names``. ``progress``, if given,
        is called with a short label after each part is prepared and after the
        boolean. Raises :class:`MeshError` naming a part that is not a closed solid,
        and :class:`GeometryError` when nothing is left.
        """
        if self._union is None:
            if not any(p.op == "add" for p in self._parts.values()):
                raise InputError(f"assembly {self.name!r}: add at least one part before "
                                 "combining it")
            self._prepare(progress)
            solid = combine(*self._operands)
            if is_void(solid, self._operands[0]):
                raise GeometryError(f"assembly {self.name!r}: nothing is left after the "
                                    "subtractions and intersections")
            self._union = Mesh.from_manifold(solid, part_of_id=self._names,
                                             attributes={"kind": "assembly", "name": self.name,
                                                         "units": self.units})
            if progress is not None:
                progress("boolean")
        return self._union

    def mesh(self):
        """The combined solid (the same as :meth:`union`), so an Assembly exports as a mesh."""
        return self.union()

    # -- output ---------------------------------------------------------------
    def _part_mesh(self, part, solids):
        """One added part as it ends up in the assembly, in its own coordinates.

        The bores of every part and the subtracted and intersected solids are
        applied to it (only those whose boxes reach it); other added parts are not
        merged in.
        """
        _, cuts, clips = self._operands
        solid = combine(list(solids), cuts, clips)
        if part.transform is not None:
            solid = solid.transform(np.linalg.inv(part.transform)[:3])
        return Mesh.from_manifold(solid, part_of_id=self._names, attributes=part.attributes)

    def to_scene(self, mode="parts"):
        """A :class:`~cadpipe.io.scene.Scene` for exporters.

        ``mode="parts"``: one scene part per added part, in its own coordinates with
        its transform, colour and attributes, already cut by the assembly's bores,
        subtractions and intersections (but not merged with other parts).
        ``mode="solid"``: one part, the unioned solid, with ``colors`` mapping part
        names to colours for its labelled faces.
        """
        mode = as_choice(mode, "mode", EXPORT_MODES)
        entries = self._parts.values()
        colors = MappingProxyType({p.name: p.color for p in entries if p.color is not None})
        solid = self.union()
        if mode == "solid":
            parts = (ScenePart(self.name, solid, attributes=solid.attributes),)
        else:
            meshes = [(p, self._part_mesh(p, solids))
                      for p, (solids, _) in zip(entries, self._solids) if p.op == "add"]
            parts = tuple(ScenePart(p.name, mesh, p.color, p.transform, p.attributes)
                          for p, mesh in meshes if len(mesh.faces))   # skip parts cut away
        return Scene(name=self.name, parts=parts, units=self.units, colors=colors)

    def export(self, path, mode=None, **options):
        """Write the assembly to ``path``; the format follows the suffix.

        ``mode`` is "solid" (the unioned solid) or "parts" (each part on its own);
        by default "solid" for printing formats (STL, 3MF, OBJ, PLY, OFF) and
        "parts" for scene formats (USD, GLB, ...). Returns the path written.
        """
        from cadpipe.io.files import export, suffix_of

        if mode is None:
            mode = "solid" if suffix_of(path) in SOLID_FORMATS else "parts"
        return export(self.to_scene(mode), path, **options)
