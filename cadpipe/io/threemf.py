"""3MF for 3D printing: units, one object per part, colours as base materials.

Written here rather than through trimesh: trimesh builds the XML element by
element (several seconds for a million triangles). This writer turns whole
vertex and triangle tables into text as numpy byte arrays
(:mod:`cadpipe.io.text`) and streams them into the zip, deflating one
chunk while the next is formatted.

Package layout (3MF core specification 1.3)::

    [Content_Types].xml
    _rels/.rels                  -> /3D/3dmodel.model
    3D/3dmodel.model             <model unit=...>: <basematerials> with one colour per
                                 part name (names unique), one <object> per scene
                                 part (world coordinates) whose pid/pindex is its own
                                 colour, one build <item> per object; triangles of a
                                 part with several colours carry pid and p1

Coordinates are written as float32 values with 9 significant digits, as an
integer mantissa and exponent (``x="123456789e-9"``, a valid 3MF number): the
fewest digits that read back to the same float32, which is what slicers parse
them into.
"""

import re
import zipfile
import zlib
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path as FilePath
from types import MappingProxyType
from typing import NamedTuple
from xml.etree import ElementTree
from xml.sax.saxutils import quoteattr

import numpy as np

from cadpipe import limits
from cadpipe.errors import InputError, MeshError, shown
from cadpipe.geometry.mesh import merge_tables
from cadpipe.core.kernels import native
from cadpipe.core.transform import placed_points
from cadpipe.core import formats
from cadpipe.io.files import atomic_path, file_mesh
from cadpipe.solids.scene import Scene, ScenePart, as_scene, unique_name
from cadpipe.io.flatten import labelled
from cadpipe.io.text import ascii_rows, float32_columns

#: 3MF's names for cadpipe's scene units
UNIT_NAMES = {"m": "meter", "cm": "centimeter", "mm": "millimeter", "in": "inch",
              "ft": "foot"}

_CORE = "http://schemas.microsoft.com/3dmanufacturing/core/2015/02"
_CONTENT_TYPES = (
    '<?xml version="1.0" encoding="UTF-8"?>\n'
    '<Types xmlns="http://schemas.openxmlformats.org/package/2006/content-types">'
    '<Default Extension="rels" '
    'ContentType="application/vnd.openxmlformats-package.relationships+xml"/>'
    '<Default Extension="model" '
    'ContentType="application/vnd.ms-package.3dmanufacturing-3dmodel+xml"/></Types>\n')
_RELS = (
    '<?xml version="1.0" encoding="UTF-8"?>\n'
    '<Relationships xmlns="http://schemas.openxmlformats.org/package/2006/relationships">'
    '<Relationship Target="/3D/3dmodel.model" Id="rel0" '
    'Type="http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"/></Relationships>\n')
_VERTEX = (b'<vertex x="', 0, b"e", 1, b'" y="', 2, b"e", 3, b'" z="', 4, b"e", 5, b'"/>\n')
_TRIANGLE = (b'<triangle v1="', 0, b'" v2="', 1, b'" v3="', 2, b'"/>\n')
_TRIANGLE_COLORED = _TRIANGLE[:-1] + (b'" pid="1" p1="', 3, b'"/>\n')
#: longest possible vertex or triangle row, in bytes (with 32-bit indices)
_MAX_ROW_BYTES = 96
#: rows formatted per chunk: bounds memory and lets compression overlap formatting
_CHUNK = 1 << 16


@formats.writer("3mf")
def write_3mf(obj, path, *, compresslevel=1, units=None, layout="scene"):
    """Write ``obj`` (Mesh, Pipe, Assembly or Scene) as a 3MF package, atomically.

    Parameters
    ----------
    compresslevel : int
        Deflate level 1-9 of the model part (1: fastest; 9 saves about 15 %).
    units : str, optional
        Length unit of the file (the model's ``unit``); default: the scene's own.
    layout : {"scene", "print"}
        See :func:`~cadpipe.solids.scene.as_scene`.
    """
    scene = as_scene(obj, layout=layout)
    units = units or scene.units
    if units not in UNIT_NAMES:
        raise InputError(f"units: 3MF knows {', '.join(UNIT_NAMES)}, got {units!r}; "
                         "convert the scene to one of them")
    unit, scale = UNIT_NAMES[units], scene.scale_to(units)
    parts = [(part.name, labelled(scene, part, world=True, scale=scale))
             for part in scene.parts]
    with atomic_path(path) as tmp, \
            zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED, compresslevel=compresslevel) as zf:
        zf.writestr("[Content_Types].xml", _CONTENT_TYPES)
        zf.writestr("_rels/.rels", _RELS)
        # Zip64 headers only where the model may pass 2 GiB: some readers refuse them
        rows = sum(len(p.mesh.vertices) + len(p.mesh.faces) for _, p in parts)
        large = _MAX_ROW_BYTES * rows + 4096 * len(parts) >= zipfile.ZIP64_LIMIT
        with zf.open("3D/3dmodel.model", "w", force_zip64=large) as stream, \
                ThreadPoolExecutor(max_workers=1) as compressor:
            # zlib releases the GIL: deflate one chunk while the next is formatted
            writing = None
            for chunk in _model_xml(scene, unit, parts):
                if writing is not None:
                    writing.result()
                writing = compressor.submit(stream.write, chunk)
            if writing is not None:
                writing.result()


def _model_xml(scene, unit, parts):
    """The model part as a sequence of UTF-8 chunks (bytes)."""
    yield (f'<?xml version="1.0" encoding="UTF-8"?>\n<model unit="{unit}" xml:lang="en-US" '
           f'xmlns="{_CORE}">\n<metadata name="Title">{_escape(scene.name)}</metadata>\n'
           '<metadata name="Application">cadpipe</metadata>\n<resources>\n').encode()
    materials, indices = merge_tables([[(name, _hex(rgb)) for name, rgb in
                                         zip(painted.names, painted.colors)]
                                        for _, painted in parts])   # (name, colour) -> base
    taken = set()
    unique = [unique_name(label, taken) for label, _ in materials]  # names repeat by colour
    # each object's own colour: its own label's, else the one most of its faces have
    own = [base[painted.names.index(name)] if name in painted.names else
           base[int(np.bincount(painted.labels, minlength=len(base)).argmax())]
           for (name, painted), base in zip(parts, indices)]
    yield b'<basematerials id="1">\n' + "".join(
        f'<base name={quoteattr(label)} displaycolor="{color}"/>\n'
        for label, (_, color) in zip(unique, materials)).encode() + b"</basematerials>\n"
    for object_id, ((name, painted), base, pindex) in enumerate(zip(parts, indices, own),
                                                                start=2):
        mesh = painted.mesh
        yield (f'<object id="{object_id}" type="model" name={quoteattr(name)} pid="1" '
               f'pindex="{pindex}">\n<mesh>\n<vertices>\n').encode()
        yield from _rows(_VERTEX, mesh.vertices, prepare=float32_columns)
        yield b"</vertices>\n<triangles>\n"
        if len(base) == 1:
            yield from _rows(_TRIANGLE, mesh.faces)
        else:
            yield from _rows(_TRIANGLE_COLORED, mesh.faces, base[painted.labels])
        yield b"</triangles>\n</mesh>\n</object>\n"
    items = "".join(f'<item objectid="{i}"/>\n' for i in range(2, len(parts) + 2))
    yield f"</resources>\n<build>\n{items}</build>\n</model>\n".encode()


def _rows(template, *tables, prepare=None):
    """``template`` (see :func:`ascii_rows`) filled from the columns of ``tables`` side by
    side, ``_CHUNK`` rows at a time, each chunk through ``prepare`` first: no
    full-size table of text columns is made."""
    for start in range(0, len(tables[0]), _CHUNK):
        block = np.column_stack([t[start:start + _CHUNK] for t in tables])
        yield ascii_rows(template, block if prepare is None else prepare(block))


def _hex(rgb):
    return "#" + "".join(f"{round(float(c) * 255):02X}" for c in rgb) + "FF"


def _escape(text):
    return quoteattr(str(text))[1:-1]


# -- reading ---------------------------------------------------------------------
_MATERIAL = "http://schemas.microsoft.com/3dmanufacturing/material/2015/02"
_PRODUCTION = "http://schemas.microsoft.com/3dmanufacturing/production/2015/06"
_MODEL_TYPE = "http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"
#: 3MF's units (core specification 1.3, 3.4.1) in cadpipe's: (unit, factor)
_UNITS_READ = {"micron": ("mm", 0.001), "millimeter": ("mm", 1.0), "centimeter": ("cm", 1.0),
               "inch": ("in", 1.0), "foot": ("ft", 1.0), "meter": ("m", 1.0)}
#: the attribute the fast path puts on each mesh table it parsed (its block's number)
_BLOCK = "{urn:cadpipe:block}n"
_TABLE = re.compile(rb"<(vertices|triangles)(?=[\s/>])")
#: a table's row element
_ROW = {b"vertices": b"vertex", b"triangles": b"triangle"}
_TRIANGLE_ATTRIBUTES = ("v1", "v2", "v3", "pid", "p1")


@formats.reader("3mf")
def read_3mf(path):
    """The objects of a 3MF package as a Z-up :class:`~cadpipe.solids.scene.Scene`.

    One part per mesh object placed by the build (through components, also those
    in other model files of the production extension), in world coordinates and
    the model's unit (a micron model in millimetres), named after the build
    item's ``partnumber`` or the object. Faces are labelled by their
    base material (its name) or colour group (the part's name and the colour),
    coloured by its ``displaycolor``. Raises :class:`~cadpipe.errors.MeshError`
    for what is not a 3MF package, and :class:`~cadpipe.errors.LimitError` for
    a build past ``max_triangles`` before any of it is placed.

    The tables of vertices and triangles, nearly all of a file, are read by one
    compiled scan each (``scan_3mf``, ``csrc/threemf.c``); the rest of the XML, a
    few elements per object, by ElementTree. A model the scan cannot read
    (comments, CDATA, a prefix on the core namespace) is read by ElementTree
    alone, more slowly.
    """
    try:
        archive = zipfile.ZipFile(path)
    except (zipfile.BadZipFile, OSError, ValueError) as exc:
        raise MeshError(f"not a 3MF package ({exc})", file=path) from None
    with archive:
        models = _Models(archive, path)
        root = models.get(_root_part(archive, path))
        placed = _placements(root, models, path)
    unit, factor = _UNITS_READ.get(root.unit, (None, 1.0))
    if unit is None:
        raise MeshError(f"unknown unit {root.unit!r}; 3MF's are {', '.join(_UNITS_READ)}",
                        file=path)
    parts, colors, taken = [], {}, set()
    for name, obj, matrix in placed:
        vertices, faces, _ = obj.mesh
        matrix = matrix.copy()
        matrix[:3] *= factor
        vertices = placed_points(vertices, matrix)     # inf/NaN: file_mesh names the part
        if np.linalg.det(matrix[:3, :3]) < 0:
            faces = faces[:, ::-1]
        name = unique_name(name, taken)
        labels, names = _face_labels(obj, name, colors)
        mesh = file_mesh(vertices, faces, path, name, face_part=labels, part_names=names,
                         attributes={"source": str(path), "units": unit})
        parts.append(ScenePart(name, mesh))
    if not parts:
        raise MeshError("the build places no triangles", file=path)
    return Scene(name=FilePath(path).stem, parts=tuple(parts), units=unit,
                 colors=MappingProxyType(colors))


class _Object(NamedTuple):
    """An ``<object>``: a mesh ``(vertices, faces, props)`` (props: (T, 2) pid and p1 per
    triangle, -1 where absent, or None) or components ``[(objectid, 4x4 matrix,
    model part)]``."""

    name: str
    pid: int
    pindex: int
    mesh: tuple | None
    components: list
    colours: dict                   #: its model part's property groups (see _Model)


class _Model(NamedTuple):
    unit: str
    objects: dict                   #: id -> _Object
    colours: dict                   #: property group id -> [(name or None, rgb or None)]
    items: list                     #: [(objectid, 4x4 matrix, partnumber, model part)]


def _root_part(archive, path):
    """The name of the package's root model part (from ``_rels/.rels``)."""
    try:
        rels = ElementTree.fromstring(_member(archive, "_rels/.rels", path))
        for rel in rels:
            if rel.get("Type") == _MODEL_TYPE and rel.get("Target"):
                return rel.get("Target").lstrip("/")
    except (KeyError, ElementTree.ParseError):
        pass
    found = [n for n in archive.namelist() if n.lower() == "3d/3dmodel.model"]
    if not found:
        raise MeshError("not a 3MF package (no 3D model part)", file=path)
    return found[0]


def _member(archive, name, path):
    """The bytes of part ``name`` (its size is checked by :func:`cadpipe.limits.check_archive`
    before the package is opened)."""
    try:
        return archive.read(name)
    except KeyError:
        raise MeshError(f"the package has no part {name!r}", file=path) from None
    except (zipfile.BadZipFile, OSError, ValueError, EOFError, zlib.error) as exc:
        raise MeshError(f"cannot unpack {name!r} ({exc})", file=path) from None


class _Models:
    """The package's model parts, each read once, when first referenced; ``spent``: the
    triangles and array bytes their tables hold so far (all parts count against the
    budgets together)."""

    def __init__(self, archive, path):
        self.archive, self.path, self.read = archive, path, {}
        self.spent = [0, 0]

    def get(self, part):
        part = part.lstrip("/")
        if part not in self.read:
            data = _member(self.archive, part, self.path)
            self.read[part] = _parse_model(data, part, self.path, self.spent)
        return self.read[part]


def _parse_model(data, part, path, spent):
    """A model part's :class:`_Model`."""
    tables = {}
    try:
        skeleton, totals = _tables_taken_out(data, part, path, tables, spent)
    except _Unscannable:
        skeleton = None
    # a comment, CDATA section, DTD or processing instruction between the tables could
    # hide markup the search for tables took for real: then ElementTree reads everything
    if skeleton is not None:
        head = skeleton.removeprefix(b"\xef\xbb\xbf")
        if head.startswith(b"<?xml"):
            head = head[head.find(b"?>"):]
        if not any(mark in head for mark in (b"<!", b"<?", b"]]>")):
            spent[:] = totals
            return _read_model(_xml(skeleton, part, path), tables, part, path)
    if b"<!DOCTYPE" in data or b"<!ENTITY" in data:
        raise MeshError(f"{part}: declares a DTD, which 3MF does not allow", file=path)
    spent[0] += data.count(b"<triangle")
    limits.check("max_triangles", spent[0], f"reading {part}", file=path, at_least=True)
    return _read_model(_xml(data, part, path), {}, part, path)


class _Unscannable(Exception):
    """A table the compiled scan does not read: the model is read by ElementTree alone."""


def _xml(text, part, path):
    try:
        root = ElementTree.fromstring(text)
    except ElementTree.ParseError as exc:
        raise MeshError(f"{part}: not well-formed XML ({exc})", file=path) from None
    if _local(root.tag) != "model":
        raise MeshError(f"{part}: the root element is <{_local(root.tag)}>, not <model>",
                        file=path)
    return root


def _tables_taken_out(data, part, path, tables, spent):
    """``data`` with each ``<vertices>`` and ``<triangles>`` table read by the compiled
    scan into ``tables`` (numbered) and replaced by an empty element marked with its
    number, and the triangles and bytes of arrays read with those ``spent`` before:
    what is left is a few elements per object for ElementTree. Each table's rows
    are counted first (``extent_3mf``, ``csrc/threemf.c``) and checked against the budgets
    (``max_triangles``; ``max_unpacked_bytes`` for its arrays) before it is read.
    Raises :class:`_Unscannable` for a table holding markup the scan does not read."""
    text = np.frombuffer(data, np.uint8)
    pieces, last = [], 0
    triangles, unpacked = spent
    marker = b'<%s xmlns:cadpipe_block="urn:cadpipe:block" cadpipe_block:n="%d"/>'
    while (match := _TABLE.search(data, last)) is not None:
        name = match.group(1)
        close = data.find(b">", match.end())
        if close < 0:
            raise _Unscannable
        start = stop = end = close + 1
        rows = 0
        if data[close - 1] != ord("/"):                     # not <vertices/>: rows
            rows, stop = native.extent_3mf(text, start, np.frombuffer(_ROW[name], np.uint8))
            end = data.find(b">", stop) + 1
            if rows < 0 or not data.startswith(b"</" + name, stop) or \
                    data[stop + 2 + len(name):end - 1].strip():
                raise _Unscannable
        if name == b"triangles":
            triangles += rows
            limits.check("max_triangles", triangles, f"reading {part}", file=path)
        unpacked += 24 * rows                          # float64 points, int64 indices
        limits.check("max_unpacked_bytes", unpacked, f"reading {part}", file=path)
        tables[len(tables)] = _scanned(text, start, stop, rows, name == b"triangles")
        pieces += [data[last:match.start()], marker % (name, len(tables) - 1)]
        last = end
    pieces.append(data[last:])
    return b"".join(pieces), [triangles, unpacked]


def _local(tag):
    return tag.rpartition("}")[2]


def _read_model(root, tables, part, path):
    core = root.tag[:-len("model")]
    unit = root.get("unit", "millimeter")
    colours, objects, items = {}, {}, []
    for resources in root.iter(core + "resources"):
        for resource in resources:
            kind = _local(resource.tag)
            if kind == "basematerials":
                colours[_int(resource, "id", path)] = [
                    (base.get("name"), _rgb(base.get("displaycolor")))
                    for base in resource if _local(base.tag) == "base"]
            elif kind == "colorgroup":
                colours[_int(resource, "id", path)] = [
                    (None, _rgb(colour.get("color")))
                    for colour in resource if _local(colour.tag) == "color"]
            elif kind == "object":
                objects[_int(resource, "id", path)] = _read_object(resource, core, tables,
                                                                   colours, part, path)
    for build in root.iter(core + "build"):
        for item in build.iter(core + "item"):
            items.append((_int(item, "objectid", path), _matrix(item.get("transform"), path),
                          item.get("partnumber"),
                          item.get(f"{{{_PRODUCTION}}}path", part)))
    return _Model(unit, objects, colours, items)


def _read_object(element, core, tables, colours, part, path):
    """An ``<object>`` element's :class:`_Object`."""
    name = element.get("name") or f"object {element.get('id')}"
    pid = _int(element, "pid", path, -1)
    pindex = _int(element, "pindex", path, -1)
    mesh = element.find(core + "mesh")
    if mesh is not None:
        vertices = _table(mesh.find(core + "vertices"), tables, "vertex", name, path)
        faces, props = _table(mesh.find(core + "triangles"), tables, "triangle", name, path)
        return _Object(name, pid, pindex, (vertices, faces, props), [], colours)
    components = [(_int(c, "objectid", path), _matrix(c.get("transform"), path),
                   c.get(f"{{{_PRODUCTION}}}path", part).lstrip("/"))
                  for c in element.iter(core + "component")]
    return _Object(name, pid, pindex, None, components, colours)


def _table(element, tables, row, name, path):
    """A ``<vertices>`` table as (N, 3) float, or a ``<triangles>`` table as (T, 3) int
    vertex indices and (T, 2) int pid and p1 (-1 where absent; None where none has
    either): from the fast path's ``tables``, else from its elements."""
    integer = row == "triangle"
    if element is not None and element.get(_BLOCK) is not None:
        return tables[int(element.get(_BLOCK))]
    names = _TRIANGLE_ATTRIBUTES if integer else ("x", "y", "z")
    rows = [] if element is None else [c for c in element if _local(c.tag) == row]
    try:
        cells = [[r.get(n, "-1" if i >= 3 else None) for i, n in enumerate(names)]
                 for r in rows]
        table = np.array(cells, dtype=np.int64 if integer else np.float64)
    except (TypeError, ValueError, OverflowError):
        raise MeshError(f"object {name!r}: a <{row}> lacks {', '.join(names[:3])} "
                        "or holds something other than numbers", file=path) from None
    table = table.reshape(-1, len(names))
    if not integer:
        return table
    return np.ascontiguousarray(table[:, :3]), table[:, 3:] if (table[:, 3:] >= 0).any() \
        else None


def _scanned(text, start, stop, rows, integer):
    """A table's numbers from ``text[start:stop]`` (``rows`` rows) by the C scan
    (``scan_3mf``), as :func:`_table` returns them; raises :class:`_Unscannable`
    where the scan cannot read it."""
    names = _TRIANGLE_ATTRIBUTES if integer else ("x", "y", "z")
    keys = np.zeros((len(names), 8), np.uint8)
    for i, n in enumerate(names):
        keys[i, :len(n)] = np.frombuffer(n.encode(), np.uint8)
    lengths = np.array([len(n) for n in names], np.int64)
    floats = np.empty((0 if integer else rows, 3))
    ints = np.empty((rows if integer else 0, 3), np.int64)
    extra = np.full((rows, len(names) - 3), -1, np.int64)
    element = np.frombuffer(b"triangle" if integer else b"vertex", np.uint8)
    slow = np.zeros(3, np.int64)   # numbers the compiled parse cannot round exactly; extra
    arguments = (text, start, stop, element, keys, lengths, floats, ints, extra, integer)
    if not native.scan_3mf(*arguments, np.empty(0, np.uint8), np.empty(0, np.int64), slow):
        raise _Unscannable
    if slow[0]:                    # their text, gathered, then parsed by numpy at once
        spans, where = np.empty(slow[1], np.uint8), np.empty(slow[0], np.int64)
        native.scan_3mf(*arguments, spans, where, slow)
        floats.reshape(-1)[where] = np.array(spans.tobytes().split(), dtype=np.float64)
    if not integer:
        return floats
    return ints, extra if slow[2] else None


def _object(models, key, path):
    part, object_id = key
    objects = models.get(part).objects
    if object_id not in objects:
        raise MeshError(f"{part}: no object {object_id} (referenced by the build or a "
                        "component)", file=path)
    return objects[object_id]


def _placements(root, models, path):
    """[(name, object, 4x4 world matrix)] of each mesh object the build places.

    Before any is placed, the triangles and parts the build places are counted
    (components may repeat an object many times over) and checked against
    ``max_triangles`` and ``max_parts``, and components are checked to form no
    cycle.
    """
    totals = {}                            # (part, id) -> (triangles, meshes) one places
    for object_id, _, _, part in root.items:
        _count(models, (part.lstrip("/"), object_id), totals, path)
    triangles = sum(totals[(p.lstrip("/"), i)][0] for i, _, _, p in root.items)
    meshes = sum(totals[(p.lstrip("/"), i)][1] for i, _, _, p in root.items)
    limits.check("max_triangles", triangles, "the objects this 3MF's build places", file=path)
    limits.check("max_parts", meshes, "the objects this 3MF's build places", file=path)
    placed = []
    for object_id, matrix, partnumber, part in root.items:
        stack = [((part.lstrip("/"), object_id), matrix)]
        while stack:
            key, world = stack.pop()
            obj = _object(models, key, path)
            if obj.mesh is not None:
                if len(obj.mesh[1]):
                    placed.append((partnumber or obj.name, obj, world))
                continue
            stack.extend(((p, c), world @ m) for c, m, p in reversed(obj.components))
    return placed


def _count(models, key, totals, path):
    """Fill ``totals`` with (triangles, meshes) placed by one instance of object ``key``
    and of every object below it (depth first, without recursion); a cycle of
    components is a :class:`MeshError`."""
    open_, stack = set(), [key]
    while stack:
        key = stack[-1]
        if key in totals:
            stack.pop()
            continue
        obj = _object(models, key, path)
        if obj.mesh is not None:
            totals[key] = (len(obj.mesh[1]), int(len(obj.mesh[1]) > 0))
            stack.pop()
            continue
        children = [(p, c) for c, _, p in obj.components]
        if key in open_:
            totals[key] = (sum(totals[c][0] for c in children),
                           sum(totals[c][1] for c in children))
            open_.discard(key)
            stack.pop()
            continue
        open_.add(key)
        for child in children:
            if child in open_:
                raise MeshError(f"object {key[1]}'s components form a cycle", file=path)
            if child not in totals:
                stack.append(child)


def _face_labels(obj, name, colors):
    """(F,) label per face of ``obj`` and the label names, from each triangle's property
    (``pid``/``p1``, else the object's ``pid``/``pindex``): a base material's name, or
    ``name`` and the colour for a colour group; ``colors`` (label -> rgb) gains each
    label's colour. ``(None, ())`` where no face has one."""
    props = obj.mesh[2]
    if props is None:
        keys, labels = np.array([[obj.pid, obj.pindex]]), None
    else:
        pid = np.where(props[:, 0] >= 0, props[:, 0], obj.pid)
        index = np.where(props[:, 1] >= 0, props[:, 1], obj.pindex)
        # one integer per (pid, p1): a sort of ints, not of rows
        packed = (pid + 1) << 32 | (index + 1)
        codes, labels = np.unique(packed, return_inverse=True)
        keys = np.stack([(codes >> 32) - 1, (codes & 0xFFFFFFFF) - 1], axis=1)
    names, coloured = [], False
    for pid, index in keys.tolist():
        group = obj.colours.get(pid, ())
        label, rgb = group[index] if 0 <= index < len(group) else (None, None)
        if rgb is None:
            label = name
        else:
            coloured = True
            label = label or f"{name}_" + "".join(f"{round(c * 255):02x}" for c in rgb)
            while colors.setdefault(label, rgb) != rgb:       # one colour per label name
                label += "_"
        names.append(label)
    if not coloured:
        return None, ()
    if labels is None:
        labels = np.zeros(len(obj.mesh[1]), np.int64)
    distinct = tuple(dict.fromkeys(names))                      # equal names: one label
    return np.array([distinct.index(n) for n in names])[labels], distinct


def _int(element, attribute, path, default=None):
    value = element.get(attribute)
    if value is None and default is not None:
        return default
    try:
        return int(value)
    except (TypeError, ValueError):
        raise MeshError(f"<{_local(element.tag)}> has {attribute}={shown(value)}, not a "
                        "whole number", file=path) from None


def _rgb(text):
    """(r, g, b) in [0, 1] of ``"#RRGGBB"`` or ``"#RRGGBBAA"``; None for anything else."""
    if not isinstance(text, str) or len(text) not in (7, 9) or text[0] != "#":
        return None
    try:
        return tuple(int(text[i:i + 2], 16) / 255.0 for i in (1, 3, 5))
    except ValueError:
        return None


def _matrix(text, path):
    """The 4x4 column-vector matrix of a 3MF ``transform`` (12 numbers: the rows of a
    4x3 matrix that multiplies row vectors); the identity when there is none."""
    matrix = np.eye(4)
    if text is None:
        return matrix
    try:
        rows = np.array(text.split(), dtype=np.float64).reshape(4, 3)
    except ValueError:
        raise MeshError(f"transform={shown(text)} is not 12 numbers", file=path) from None
    if not np.isfinite(rows).all():
        raise MeshError(f"transform={shown(text)} is not finite", file=path)
    matrix[:3, :3], matrix[:3, 3] = rows[:3].T, rows[3]
    return matrix
