"""A scene's parts as labelled meshes with one colour per label.

Every exporter needs the same two answers: which faces belong to which named
part, and what colour that part has. A plain part's faces all carry its own
name and colour; a unioned part (``Mesh.face_part``) keeps the names of the
parts its faces came from, coloured through ``Scene.colors``. Formats with a
single mesh (STL, 3MF, OBJ, PLY) take :func:`flatten`, which puts every part
in world coordinates.
"""

import numpy as np

from ..errors import InputError
from ..mesh import Mesh
from ..scene import parse_color

#: colour of a part that was given none (a light steel grey)
DEFAULT_COLOR = (0.70, 0.72, 0.75)


def labelled(scene, part, *, world=False):
    """``part``'s mesh (local, or in world coordinates) with part labels, and their colours.

    Returns
    -------
    mesh : Mesh
        ``face_part`` always set: all zeros for a plain part, the boolean's
        labels for a unioned one.
    colors : (L, 3) float array
        RGB in [0, 1] for each of ``mesh.part_names``.
    """
    mesh = part.world_mesh() if world else part.mesh
    if len(mesh.faces) == 0:
        raise InputError(f"part {part.name!r}: it has no triangles to export; "
                         "leave it out of the scene")
    own = parse_color(part.color) if part.color is not None else DEFAULT_COLOR
    if mesh.face_part is None:
        return mesh.with_parts([part.name]), np.array([own])
    colors = [parse_color(scene.colors[n]) if n in scene.colors else own
              for n in mesh.part_names]
    return mesh, np.array(colors, dtype=np.float64).reshape(-1, 3)


def flatten(scene):
    """All parts of ``scene`` as one world-coordinate mesh, labelled, with label colours.

    Labels with the same name in different parts merge (as in
    :meth:`Mesh.concatenate`); the first part's colour for a name wins.
    """
    pieces = [labelled(scene, part, world=True) for part in scene.parts]
    if len(pieces) == 1:
        return pieces[0]
    mesh = Mesh.concatenate([m for m, _ in pieces])
    color_of = {}
    for m, colors in pieces:
        for name, rgb in zip(m.part_names, colors):
            color_of.setdefault(name, rgb)
    return mesh, np.array([color_of[n] for n in mesh.part_names])
