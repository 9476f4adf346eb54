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

import re
import warnings
from functools import partial
from pathlib import Path as FilePath

import numpy as np

from cadpipe.core.kernels import native
from cadpipe.errors import ExportError, MeshError
from cadpipe.core import formats
from cadpipe.core.units import UNITS
from cadpipe.io.files import atomic_path, file_mesh
from cadpipe.io.flatten import flatten, labelled
from cadpipe.io.text import ascii_rows, float32_columns
from cadpipe.io.usd import fan_triangles
from cadpipe.solids.scene import Scene, ScenePart, as_scene, unique_name

_OBJ_VERTEX = (b"v ", 0, b"e", 1, b" ", 2, b"e", 3, b" ", 4, b"e", 5, b"\n")
_OBJ_FACE = (b"f ", 0, b" ", 1, b" ", 2, b"\n")
_PLY_VERTEX = (0, b"e", 1, b" ", 2, b"e", 3, b" ", 4, b"e", 5, b" ", 6, b" ", 7, b" ", 8, b"\n")
_PLY_FACE = (b"3 ", 0, b" ", 1, b" ", 2, b" ", 3, b" ", 4, b" ", 5, b"\n")
#: rows formatted or packed per block (bounds the memory of a write)
_BLOCK = 1 << 16


@formats.writer("obj")
def write_obj(obj, path, *, units="m", layout="scene"):
    """Write ``obj`` as Wavefront OBJ (geometry, parts as ``o``/``g``), atomically.

    Parameters
    ----------
    units : str
        Length unit of the coordinates (metres, as Blender reads OBJ).
    layout : {"scene", "print"}
        See :func:`~cadpipe.solids.scene.as_scene`.
    """
    scene = as_scene(obj, layout=layout)
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


@formats.writer("ply")
def write_ply(obj, path, *, ascii=False, units="m", layout="scene"):
    """Write ``obj`` as PLY with vertex and face colours (binary unless ``ascii``), atomically.

    Parameters
    ----------
    ascii : bool
        Write the text form instead of binary little-endian.
    units : str
        Length unit of the coordinates (metres, as Blender and MeshLab read PLY).
    layout : {"scene", "print"}
        See :func:`~cadpipe.solids.scene.as_scene`.
    """
    scene = as_scene(obj, layout=layout)
    painted = flatten(scene, scene.scale_to(units))
    vertices, faces = painted.mesh.vertices, painted.mesh.faces
    rgb = np.round(painted.colors * 255).astype(np.uint8)
    if len(painted.names) > 1:     # a vertex where colours meet: one copy per colour
        narrow = len(vertices) + faces.size < 2**31       # int32 indices, as PLY holds them
        split = np.empty(faces.shape, np.int32 if narrow else np.int64)
        own_label, copy_of, copy_label = _copies_per_label(faces, painted.labels,
                                                           len(vertices), split)
        faces = split
        # the vertices as they are, then the extra copies (no full-size concatenation)
        sources = ((vertices, own_label), (vertices[copy_of], copy_label))
    else:
        sources = ((vertices, np.zeros(len(vertices), np.int64)),)
    n_vertices = sum(len(points) for points, _ in sources)
    if n_vertices >= 2**31:
        raise ExportError(f"PLY's int vertex indices cannot number {n_vertices:,} vertices",
                          file=path)
    header = ("ply\nformat {} 1.0\ncomment cadpipe: {} (units: {})\n"
              "element vertex {}\nproperty float x\nproperty float y\nproperty float z\n"
              "property uchar red\nproperty uchar green\nproperty uchar blue\n"
              "element face {}\nproperty list uchar int vertex_indices\n"
              "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n")
    header = header.format("ascii" if ascii else "binary_little_endian",
                           scene.name.replace("\n", " "), units,
                           n_vertices, len(faces))
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        fh.write(header.encode())
        if ascii:
            for points, label in sources:
                _write_rows(fh, _PLY_VERTEX, range(len(points)),
                            lambda rows, points=points, label=label: np.column_stack(
                                [float32_columns(points[rows]), rgb[label[rows]]]))
            _write_rows(fh, _PLY_FACE, range(len(faces)),
                        lambda rows: np.column_stack([faces[rows], rgb[painted.labels[rows]]]))
            return
        vertex_row = np.dtype([("p", "<f4", 3), ("c", "u1", 3)])
        face_row = np.dtype([("n", "u1"), ("i", "<i4", 3), ("c", "u1", 3)])
        for points, label in sources:
            for start in range(0, len(points), _BLOCK):
                block = np.empty(len(points[start:start + _BLOCK]), vertex_row)
                block["p"] = points[start:start + _BLOCK]
                block["c"] = rgb[label[start:start + _BLOCK]]
                fh.write(block.tobytes())
        for start in range(0, len(faces), _BLOCK):
            block = np.empty(len(faces[start:start + _BLOCK]), face_row)
            block["n"] = 3
            block["i"] = faces[start:start + _BLOCK]
            block["c"] = rgb[painted.labels[start:start + _BLOCK]]
            fh.write(block.tobytes())


def _copies_per_label(faces, labels, n_vertices, out):
    """Fill ``out`` (F, 3) with faces whose corners each reach a vertex of their face's
    label: one linear pass (C, ``csrc/meshfiles.c``).

    A vertex keeps its index for the first label that reaches it; each further
    label at it gets a copy numbered from ``n_vertices`` on (found through a
    short chain per vertex: as many links as colours meet there).

    Returns
    -------
    own_label : (V,) int64 label of each vertex as it is (0 where unused)
    copy_of : (E,) int64 vertex each copy repeats
    copy_label : (E,) int64 its label
    """
    return native.copies_per_label(np.ascontiguousarray(faces, np.int64), _index(labels),
                                   int(n_vertices), out)


def _index(values):
    """``values`` as a C-ordered int32 or int64 array (the kernels read either)."""
    values = np.asarray(values)
    return np.ascontiguousarray(values, values.dtype if values.dtype in (np.int32, np.int64)
                                else np.int64)


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


@formats.reader("obj")
def read_obj(path):
    """An OBJ file as a :class:`~cadpipe.solids.scene.Scene`: one part per ``o``, its faces
    labelled by ``g``; polygons fanned into triangles, exact duplicate vertices kept
    as written. In metres unless the header says otherwise (cadpipe writes
    ``# cadpipe: NAME (units: U)``).

    Lines are classified with numpy, and each run of ``v`` or ``f`` lines is parsed
    by one ``np.fromstring`` call: no Python work per vertex or face.
    """

    data = FilePath(path).read_bytes()
    if any(mark in data for mark in (b"\n ", b"\n\t")) or data[:1] in (b" ", b"\t"):
        data = re.sub(rb"(?m)^[ \t]+", b"", data)   # indented lines: classify by their word
    stem = FilePath(path).stem
    head = data[:200].decode("utf-8", "replace")
    units = "m"
    found = re.search(r"#\s*cadpipe:.*\(units: ([^)\s]+)\)", head)
    if found:
        units = found.group(1)
    vertices, objects = [], []        # objects: [name, [[group, [(counts, corners)]]]]
    n_vertices = 0
    try:
        runs = list(_runs(data))
    except ValueError:
        raise MeshError("a v or f line holds something other than numbers",
                        file=path) from None
    for kind, value in runs:
        if kind == b"v":
            values, per_line = value
            if (per_line < 3).any():
                raise MeshError("a vertex line is not three numbers", file=path)
            if (per_line == 3).all():
                vertices.append(values.reshape(-1, 3))
            else:                     # x y z and more (w, or a colour): the first three
                first = np.concatenate([[0], np.cumsum(per_line)[:-1]])
                vertices.append(values[first[:, None] + np.arange(3)])
            n_vertices += len(per_line)
        elif kind == b"f":
            corners, counts = value
            corners = np.where(corners > 0, corners - 1, n_vertices + corners)
            if not objects:
                objects.append([stem, []])
            if not objects[-1][1]:
                objects[-1][1].append([objects[-1][0], []])
            objects[-1][1][-1][1].append((counts, corners))
        else:                         # o and g lines, one at a time (there are few)
            for line in value.splitlines():
                word, _, rest = line.decode("utf-8", "replace").strip().partition(" ")
                if word == "o":
                    objects.append([rest.strip() or "object", []])
                elif word == "g":
                    if not objects:
                        objects.append([stem, []])
                    objects[-1][1].append([rest.strip() or objects[-1][0], []])
    points = np.concatenate(vertices) if vertices else np.empty((0, 3))
    units = units if units in UNITS else "m"
    parts, taken = [], set()
    for name, groups in objects:
        pieces, names = [], []
        for group, runs in groups:
            for counts, corners in runs:
                keep = counts >= 3
                if not keep.all():       # points and lines hold no triangles
                    corners = corners[np.repeat(keep, counts)]
                    counts = counts[keep]
                if len(counts) == 0:
                    continue
                if group not in names:
                    names.append(group)
                pieces.append((fan_triangles(counts, corners)[0], names.index(group)))
        if not pieces:
            continue
        faces = np.concatenate([f for f, _ in pieces])
        labels = np.repeat([k for _, k in pieces], [len(f) for f, _ in pieces])
        if faces.min() < 0 or faces.max() >= len(points):
            raise MeshError(f"object {name!r}: a face points past the vertices", file=path)
        used = np.zeros(len(points), bool)        # this object's vertices, in file order
        used[faces] = True
        faces = (np.cumsum(used) - 1)[faces]
        mesh = file_mesh(points[used], faces, path, name, face_part=labels,
                         part_names=names, attributes={
                             "source": str(path), "units": units,
                             "units_assumed": "(units: " not in head})
        parts.append(ScenePart(unique_name(name, taken), mesh))
    if not parts:
        raise MeshError("the file holds no triangles", file=path)
    return Scene(name=stem, parts=tuple(parts), units=units)


_SPACE = np.zeros(256, bool)
_SPACE[list(b" \t\r\n\v\f")] = True


def _runs(data):
    """(kind, value) for each run of consecutive lines of one kind: for ``v`` and ``f``
    lines their numbers and how many each line holds (:func:`_numbers`), for ``o``
    and ``g`` lines their text; all else (normals, texture coordinates, comments,
    materials) is skipped."""
    buf = np.frombuffer(data, np.uint8)
    starts = np.concatenate([[0], np.flatnonzero(buf == 10) + 1])
    starts = starts[starts < len(buf)]
    if not len(starts):                            # an empty file: no lines, no runs
        return
    ends = np.append(starts[1:], len(buf))
    padded = np.append(buf, [10, 10])
    first, second = padded[starts], padded[starts + 1]
    blank2 = _SPACE[second]
    kind = np.zeros(len(starts), np.int8)          # 0 skip, 1 v, 2 f, 3 o/g/other text
    kind[(first == ord("v")) & blank2] = 1
    kind[(first == ord("f")) & blank2] = 2
    kind[((first == ord("o")) | (first == ord("g"))) & (blank2 | (second == 10))] = 3
    change = np.flatnonzero(np.diff(kind.astype(np.int16)) != 0) + 1
    bounds = np.concatenate([[0], change, [len(kind)]])
    writable = None
    for a, b in zip(bounds[:-1], bounds[1:]):
        k = kind[a]
        if k == 0:
            continue
        if k == 3:
            yield b"o", data[starts[a]:ends[b - 1]]
            continue
        if writable is None:
            writable = bytearray(data)
        text = np.frombuffer(writable, np.uint8)
        text[starts[a:b]] = 32                     # blank the keyword of every line
        chunk = bytes(writable[starts[a]:ends[b - 1]])
        if k == 1:
            yield b"v", _numbers(chunk, np.float64)
        else:                                     # "f 1/2/3 ...": the vertex index only
            yield b"f", _numbers(re.sub(rb"/\S*", b"", chunk), np.int64)


def _numbers(text, dtype):
    """All numbers of ``text`` (whole lines; one ``np.fromstring``) and how many each
    line holds."""
    buf = np.frombuffer(text, np.uint8)
    line_starts = np.concatenate([[0], np.flatnonzero(buf[:-1] == 10) + 1])
    with warnings.catch_warnings():       # a stray word ends the parse early: caught below
        warnings.simplefilter("ignore", DeprecationWarning)
        values = np.fromstring(text, dtype=dtype, sep=" ")
    per_line = native.words_per_line(buf, line_starts, _SPACE)
    if len(values) != per_line.sum():
        raise ValueError("not numbers")
    return values, per_line
