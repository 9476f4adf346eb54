"""OBJ and PLY, the mesh files trimesh, Blender and MeshLab exchange, written from numpy.

Both hold world coordinates in metres by default (Blender and MeshLab read
them as metres; ``units`` chooses otherwise) and no normals: Blender, MeshLab
and trimesh compute shading normals themselves.

- **OBJ**: ``o <part>`` per part (Blender makes one object of each) and
  ``g <label>`` per source part of a union; geometry only (colour in OBJ needs
  a side-car .mtl file, which would break the one-file, atomic write).
- **PLY**: binary (or ASCII) with colours per vertex, which Blender and
  MeshLab show, and per face, which keeps a union's labels exact (MeshLab and
  trimesh read them). Vertices where two colours meet are written once per
  colour. PLY has no names.

Numbers are float32 with 9 significant digits written as an integer mantissa
and exponent (:func:`cadpipe.io.text.float32_decimal`).
"""

from functools import partial
from pathlib import Path as FilePath

import numpy as np

from cadpipe.errors import MeshError
from cadpipe.io.files import atomic_path, file_mesh, unique_name
from cadpipe.io.flatten import flatten, labelled
from cadpipe.io.scene import as_scene
from cadpipe.io.text import ascii_rows, float32_columns

_OBJ_VERTEX = (b"v ", 0, b"e", 1, b" ", 2, b"e", 3, b" ", 4, b"e", 5, b"\n")
_OBJ_FACE = (b"f ", 0, b" ", 1, b" ", 2, b"\n")
_PLY_VERTEX = (0, b"e", 1, b" ", 2, b"e", 3, b" ", 4, b"e", 5, b" ", 6, b" ", 7, b" ", 8, b"\n")
_PLY_FACE = (b"3 ", 0, b" ", 1, b" ", 2, b" ", 3, b" ", 4, b" ", 5, b"\n")
#: rows formatted or packed per block (bounds the memory of a write)
_BLOCK = 1 << 16


def write_obj(obj, path, *, units="m"):
    """Write ``obj`` as Wavefront OBJ (geometry, parts as ``o``/``g``), atomically.

    Parameters
    ----------
    units : str
        Length unit of the coordinates (metres, as Blender reads OBJ).
    """
    scene = as_scene(obj)
    scale = scene.scale_to(units)
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        fh.write(f"# cadpipe: {scene.name} (units: {units})\n".encode())
        offset = 1
        for part in scene.parts:
            painted = labelled(scene, part, world=True, scale=scale)
            mesh = painted.mesh
            fh.write(f"o {_obj_name(part.name)}\n".encode())
            _write_rows(fh, _OBJ_VERTEX, mesh.vertices, float32_columns)
            if len(painted.names) == 1:
                _write_rows(fh, _OBJ_FACE, mesh.faces, partial(np.add, offset))
            else:        # a group per label: its faces gathered a block at a time
                order = np.argsort(painted.labels, kind="stable")
                starts = np.searchsorted(painted.labels[order],
                                         np.arange(len(painted.names) + 1))
                for label, name in enumerate(painted.names):
                    if starts[label] == starts[label + 1]:
                        continue
                    fh.write(f"g {_obj_name(name)}\n".encode())
                    _write_rows(fh, _OBJ_FACE, order[starts[label]:starts[label + 1]],
                                partial(_faces_from, mesh.faces, offset))
            offset += len(mesh.vertices)


def write_ply(obj, path, *, ascii=False, units="m"):
    """Write ``obj`` as PLY with vertex and face colours (binary unless ``ascii``), atomically.

    Parameters
    ----------
    ascii : bool
        Write the text form instead of binary little-endian.
    units : str
        Length unit of the coordinates (metres, as Blender and MeshLab read PLY).
    """
    scene = as_scene(obj)
    painted = flatten(scene, scene.scale_to(units))
    vertices, faces = painted.mesh.vertices, painted.mesh.faces
    rgb = np.round(painted.colors * 255).astype(np.uint8)
    if len(painted.names) > 1:     # a vertex where colours meet: one copy per colour
        key = faces * len(rgb) + painted.labels[:, None]
        unique, faces = np.unique(key, return_inverse=True)
        faces = faces.reshape(-1, 3)
        vertex_of, vertex_label = np.divmod(unique, len(rgb))
        vertices = vertices[vertex_of]
    else:
        vertex_label = np.zeros(len(vertices), np.int64)
    header = ("ply\nformat {} 1.0\ncomment cadpipe: {} (units: {})\n"
              "element vertex {}\nproperty float x\nproperty float y\nproperty float z\n"
              "property uchar red\nproperty uchar green\nproperty uchar blue\n"
              "element face {}\nproperty list uchar int vertex_indices\n"
              "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n")
    header = header.format("ascii" if ascii else "binary_little_endian",
                           scene.name.replace("\n", " "), units, len(vertices), len(faces))
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        fh.write(header.encode())
        if ascii:
            _write_rows(fh, _PLY_VERTEX, np.column_stack([vertices, vertex_label]),
                        lambda rows: np.column_stack([float32_columns(rows[:, :3]),
                                                      rgb[rows[:, 3].astype(np.int64)]]))
            _write_rows(fh, _PLY_FACE, np.column_stack([faces, rgb[painted.labels]]))
            return
        vertex_row = np.dtype([("p", "<f4", 3), ("c", "u1", 3)])
        face_row = np.dtype([("n", "u1"), ("i", "<i4", 3), ("c", "u1", 3)])
        for start in range(0, len(vertices), _BLOCK):
            block = np.empty(len(vertices[start:start + _BLOCK]), vertex_row)
            block["p"] = vertices[start:start + _BLOCK]
            block["c"] = rgb[vertex_label[start:start + _BLOCK]]
            fh.write(block.tobytes())
        for start in range(0, len(faces), _BLOCK):
            block = np.empty(len(faces[start:start + _BLOCK]), face_row)
            block["n"] = 3
            block["i"] = faces[start:start + _BLOCK]
            block["c"] = rgb[painted.labels[start:start + _BLOCK]]
            fh.write(block.tobytes())


def _faces_from(faces, offset, rows):
    """Rows ``rows`` of ``faces``, numbered from ``offset`` (OBJ counts from 1 across parts)."""
    return faces[rows] + offset


def _write_rows(fh, template, table, prepare=None):
    """``table`` as text rows (:func:`ascii_rows`), a block at a time through ``prepare``."""
    for start in range(0, len(table), _BLOCK):
        block = table[start:start + _BLOCK]
        fh.write(ascii_rows(template, block if prepare is None else prepare(block)))


def _obj_name(name):
    """OBJ names end at white space: keep the name one word."""
    return "_".join(str(name).split()) or "part"


def read_obj(path):
    """An OBJ file as a :class:`~cadpipe.io.scene.Scene`: one part per ``o``, its faces
    labelled by ``g``; polygons fanned into triangles, exact duplicate vertices kept
    as written. In metres unless the header says otherwise (cadpipe writes
    ``# cadpipe: NAME (units: U)``)."""
    from cadpipe.io.scene import UNITS, Scene, ScenePart

    text = FilePath(path).read_text(encoding="utf-8", errors="replace")
    units = "m"
    vertices, objects = [], []        # objects: [name, [(group, [polygon, ...])]]
    for line in text.splitlines():
        word, _, rest = line.strip().partition(" ")
        if word == "v":
            vertices.append(rest.split()[:3])
        elif word == "f":
            if not objects:
                objects.append([FilePath(path).stem, []])
            if not objects[-1][1]:
                objects[-1][1].append([objects[-1][0], []])
            corners = [int(c.split("/")[0]) for c in rest.split()]
            objects[-1][1][-1][1].append([c - 1 if c > 0 else len(vertices) + c
                                          for c in corners])
        elif word == "o":
            objects.append([rest.strip() or "object", []])
        elif word == "g":
            if not objects:
                objects.append([FilePath(path).stem, []])
            objects[-1][1].append([rest.strip() or objects[-1][0], []])
        elif word == "#" and rest.startswith("cadpipe:") and "(units: " in rest:
            units = rest.rsplit("(units: ", 1)[1].rstrip(")").strip()
    try:
        points = np.array(vertices, dtype=np.float64).reshape(-1, 3)
    except ValueError:
        raise MeshError("a vertex line is not three numbers", file=path) from None
    units = units if units in UNITS else "m"
    parts, taken = [], set()
    for name, groups in objects:
        triangles, labels, names = [], [], []
        for group, polygons in groups:
            fanned = [(p[0], p[k], p[k + 1]) for p in polygons for k in range(1, len(p) - 1)]
            if not fanned:
                continue
            if group not in names:
                names.append(group)
            triangles += fanned
            labels += [names.index(group)] * len(fanned)
        if not triangles:
            continue
        faces = np.array(triangles, dtype=np.int64)
        used, faces = np.unique(faces, return_inverse=True)
        if used.min() < 0 or used.max() >= len(points):
            raise MeshError(f"object {name!r}: a face points past the vertices", file=path)
        mesh = file_mesh(points[used], faces.reshape(-1, 3), path, name, face_part=labels,
                         part_names=names, attributes={
                             "source": str(path), "units": units,
                             "units_assumed": "(units: " not in text[:200]})
        parts.append(ScenePart(unique_name(name, taken), mesh))
    if not parts:
        raise MeshError("the file holds no triangles", file=path)
    return Scene(name=FilePath(path).stem, parts=tuple(parts), units=units)
