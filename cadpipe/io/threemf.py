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
from collections import Counter
from concurrent.futures import ThreadPoolExecutor
from xml.sax.saxutils import quoteattr, unescape

import numpy as np

from cadpipe.errors import InputError
from cadpipe.geometry.mesh import merge_tables
from cadpipe.io.scene import as_scene, parse_color
from cadpipe.io.files import atomic_path, unique_name
from cadpipe.io.flatten import DEFAULT_COLOR, labelled
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


def write_3mf(obj, path, *, compresslevel=1, units=None):
    """Write ``obj`` (Mesh, Pipe, Assembly or Scene) as a 3MF package, atomically.

    Parameters
    ----------
    compresslevel : int
        Deflate level 1-9 of the model part (1: fastest; 9 saves about 15 %).
    units : str, optional
        Length unit of the file (the model's ``unit``); default: the scene's own.
    """
    scene = as_scene(obj)
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


# -- reading the colours back -------------------------------------------------------
_OBJECT = re.compile(rb"<(?:\w+:)?object\b([^>]*)>")
_OBJECT_END = re.compile(rb"</(?:\w+:)?object>")
_BASE_GROUP = re.compile(rb"<(?:\w+:)?basematerials\b([^>]*)>(.*?)</(?:\w+:)?basematerials>",
                         re.S)
_BASE = re.compile(rb"<(?:\w+:)?base\b([^>]*)>")
_ATTRIBUTE = re.compile(rb'([\w:]+)\s*=\s*"([^"]*)"')
_P1 = re.compile(rb' p1="(\d{1,9})"')
_PID = re.compile(rb' pid="(\d+)"')


def base_materials(path):
    """The base material of each triangle of each object of a 3MF file.

    Returns
    -------
    materials : dict
        ``{object name: (labels, bases)}``: ``labels`` (T,) int, the index into
        ``bases`` of each triangle in file order (its ``p1``, else the object's
        ``pindex``); ``bases`` a list of ``(name, (r, g, b))`` with channels in
        [0, 1]. Only objects named once, whose triangles all take materials of the
        object's own ``<basematerials>`` group (what cadpipe and most slicers write).

    The model is scanned as bytes (C-level searches, no parse of every element): a
    resource is declared before it is used, so the material groups come before the
    first object.
    """
    with zipfile.ZipFile(path) as package:
        data = package.read(_root_model(package))
    first = _OBJECT.search(data)
    groups = {}
    for attributes, body in _BASE_GROUP.findall(data, 0, first.start() if first else 0):
        groups[_attributes(attributes).get("id")] = [
            (b.get("name", ""), _rgb(b.get("displaycolor", "")))
            for b in map(_attributes, _BASE.findall(body))]
    found, named = {}, Counter()
    while first is not None:
        stop = data.find(b"</object>", first.end())        # the core namespace's, at C speed
        if stop < 0:
            end = _OBJECT_END.search(data, first.end())
            stop = end.start() if end else len(data)
        own = _attributes(first.group(1))
        name = own.get("name", own.get("id", ""))
        named[name] += 1
        bases = groups.get(own.get("pid"))
        labels = _object_labels(data[first.end():stop], own, len(bases)) if bases else None
        if labels is not None:
            found[name] = (labels, bases)
        first = _OBJECT.search(data, stop)
    return {name: value for name, value in found.items() if named[name] == 1}


def _object_labels(body, own, bases):
    """(T,) base of each triangle of the object whose content is ``body``, or None when
    its triangles do not all take one of the ``bases`` (a count) of its own group."""
    count = body.count(b"<triangle ") + body.count(b"<triangle\t")
    if not count or set(_PID.findall(body)) - {own["pid"].encode()}:
        return None
    p1 = _P1.findall(body)
    if len(p1) == count:
        labels = np.array(p1).astype(np.int64)
    elif not p1 and own.get("pindex", "0").isdigit():
        labels = np.full(count, int(own.get("pindex", "0")))
    else:
        return None                       # some triangles with p1, some without
    return labels if labels.max() < bases else None


def _root_model(package):
    """The path of the package's root model part (its relationship's target)."""
    rels = package.read("_rels/.rels") if "_rels/.rels" in package.namelist() else b""
    for attributes in re.findall(rb"<Relationship\b([^>]*)>", rels):
        relation = _attributes(attributes)
        if relation.get("Type", "").endswith("/3dmodel"):
            return relation.get("Target", "").lstrip("/")
    return "3D/3dmodel.model"


def _attributes(text):
    return {k.decode(): unescape(v.decode("utf-8", "replace"), {"&quot;": '"'})
            for k, v in _ATTRIBUTE.findall(text)}


def _rgb(text):
    """3MF's ``#RRGGBB[AA]`` as (r, g, b) in [0, 1]; cadpipe's grey for anything else."""
    try:
        return parse_color(text.strip()[:7])
    except InputError:
        return DEFAULT_COLOR
