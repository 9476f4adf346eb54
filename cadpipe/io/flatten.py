"""A scene's parts as meshes whose faces carry part labels and colours.

Every exporter needs the same two answers: which faces belong to which named
part, and what colour that part has. A plain part's faces all carry its own
name and colour; a unioned part (``Mesh.face_part``) keeps the names of the
parts its faces came from, coloured through ``Scene.colors``. Formats with a
single mesh (STL, 3MF, OBJ, PLY) take :func:`flatten`, which puts every part
in world coordinates.

Colour rule, the same in every format and mode: a face takes the colour of the
part it came from (``Scene.colors``; a part's own faces its own colour). Faces
cut by a subtracted part are that part's faces, so they show its colour; a part
given no colour is :data:`DEFAULT_COLOR`.
"""

from typing import NamedTuple

import numpy as np

from cadpipe.errors import InputError
from cadpipe.geometry.mesh import Mesh
from cadpipe.core.color import parse_color

#: colour of a part that was given none (a light steel grey)
DEFAULT_COLOR = (0.70, 0.72, 0.75)


class Painted(NamedTuple):
    """A mesh with a label per face, and a name and colour per label."""

    mesh: Mesh
    labels: np.ndarray      #: (F,) int index into names
    names: tuple
    colors: np.ndarray      #: (L, 3) RGB in [0, 1]


def labelled(scene, part, *, world=False, scale=1.0):
    """``part``'s mesh (local, or in world coordinates times ``scale``) as a :class:`Painted`."""
    mesh = part.world_mesh(scale) if world else part.mesh
    if len(mesh.faces) == 0:
        raise InputError(f"part {part.name!r}: it has no triangles to export; "
                         "leave it out of the scene")
    def color_of(name):
        if name == part.name and part.color is not None:
            return parse_color(part.color)
        return parse_color(scene.colors[name]) if name in scene.colors else DEFAULT_COLOR

    if mesh.face_part is None:
        return Painted(mesh, np.zeros(len(mesh.faces), np.int32), (part.name,),
                       np.array([color_of(part.name)]))
    colors = [color_of(n) for n in mesh.part_names]
    return Painted(mesh, mesh.face_part, mesh.part_names, np.array(colors).reshape(-1, 3))


def flatten(scene, scale=1.0):
    """All parts of ``scene`` as one world-coordinate :class:`Painted` mesh, coordinates
    times ``scale`` (:meth:`Scene.scale_to`).

    Labels with the same name in different parts merge; the first part's
    colour for a name wins.
    """
    pieces = [labelled(scene, part, world=True, scale=scale) for part in scene.parts]
    if len(pieces) == 1:
        return pieces[0]
    mesh = Mesh.concatenate([p.mesh.with_parts(p.names, p.labels) for p in pieces])
    colors = np.empty((len(mesh.part_names), 3))
    for piece in reversed(pieces):                 # the first part's colour for a name wins
        colors[[mesh.part_names.index(n) for n in piece.names]] = piece.colors
    return Painted(mesh, mesh.face_part, mesh.part_names, colors)
