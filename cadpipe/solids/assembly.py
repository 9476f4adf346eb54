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

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from cadpipe import limits
from cadpipe._validate import as_choice
from cadpipe.solids.booleans import as_solid, combine, is_void, reserve_ids, snap
from cadpipe.errors import CadpipeError, GeometryError, InputError
from cadpipe.geometry.mesh import Mesh
from cadpipe.io.scene import Scene, ScenePart, meters_per_unit, parse_color
from cadpipe.solids.transform import as_matrix

OPERATIONS = ("add", "subtract", "intersect")

#: the numpy sections of :meth:`Assembly.add`, ``subtract`` and ``intersect``
_PART_ARGUMENTS = """
    Parameters
    ----------
    name : str
        The part's name, unique in the assembly; output faces keep it.
    obj : Mesh, Pipe, HollowPipe, HollowChain or Junction
        A closed solid (a primitive, a loaded file) or a part that makes one.
    transform : (4, 4) array_like, optional
        Placement of ``obj`` (see :func:`cadpipe.solids.transform.placement`).
    color : str or (3,) float, optional
        ``"#rrggbb"`` or three numbers in [0, 1].

    Returns
    -------
    assembly : Assembly
        ``self``, so calls chain.
"""

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

    def __init__(self, units: str = "m", name: str = "assembly"):
        meters_per_unit(units)
        if not isinstance(name, str) or not name:
            raise InputError(f"expected a non-empty string, got {name!r}", key="name")
        self.units = units
        self.name = name
        self._parts = {}         # name -> Part, in the order given
        self._solids = None      # per part: (solids, bores) as manifold3d objects, world frame
        self._operands = None    # (adds, cuts, clips) gathered from _solids
        self._union = None

    def __repr__(self):
        return f"<cadpipe.Assembly {self.name!r}, {len(self._parts)} parts, units {self.units}>"

    @property
    def parts(self) -> tuple[Part, ...]:
        """The parts in the order they were given."""
        return tuple(self._parts.values())

    # -- building -------------------------------------------------------------
    def add(self, name: str, obj: Any, transform: ArrayLike | None = None,
            color: str | ArrayLike | None = None) -> Assembly:
        """Add a solid to the union."""
        return self._put(name, obj, "add", transform, color)

    def subtract(self, name: str, obj: Any, transform: ArrayLike | None = None,
                 color: str | ArrayLike | None = None) -> Assembly:
        """Remove ``obj`` from the added solids; its cut faces keep ``name`` and ``color``."""
        return self._put(name, obj, "subtract", transform, color)

    def intersect(self, name: str, obj: Any, transform: ArrayLike | None = None,
                  color: str | ArrayLike | None = None) -> Assembly:
        """Keep only what lies inside ``obj``."""
        return self._put(name, obj, "intersect", transform, color)

    for _method in (add, subtract, intersect):       # one argument list for the three
        _method.__doc__ += "\n" + _PART_ARGUMENTS
    del _method

    def _put(self, name, obj, op, transform, color):
        if not isinstance(name, str) or not name:
            raise InputError(f"expected a non-empty string, got {name!r}", key="name")
        if name in self._parts:
            raise InputError(f"a part named {name!r} is already in the assembly; "
                             "part names must be unique", key="name")
        if not (isinstance(obj, Mesh) or callable(getattr(obj, "mesh", None))
                or callable(getattr(obj, "solids", None))):
            raise InputError("expected a Mesh, Pipe, HollowPipe or Junction, "
                             f"got {type(obj).__name__}", part=name)
        matrix = None
        if transform is not None:
            matrix = as_matrix(transform, "transform", part=name)
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
        limits.check("max_triangles", sum(limits.estimated_triangles(p.obj)
                                          for p in self._parts.values()),
                     f"assembly {self.name!r}")
        for part in self._parts.values():
            try:
                shapes = part.shapes()
            except CadpipeError as exc:       # e.g. a pipe that intersects itself
                raise exc.at(part=part.name) from exc.__cause__
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

    def union(self, progress: Callable[[str], object] | None = None) -> Mesh:
        """Combine every part into one watertight :class:`Mesh` (computed once, then cached).

        Parameters
        ----------
        progress : callable, optional
            Called with a short label after each part is prepared and after the boolean.

        Returns
        -------
        mesh : Mesh
            The solid; each face's part is in ``face_part``/``part_names``.

        Raises
        ------
        MeshError
            Naming a part that is not a closed solid.
        GeometryError
            When nothing is left.
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

    def mesh(self) -> Mesh:
        """The combined solid (the same as :meth:`union`), so an Assembly exports as a mesh.

        Returns
        -------
        mesh : Mesh
        """
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

    def to_scene(self, mode: str = "parts") -> Scene:
        """A :class:`~cadpipe.io.scene.Scene` for exporters.

        ``mode="parts"``: one scene part per added part, in its own coordinates with
        its transform, colour and attributes, already cut by the assembly's bores,
        subtractions and intersections (but not merged with other parts).
        ``mode="solid"``: one part, the unioned solid, with ``colors`` mapping part
        names to colours for its labelled faces.

        Parameters
        ----------
        mode : {"parts", "solid"}

        Returns
        -------
        scene : Scene
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

    def export(self, path: str | os.PathLike, mode: str | None = None,
               **options: Any) -> Any:
        """Write the assembly to ``path``; the format follows the suffix.

        Parameters
        ----------
        path : str or path-like
        mode : {"solid", "parts"}, optional
            The unioned solid, or each part on its own; by default "solid" for
            printing formats (STL, 3MF, OBJ, PLY, OFF) and "parts" for scene formats
            (USD, GLB, ...).
        **options
            Format options (see :mod:`cadpipe.io.files`).

        Returns
        -------
        path : pathlib.Path
            The file written.
        """
        from cadpipe.io.files import export, suffix_of

        if mode is None:
            mode = "solid" if suffix_of(path) in SOLID_FORMATS else "parts"
        return export(self.to_scene(mode), path, **options)
