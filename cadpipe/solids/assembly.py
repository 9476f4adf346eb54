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

Booleans run only where bounding boxes meet: a part that overlaps nothing (a
single pipe) is never sent through manifold3d, its mesh goes into the result as
it is (a cadpipe-built part as made, an imported mesh once checked to be one
outward shell).
"""

from __future__ import annotations

import inspect
import os
from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property, partial
from types import MappingProxyType
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from cadpipe import limits
from cadpipe._validate import as_choice
from cadpipe.solids.booleans import (as_solid, bounding_boxes, clusters, combine,
                                     combine_cluster, snap)
from cadpipe.errors import CadpipeError, GeometryError, InputError
from cadpipe.geometry.intersect import self_intersections
from cadpipe.geometry.mesh import Mesh, reserve_ids
from cadpipe.geometry.swept import float32_solid
from cadpipe.solids.validity import problems_of
from cadpipe.core import float32, formats
from cadpipe.core.color import parse_color
from cadpipe.core.units import UNITS, meters_per_unit
from cadpipe.solids.scene import LAYOUTS, Scene, ScenePart
from cadpipe.core.transform import as_matrix

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
        Placement of ``obj`` (see :func:`cadpipe.core.transform.placement`).
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


def export_options(path: str | os.PathLike, options: dict[str, Any]) -> dict[str, Any]:
    """``options`` checked for :meth:`Assembly.export` to ``path``, before any work.

    The options are the keyword parameters of the format's writer (``units``,
    ``layout``, ``ascii``, ...; :mod:`cadpipe.core.formats`), read from its signature,
    so a spec's output table reaches every one of them.

    Parameters
    ----------
    path : str or path-like
        The file to write; its suffix names the format.
    options : dict
        Option name to value; a value has the type of the option's default (any
        number for a number), ``units`` and ``layout`` one of their choices.

    Returns
    -------
    options : dict
        A copy of ``options``.

    Raises
    ------
    InputError
        With ``key`` the option at fault.
    """
    suffix = formats.suffix_of(path)
    writer = formats.writer_for(path)
    params = {n: p for n, p in inspect.signature(writer).parameters.items()
              if p.kind is p.KEYWORD_ONLY}
    open_ended = any(p.kind is p.VAR_KEYWORD for p in inspect.signature(writer).parameters.values())
    for name, value in options.items():
        if name not in params:
            if open_ended:
                continue
            raise InputError(f"'.{suffix}' files take no option {name!r}; they take "
                             f"{', '.join(sorted(params))}", key=name)
        default = params[name].default
        if default is None or default is inspect.Parameter.empty:
            continue
        kinds = (int, float) if type(default) in (int, float) else (type(default),)
        if not isinstance(value, kinds) or (isinstance(value, bool) and bool not in kinds):
            raise InputError(f"expected a value like {default!r}, got {value!r}", key=name)
    if "units" in options:
        as_choice(options["units"], "units", tuple(UNITS))
    if "layout" in options:
        as_choice(options["layout"], "layout", LAYOUTS)
    return dict(options)


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


@dataclass(frozen=True, eq=False)
class _Shape:
    """One closed mesh of a part, placed in the world, with the manifold3d id its
    triangles carry. ``plain``: known to be one outward shell, so it needs
    manifold3d only where it meets another solid."""

    part: str
    label: str
    local: Mesh
    world: Mesh
    original: int
    plain: bool

    @cached_property
    def box(self):
        return self.world.bounds

    @cached_property
    def solid(self):
        return as_solid(self.world, self.label, self.original)


def _is_plain(obj, mesh):
    """Whether ``mesh`` of part object ``obj`` can skip manifold3d when it meets nothing:
    a cadpipe part made it (a pipe is a closed outward solid by construction), or it
    is one closed, consistently wound, outward shell."""
    if not isinstance(obj, Mesh) and type(obj).__module__.startswith("cadpipe."):
        return True
    return mesh.is_oriented and mesh.volume > 0 and mesh.n_bodies == 1


def _finest(obj):
    """The finest feature a part object is made of, in its own units, or None where it
    has none of its own: a pipe's ring edge, a hollow part's wall too."""
    pipes = getattr(obj, "pipes", None)
    if pipes is not None:                              # a junction or a hollow chain
        found = [f for f in map(_finest, pipes) if f is not None]
        wall = getattr(obj, "wall", None)
        return min(found + ([wall] if wall else [])) if found else None
    inner = getattr(obj, "pipe", None)
    if inner is not None:                              # a hollow pipe
        return min(_finest(inner), obj.wall)
    if hasattr(obj, "ring_radii") and hasattr(obj, "sides"):
        return 2 * float(obj.ring_radii.min()) * np.sin(np.pi / obj.sides)
    return None


def _refuse_invalid(solid, name):
    """:class:`GeometryError` when the boolean result ``solid`` of assembly ``name`` fails
    the test :func:`~cadpipe.solids.validity.check_mesh` holds solids to, naming the parts
    whose faces are at fault: no invalid solid is ever returned or written. Parts that
    skip the booleans (their boxes reach no other) are valid as prepared and cannot cross
    or hold what lies outside their boxes, so only the boolean result is checked."""
    crossing = self_intersections(solid)
    problems = problems_of(solid, crossing=len(crossing))
    if not problems:
        return
    parts = ()
    if len(crossing) and solid.face_part is not None:
        parts = tuple(dict.fromkeys(solid.part_names[k] for k in
                                    solid.face_part[crossing.ravel()].tolist()))
    where = f" where {' and '.join(map(repr, parts[:3]))} meet" if parts else ""
    raise GeometryError(f"assembly {name!r}: the union is no valid solid{where} "
                        f"({problems[0]}); move those parts apart or make them overlap more, "
                        "or report the assembly", part=parts[0] if parts else None)


def _batch_progress(progress, stage, before, size, total, done, calls):
    """A group's batches as solids united so far of ``total``; then the joins of the
    batches, level by level, as their own stage (joins done of all)."""
    batches = (calls + 1) // 2
    if done <= batches:
        progress(stage, before + size * done // batches, total)
    else:
        progress(f"{stage}: joining {batches} batches", done - batches, batches - 1)


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
        """Validate and place every part's solids and bores, once; manifold3d objects are
        made only for what a boolean needs (and to check what is not plain)."""
        if self._solids is not None:
            return
        limits.check("max_triangles", sum(limits.estimated_triangles(p.obj)
                                          for p in self._parts.values()),
                     f"assembly {self.name!r}")
        placed_parts, names = [], {}
        count = len(self._parts)
        for k, part in enumerate(self._parts.values()):
            if progress is not None:
                progress(f"meshing {part.name}", k, count)
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
                    world = mesh if part.transform is None else mesh.transformed(part.transform)
                    shape = _Shape(part.name, label, mesh, world, original,
                                   _is_plain(part.obj, mesh))
                    if not shape.plain:
                        _ = shape.solid           # checked now: the error names the part
                    group.append(shape)
                placed.append(group)
            placed_parts.append(tuple(placed))
        if progress is not None:
            progress("meshing done", count, count)
        self._refuse_too_fine(placed_parts)
        self._solids, self._names = placed_parts, names
        self._operands = self._collect()

    def _refuse_too_fine(self, placed_parts):
        """:class:`GeometryError` at the first part whose finest feature is below what
        float32 files resolve at the assembly's largest coordinate (the steps every
        union is repaired in, :data:`~cadpipe.core.float32.COLLAPSE` of them): its
        rings would come back as slivers. Before any boolean."""
        boxes = [s.box for solids, bores in placed_parts for s in (*solids, *bores)]
        if not boxes:
            return
        step = float32.step(np.array(boxes), float32.COLLAPSE)
        for part, (solids, _) in zip(self._parts.values(), placed_parts):
            feature = _finest(part.obj)
            if feature is not None and part.transform is not None:   # its least stretch
                feature *= float(np.linalg.svd(part.transform[:3, :3], compute_uv=False).min())
            thinnest = min(float(np.ptp(s.box, axis=0).min()) for s in solids) \
                if solids else None                   # any part: its box's least extent
            found = [f for f in (feature, thinnest) if f is not None]
            if not found:
                continue
            feature = min(found)
            if feature < step:
                raise GeometryError(
                    f"its finest features ({feature:.3g} {self.units}) are finer than float32 "
                    f"files can hold where this assembly reaches ({step:.3g} {self.units} "
                    "there); make the part larger, or build it in an assembly nearer the "
                    "origin", part=part.name)

    def _collect(self):
        """``(adds, cuts, clips)``: every added shape and every bore and subtracted part
        (shapes); every intersected part (hollow ones as their own outer-minus-bore
        solid, a manifold3d object)."""
        adds, cuts, clips = [], [], []
        for part, (solids, bores) in zip(self._parts.values(), self._solids):
            if part.op == "add":
                adds += solids
                cuts += bores
            elif part.op == "subtract" and not bores:
                cuts += solids
            else:
                whole = combine([s.solid for s in solids], [b.solid for b in bores])
                (cuts if part.op == "subtract" else clips).append(whole)
        return adds, cuts, clips

    def _combined(self, adds, progress=None):
        """``[(shape or None, mesh), ...]``: the pieces of ``(union of adds - every cut) &
        every clip``. A shape no other solid's box reaches is its own world mesh,
        untouched (shape given); the rest is one boolean result (shape None)."""
        _, cuts, clips = self._operands
        cut_boxes = np.array([c.box if isinstance(c, _Shape) else
                              np.reshape(c.bounding_box(), (2, 3)) for c in cuts],
                             np.float64).reshape(-1, 2, 3)
        work = clusters(np.array([a.box for a in adds]).reshape(-1, 2, 3), cut_boxes,
                        bounding_boxes(clips))
        pieces, booleans = [], []
        for index, reach in work:
            shape = adds[index[0]]
            if len(index) == 1 and not len(reach) and not clips and shape.plain:
                pieces.append((shape, shape.world))
            else:
                booleans.append((index, reach))
        solids, so_far = [], 0
        members, groups = sum(len(i) for i, _ in booleans), len(booleans)
        stage = f"union of {members} solids in {groups} group{'s' * (groups != 1)}"
        for index, reach in booleans:
            batches = None
            if progress is not None:
                progress(stage, so_far, members)
                batches = partial(_batch_progress, progress, stage, so_far, len(index), members)
            solid = combine_cluster(
                [adds[i].solid for i in index],
                [c.solid if isinstance(c, _Shape) else c for c in (cuts[j] for j in reach)],
                clips, batches)
            solid.num_tri()                       # manifold3d is lazy: work now, counted
            solids.append(solid)
            so_far += len(index)
        if solids:
            import manifold3d

            solid = solids[0] if len(solids) == 1 else \
                manifold3d.Manifold.batch_boolean(solids, manifold3d.OpType.Add)
            reference = sum(adds[i].world.volume for index, _ in booleans for i in index)
            if not solid.is_empty() and solid.volume() > 1e-9 * reference:
                pieces.append((None, float32_solid(solid, part_of_id=self._names)))
        return pieces

    def _labelled(self, pieces, attributes):
        """One :class:`Mesh` of ``pieces``, faces labelled with part names in part order."""
        meshes = [m if shape is None else
                  Mesh.trusted(m.vertices, m.faces, face_part=np.zeros(len(m.faces), np.int32),
                               part_names=(shape.part,))
                  for shape, m in pieces]
        mesh = meshes[0] if len(meshes) == 1 else Mesh.concatenate(meshes)
        order = [p for p in self._parts if p in mesh.part_names]
        rank = np.array([order.index(n) for n in mesh.part_names], np.int32)
        # in order already (one part): the labels as they are, not a relabelled copy of F
        labels = mesh.face_part if np.array_equal(rank, np.arange(len(rank))) else \
            rank[mesh.face_part]
        return Mesh.trusted(mesh.vertices, mesh.faces, face_part=labels,
                            part_names=order, attributes=attributes)

    def union(self, progress: Callable[[str, int, int], object] | None = None) -> Mesh:
        """Combine every part into one watertight :class:`Mesh` (computed once, then cached).

        Parameters
        ----------
        progress : callable, optional
            ``progress(stage, done, total)`` as each stage starts and as it moves:
            ``"meshing <part>"`` (parts done so far of all), ``"meshing done"``,
            ``"union of <n> solids in <k> groups"`` (solids united so far of ``n``,
            in groups of overlapping boxes; none when no boxes overlap: a group of
            many is united in batches, so this moves within one group) and
            ``"union of ... : joining <b> batches"`` (joins done so far of
            ``b - 1``: the batches are joined in pairs, level by level), so a display
            can name the stage running.

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
            pieces = self._combined(self._operands[0], progress)
            if not pieces:
                raise GeometryError(f"assembly {self.name!r}: nothing is left after the "
                                    "subtractions and intersections")
            for shape, mesh in pieces:     # a part no other box reaches is valid as it was
                if shape is None:
                    _refuse_invalid(mesh, self.name)
            self._union = self._labelled(pieces, {"kind": "assembly", "name": self.name,
                                                  "units": self.units})
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
        pieces = self._combined(list(solids))
        if not pieces:
            return Mesh(np.empty((0, 3)), np.empty((0, 3), np.int64))
        if all(shape is not None for shape, _ in pieces):     # untouched: as it was made
            pieces = [(shape, shape.local) for shape, _ in pieces]
            return self._labelled(pieces, part.attributes)
        mesh = self._labelled(pieces, part.attributes)
        return mesh if part.transform is None else \
            mesh.transformed(np.linalg.inv(part.transform))

    def to_scene(self, mode: str = "parts") -> Scene:
        """A :class:`~cadpipe.solids.scene.Scene` for exporters.

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
            The format's options (``layout``, ``units``, ...; see
            :func:`export_options`).

        Returns
        -------
        path : pathlib.Path
            The file written.
        """
        if mode is None:
            mode = "solid" if formats.suffix_of(path) in SOLID_FORMATS else "parts"
        return formats.export(self.to_scene(mode), path, **options)
