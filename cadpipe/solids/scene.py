"""What files hold: named, coloured parts with their transforms and units.

An :class:`~cadpipe.Assembly` turns itself into a :class:`Scene` (``to_scene()``);
a lone Mesh or Pipe becomes a one-part scene. Every writer takes a Scene and every
reader returns one, so each format sees and gives back the same parts, names,
colours and units.
"""

import unicodedata
from dataclasses import dataclass, field, replace
from types import MappingProxyType

import numpy as np

from cadpipe.core.units import meters_per_unit
from cadpipe.errors import InputError

#: longest part or scene name a writer puts in a file (XML attributes, prim names, nodes)
MAX_NAME = 128

#: scene up axis -> rotation of its coordinates onto +Y up (glTF, USDZ for AR)
TO_Y_UP = MappingProxyType({"Z": np.array([[1.0, 0, 0], [0, 0, 1], [0, -1, 0]]),
                            "Y": np.eye(3)})


def safe_name(name):
    """``name`` as every writer can store and read back: control characters (NUL,
    newline, bell, ...) become ``_``, and it is cut to :data:`MAX_NAME` characters.

    XML 1.0 cannot hold most control characters at all, USD cuts prim names at
    NUL, and one error message must stay one line.
    """
    return printable(name)[:MAX_NAME] or "part"


def unique_name(name, taken):
    """``name``, or ``name_1``, ``name_2``, ... if already in ``taken``; adds the result."""
    candidate, n = str(name), 1
    while candidate in taken:
        candidate, n = f"{name}_{n}", n + 1
    taken.add(candidate)
    return candidate


def printable(text):
    """``text`` with every control character (and lone surrogate) replaced by ``_``."""
    return "".join("_" if unicodedata.category(c) in ("Cc", "Cs") else c for c in str(text))


def _scaled(mesh, scale):
    from cadpipe.geometry.mesh import Mesh

    return Mesh.trusted(mesh.vertices * scale, mesh.faces, face_part=mesh.face_part,
                        part_names=mesh.part_names, attributes=mesh.attributes)


def _renamed(mesh):
    from cadpipe.geometry.mesh import Mesh

    names = tuple(map(safe_name, mesh.part_names))
    if names == mesh.part_names:
        return mesh
    return Mesh.trusted(mesh.vertices, mesh.faces, face_part=mesh.face_part, part_names=names,
                        attributes=mesh.attributes)


@dataclass(frozen=True)
class ScenePart:
    """One named part: its mesh in local coordinates and where it sits."""

    name: str
    mesh: object
    color: tuple = None
    transform: np.ndarray = None
    attributes: MappingProxyType = field(default_factory=lambda: MappingProxyType({}))

    def world_mesh(self, scale=1.0):
        """The mesh placed by its transform, coordinates times ``scale`` (one copy at most)."""
        if self.transform is None and scale == 1.0:
            return self.mesh
        matrix = np.eye(4) if self.transform is None else np.array(self.transform, float)
        matrix[:3] *= scale
        return self.mesh.transformed(matrix)


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

    def scale_to(self, units):
        """Factor from this scene's coordinates to ``units`` (``None``: its own, 1.0)."""
        return 1.0 if units is None else self.meters_per_unit / meters_per_unit(units)

    def in_units(self, units):
        """This scene with every coordinate in ``units`` (a key of :data:`UNITS`).

        ``None`` keeps the scene's own units. Part meshes are scaled and the
        translations of their transforms with them, so each part keeps its own
        frame (a USD Xform or glTF node carries no scale).
        """
        scale = self.scale_to(units)
        if scale == 1.0:
            return replace(self, units=units or self.units)
        parts = []
        for part in self.parts:
            transform = part.transform
            if transform is not None:
                transform = np.array(transform, dtype=np.float64)
                transform[:3, 3] *= scale
            parts.append(replace(part, mesh=_scaled(part.mesh, scale), transform=transform))
        return replace(self, parts=tuple(parts), units=units)

    def as_mesh(self):
        """The scene as one :class:`~cadpipe.Mesh` in world coordinates.

        A scene of several parts gives a mesh whose faces are labelled with their
        part's name (``face_part``); a single part keeps its own labels (a GLB's
        materials, a USD mesh's subsets). ``attributes`` are the first part's.
        """
        from cadpipe.geometry.mesh import Mesh

        if len(self.parts) == 1:
            return self.parts[0].world_mesh()
        meshes = [part.world_mesh().with_parts((part.name,)) for part in self.parts]
        joined = Mesh.concatenate(meshes)
        return Mesh(joined.vertices, joined.faces, face_part=joined.face_part,
                    part_names=joined.part_names, attributes=self.parts[0].mesh.attributes)

    def welded(self):
        """This scene with every part's duplicate vertices made one
        (:meth:`~cadpipe.Mesh.welded`): what a file read becomes."""
        return replace(self, parts=tuple(replace(p, mesh=p.mesh.welded()) for p in self.parts))

    def safe_names(self):
        """This scene with every name through :func:`safe_name` (itself if all are safe)."""
        names = [self.name, *self.colors, *(n for p in self.parts
                                             for n in (p.name, *p.mesh.part_names))]
        if all(safe_name(n) == n for n in names):
            return self
        parts = tuple(replace(p, name=safe_name(p.name), mesh=_renamed(p.mesh))
                      for p in self.parts)
        colors = MappingProxyType({safe_name(k): v for k, v in self.colors.items()})
        return replace(self, name=safe_name(self.name), parts=parts, colors=colors)


#: how a writer lays the scene out (``layout=``): as it stands, or on a build plate
LAYOUTS = ("scene", "print")


def as_scene(obj, name="cadpipe", layout="scene"):
    """A :class:`Scene` from a Scene, anything with ``to_scene()``, a Mesh or a Pipe,
    its names made safe to write (:func:`safe_name`).

    Parameters
    ----------
    obj : Scene, Assembly, Mesh or Pipe
    name : str
        The scene's name when ``obj`` is a lone mesh.
    layout : {"scene", "print"}
        "scene" keeps the parts where they are; "print" lays every separate body on a
        build plate (:func:`laid_out_for_print`: on z = 0, side by side).
    """
    if layout not in LAYOUTS:
        raise InputError(f"expected one of {', '.join(LAYOUTS)}, got {layout!r}",
                         key="layout")
    scene = _as_scene(obj, name)
    return laid_out_for_print(scene) if layout == "print" else scene


def _as_scene(obj, name):
    from cadpipe.geometry.mesh import Mesh

    if isinstance(obj, Scene):
        return obj.safe_names()
    if callable(getattr(obj, "to_scene", None)):
        return obj.to_scene().safe_names()
    mesh = obj if isinstance(obj, Mesh) else getattr(obj, "mesh", None)
    if callable(mesh):
        mesh = mesh()
    if not isinstance(mesh, Mesh):
        raise InputError(f"cannot export a {type(obj).__name__}; expected a Mesh, Pipe, "
                         "Assembly or Scene")
    part = mesh.attributes.get("kind", "mesh")
    return Scene(name=name, parts=(ScenePart(part, mesh, attributes=mesh.attributes),),
                 units=mesh.attributes.get("units", "m")).safe_names()


#: space left between bodies laid out for printing, in metres
PRINT_GAP = 0.005


def laid_out_for_print(scene, gap=PRINT_GAP):
    """``scene`` as a build plate: each separate body a part of its own, standing on
    z = 0 and set beside the previous one along +X, ``gap`` metres apart.

    Bodies whose boxes overlap (a shell inside another, parts hooked together)
    stay together as they were. A body is named after the part most of its
    faces came from (made unique). Rotations are left alone: each body prints
    the way it stood in the scene.

    Returns
    -------
    Scene
        Untransformed parts in the scene's units and axes (Z up).
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    from cadpipe.geometry.mesh import Mesh

    if str(scene.up_axis).upper() != "Z":
        raise InputError("layout: a print layout needs a Z-up scene (the bed is z = 0)")
    step = gap / scene.meters_per_unit
    parts, taken, cursor = [], set(), 0.0
    for part in scene.parts:
        mesh = part.world_mesh()
        if len(mesh.faces) == 0:
            continue
        face_body = np.unique(mesh.body_labels[mesh.faces[:, 0]], return_inverse=True)[1]
        face_body = face_body.ravel()
        count = int(face_body.max()) + 1
        corners = mesh.triangles
        lo = np.full((count, 3), np.inf)
        hi = np.full((count, 3), -np.inf)
        np.minimum.at(lo, face_body, corners.min(axis=1))
        np.maximum.at(hi, face_body, corners.max(axis=1))
        touching = ((lo[:, None] <= hi[None]) & (lo[None] <= hi[:, None])).all(axis=2)
        _, group_of = connected_components(coo_matrix(touching), directed=False)
        face_group = group_of[face_body]
        for group in range(int(face_group.max()) + 1):
            picked = face_group == group
            used, faces = np.unique(mesh.faces[picked], return_inverse=True)
            vertices = mesh.vertices[used]
            low = vertices.min(axis=0)
            vertices = vertices - [low[0] - cursor, low[1], low[2]]
            cursor += float(np.ptp(vertices[:, 0])) + step
            labels = None if mesh.face_part is None else mesh.face_part[picked]
            body = Mesh.trusted(vertices, faces.reshape(-1, 3), face_part=labels,
                                part_names=mesh.part_names, attributes=part.attributes)
            name = part.name if labels is None else \
                mesh.part_names[int(np.bincount(labels).argmax())]
            color = scene.colors.get(name, part.color)
            parts.append(ScenePart(unique_name(name, taken), body, color, None,
                                   part.attributes))
    return replace(scene, parts=tuple(parts))
