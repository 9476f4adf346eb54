"""Binary glTF 2.0 (.glb) for VR, web viewers and Blender, written from numpy.

Layout::

    scene 0 -> node <scene>      matrix: the scene's axes and units onto glTF's
                                 (+Y up, metres), see :func:`gltf_root`
                 node <part>     one per part, its transform as ``matrix``,
                                 mesh <part>: one primitive per colour (the
                                 part's faces of that colour), all of them
                                 sharing the part's POSITION and NORMAL
                                 accessors; material per colour, names unique

One node and one mesh per part, so Blender imports each part as one object
(with a material slot per colour) and a viewer draws a part in as many calls as
it has colours. Normals follow the crease angle (:mod:`cadpipe.io.normals`):
vertices on a crease are split so each corner keeps its normal. Arrays are
written straight from numpy into the file, one after the other, so writing
costs little memory beyond the arrays themselves.
"""

import json
import struct
from pathlib import Path as FilePath
from types import MappingProxyType

import numpy as np

from cadpipe import limits
from cadpipe.core.vec import bounds as point_bounds
from cadpipe.errors import CadpipeError, InputError, MeshError, shown
from cadpipe.core.transform import placed_points
from cadpipe.core import formats
from cadpipe.io.files import atomic_path, file_mesh
from cadpipe.io.flatten import labelled
from cadpipe.io.normals import DEFAULT_CREASE_ANGLE, split_for_normals
from cadpipe.solids.scene import TO_Y_UP, Scene, ScenePart, as_scene, unique_name

_FLOAT, _UINT = 5126, 5125
_ARRAY_BUFFER, _ELEMENT_ARRAY_BUFFER = 34962, 34963


def gltf_root(scene):
    """4x4 matrix from the scene's axes and units to glTF's (+Y up, metres)."""
    matrix = np.eye(4)
    up = str(scene.up_axis).upper()
    if up not in TO_Y_UP:
        raise InputError(f"up_axis: expected 'Y' or 'Z', got {scene.up_axis!r}")
    matrix[:3, :3] = TO_Y_UP[up] * scene.meters_per_unit
    return matrix


@formats.writer("glb")
def write_glb(obj, path, *, crease_angle=DEFAULT_CREASE_ANGLE, units="m", normals=True,
              layout="scene"):
    """Write ``obj`` (Mesh, Pipe, Assembly or Scene) as binary glTF, atomically.

    Parameters
    ----------
    crease_angle : float
        Degrees: faces meeting at a sharper angle shade with a hard edge.
    normals : bool
        Write shading normals (glTF viewers draw a mesh without them faceted).
    units : str
        Must be "m": glTF is in metres by definition (the root node scales
        the scene's own units to metres).
    layout : {"scene", "print"}
        See :func:`~cadpipe.solids.scene.as_scene`.
    """
    if units != "m":
        raise InputError(f"units: glTF is in metres by definition, got {units!r}; "
                         "the file's root node converts the scene's units")
    scene = as_scene(obj, layout=layout)
    doc = _Document()
    root = {"name": scene.name, "matrix": _column_major(gltf_root(scene)), "children": []}
    doc.nodes.append(root)
    node_names = set()
    for part in scene.parts:
        painted = labelled(scene, part)
        if normals:
            vertices, faces, shading = split_for_normals(painted.mesh, crease_angle)
        else:
            vertices = painted.mesh.vertices.astype(np.float32)
            faces = painted.mesh.faces.astype(np.uint32)
        name = unique_name(part.name, node_names)
        attributes = {"POSITION": doc.accessor(vertices, "VEC3", _ARRAY_BUFFER, bounds=True)}
        if normals:
            attributes["NORMAL"] = doc.accessor(shading, "VEC3", _ARRAY_BUFFER)
        primitives = []
        groups = _colour_groups(painted)
        for label_group, rgb in groups:
            picked = faces if len(groups) == 1 else faces[np.isin(painted.labels, label_group)]
            primitives.append({
                "attributes": attributes,
                "indices": doc.accessor(picked.ravel(), "SCALAR", _ELEMENT_ARRAY_BUFFER),
                "material": doc.material(painted.names[label_group[0]], rgb),
                "mode": 4})
        doc.meshes.append({"name": name, "primitives": primitives})
        node = {"name": name, "mesh": len(doc.meshes) - 1}
        if part.transform is not None:
            node["matrix"] = _column_major(part.transform)
        root["children"].append(len(doc.nodes))
        doc.nodes.append(node)
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        doc.write(fh)


def _colour_groups(painted):
    """[(labels, rgb)]: the labels that have faces, grouped by colour, in label order."""
    if len(painted.names) == 1:                   # a part's faces, all of one label
        return [([0], painted.colors[0])]
    used = np.flatnonzero(np.bincount(painted.labels, minlength=len(painted.names)))
    groups = {}
    for label in used:
        groups.setdefault(tuple(np.round(painted.colors[label], 6)), []).append(int(label))
    return [(labels, painted.colors[labels[0]]) for labels in groups.values()]


def _column_major(matrix):
    return [float(x) for x in np.asarray(matrix, dtype=np.float64).T.ravel()]


class _Document:
    """The JSON tables of a glTF file and the arrays of its one binary buffer."""

    def __init__(self):
        self.nodes, self.meshes, self.materials = [], [], []
        self.accessors, self.views, self.arrays = [], [], []
        self.length = 0
        self._material_of, self._material_names = {}, set()

    def accessor(self, array, kind, target, bounds=False):
        """Index of a new accessor over ``array`` (float32 or uint32, appended to the buffer)."""
        array = np.ascontiguousarray(array)
        self.views.append({"buffer": 0, "byteOffset": self.length,
                           "byteLength": array.nbytes, "target": target})
        self.arrays.append(array)
        self.length += array.nbytes              # 4-byte elements: always aligned
        entry = {"bufferView": len(self.views) - 1, "count": len(array),
                 "componentType": _FLOAT if array.dtype == np.float32 else _UINT,
                 "type": kind}
        if bounds:
            entry["min"], entry["max"] = point_bounds(array).tolist()
        self.accessors.append(entry)
        return len(self.accessors) - 1

    def material(self, name, rgb):
        """Index of the PBR material of this name and colour (names kept unique)."""
        key = (name, tuple(np.round(rgb, 6)))
        if key not in self._material_of:
            self._material_of[key] = len(self.materials)
            self.materials.append({
                "name": unique_name(name, self._material_names),
                "pbrMetallicRoughness": {"baseColorFactor": [*map(float, rgb), 1.0],
                                         "metallicFactor": 0.0, "roughnessFactor": 0.5}})
        return self._material_of[key]

    def write(self, fh):
        """The GLB container: header, JSON chunk, BIN chunk (arrays streamed as they are)."""
        doc = {"asset": {"version": "2.0", "generator": "cadpipe"}, "scene": 0,
               "scenes": [{"nodes": [0]}], "nodes": self.nodes, "meshes": self.meshes,
               "materials": self.materials, "accessors": self.accessors,
               "bufferViews": self.views, "buffers": [{"byteLength": self.length}]}
        text = json.dumps(doc, separators=(",", ":")).encode()
        text += b" " * (-len(text) % 4)
        fh.write(struct.pack("<4sII", b"glTF", 2, 12 + 8 + len(text) + 8 + self.length))
        fh.write(struct.pack("<I4s", len(text), b"JSON") + text)
        fh.write(struct.pack("<I4s", self.length, b"BIN\0"))
        for array in self.arrays:
            fh.write(memoryview(array).cast("B"))


# -- reading ---------------------------------------------------------------------
_COMPONENTS = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32,
               5126: np.float32}
_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}


@formats.reader("glb")
def read_glb(path):
    """The parts of a binary glTF file as a Z-up :class:`~cadpipe.solids.scene.Scene` in metres.

    Each node with a mesh is a part (named after the node, or its mesh) in world
    coordinates; each triangle primitive's faces are labelled with its
    material's name and coloured by its base colour. glTF's +Y up is turned
    back to +Z up. Raises :class:`~cadpipe.errors.MeshError` for a file that is
    not GLB or holds no triangles.
    """

    limits.check("max_unpacked_bytes", FilePath(path).stat().st_size, "reading this GLB file",
                 file=path)
    data = FilePath(path).read_bytes()
    try:
        magic, _, _ = struct.unpack_from("<4sII", data, 0)
        json_length, json_kind = struct.unpack_from("<I4s", data, 12)
        if magic != b"glTF" or json_kind != b"JSON":
            raise MeshError("not a binary glTF file (no glTF header)", file=path)
        if 20 + json_length > len(data):
            raise MeshError(f"truncated: its JSON chunk declares {json_length:,} bytes, "
                            f"the file holds {len(data) - 20:,}", file=path)
        doc = json.loads(data[20:20 + json_length])
        binary = b""
        if len(data) > 28 + json_length:
            bin_length, _ = struct.unpack_from("<I4s", data, 20 + json_length)
            if 28 + json_length + bin_length > len(data):
                raise MeshError(f"truncated: its binary chunk declares {bin_length:,} bytes, "
                                f"the file holds {len(data) - 28 - json_length:,}", file=path)
            binary = memoryview(data)[28 + json_length:28 + json_length + bin_length]
    except MeshError:
        raise
    except (struct.error, ValueError) as exc:
        raise MeshError(f"not a binary glTF file ({exc})", file=path) from None
    except RecursionError:
        raise MeshError("its JSON nests too deeply to read", file=path) from None
    try:
        order = _scene_nodes(doc)
        _check_budget(doc, order, path, len(data), len(binary))
        parts, colors = _gltf_parts(doc, order, binary)
    except CadpipeError:
        raise
    except (KeyError, IndexError, TypeError, ValueError) as exc:
        raise MeshError(f"malformed glTF ({type(exc).__name__}: {exc})",
                        file=path) from None
    to_z_up = np.eye(4)
    to_z_up[:3, :3] = TO_Y_UP["Z"].T
    taken, scene_parts = set(), []
    for name, vertices, world, faces, labels, names in parts:
        # one pass from the file's float32 to Z-up world float64 (inf/NaN: file_mesh
        # names the part)
        vertices = placed_points(vertices, to_z_up @ world)
        mesh = file_mesh(vertices, faces, path, name, face_part=labels,
                         part_names=names, attributes={"source": str(path), "units": "m"})
        scene_parts.append(ScenePart(unique_name(name, taken), mesh))
    if not scene_parts:
        raise MeshError("the file holds no triangles", file=path)
    return Scene(name=FilePath(path).stem, parts=tuple(scene_parts), units="m",
                 colors=MappingProxyType(colors))


def _scene_nodes(doc):
    """Indices of the nodes of the scene shown, parents first, checked to form trees
    (as glTF requires): a node listed twice or in a cycle would be read many times
    over, or forever."""
    nodes = doc.get("nodes", [])
    scene = doc.get("scenes", [{"nodes": list(range(len(nodes)))}])[doc.get("scene", 0)]
    order, seen = [], set()
    stack = list(reversed(scene.get("nodes", [])))
    while stack:
        index = stack.pop()
        if not isinstance(index, int) or index < 0 or index in seen:
            raise ValueError(f"node {shown(index)} is reached twice: the nodes do not form "
                             "trees")
        seen.add(index)
        order.append(index)
        stack.extend(reversed(nodes[index].get("children", [])))
    return order


def _check_budget(doc, order, path, size, stored):
    """Refuse a GLB that would expand past :mod:`cadpipe.limits`' budgets, from the
    counts its accessors declare, before any array is read; and one whose buffer or
    views claim more bytes than its binary chunk holds (``stored``)."""
    claimed = max([b.get("byteLength", 0) for b in doc.get("buffers", [])[:1]] +
                  [v.get("byteOffset", 0) + v["byteLength"] for v in doc.get("bufferViews", [])
                   if v.get("buffer", 0) == 0], default=0)
    if not claimed <= stored:
        raise MeshError(f"truncated: its buffers claim {shown(claimed)} bytes, its binary "
                        f"chunk holds {stored:,}", file=path)
    nodes, meshes, accessors = doc.get("nodes", []), doc.get("meshes", []), \
        doc.get("accessors", [])
    triangles = points = 0
    for index in order:
        if "mesh" not in nodes[index]:
            continue
        for primitive in meshes[nodes[index]["mesh"]].get("primitives", []):
            position = accessors[primitive["attributes"]["POSITION"]]["count"]
            corners = accessors[primitive["indices"]]["count"] if "indices" in primitive \
                else position
            triangles, points = triangles + corners // 3, points + position
    unpacked = 24 * (triangles + points)          # float64 points, int64 corner indices
    limits.check("max_triangles", triangles, "reading this GLB file", file=path)
    limits.check("max_unpacked_bytes", unpacked, "reading this GLB file", file=path)
    if unpacked > (1 << 20):
        limits.check("max_expansion", unpacked / max(size, 1),
                     "this GLB file (its nodes repeat its meshes)", file=path)


def _gltf_parts(doc, order, binary):
    """[(name, vertices, world matrix, faces, labels, label names)] and {label name: rgb}
    of a glTF doc's nodes ``order`` (see :func:`_scene_nodes`); the vertices as the
    file stores them, in the node's frame."""
    nodes, meshes = doc.get("nodes", []), doc.get("meshes", [])
    parts, colors, worlds = [], {}, {}
    parent = {child: index for index in order for child in nodes[index].get("children", [])}
    for index in order:                       # depth first, in the file's order
        node = nodes[index]
        world = worlds[index] = (worlds[parent[index]] if index in parent else np.eye(4)) \
            @ _node_matrix(node)
        if "mesh" not in node:
            continue
        mesh = meshes[node["mesh"]]
        pieces, names = [], []
        for primitive in mesh.get("primitives", []):
            if primitive.get("mode", 4) != 4:
                continue                     # points and lines hold no triangles
            vertices = _accessor(doc, binary, primitive["attributes"]["POSITION"])
            if vertices.shape[1:] != (3,):
                raise ValueError("a POSITION accessor is not VEC3")
            faces = (_accessor(doc, binary, primitive["indices"]) if "indices" in primitive
                     else np.arange(len(vertices))).astype(np.int64).reshape(-1, 3)
            material = doc.get("materials", [])[primitive["material"]] \
                if "material" in primitive else {}
            label = material.get("name") or node.get("name") or mesh.get("name") or "mesh"
            factor = material.get("pbrMetallicRoughness", {}).get("baseColorFactor")
            if factor is not None:
                colors.setdefault(label, tuple(float(c) for c in factor[:3]))
            if label not in names:
                names.append(label)
            pieces.append((vertices, faces, names.index(label)))
        if not pieces:
            continue
        if len(pieces) == 1:                     # one primitive: its arrays as they are
            vertices, faces, _ = pieces[0]
        else:
            if any(len(f) and f.max() >= len(v) for v, f, _ in pieces):
                raise ValueError("a primitive's indices point past its vertices")
            offsets = np.cumsum([0] + [len(v) for v, _, _ in pieces[:-1]])
            vertices = np.concatenate([v for v, _, _ in pieces])
            faces = np.concatenate([f + o for (_, f, _), o in zip(pieces, offsets)])
        if np.linalg.det(world[:3, :3]) < 0:
            faces = faces[:, ::-1]
        labels = np.repeat(np.array([k for _, _, k in pieces], np.int32),
                           [len(f) for _, f, _ in pieces]) if len(names) > 1 else \
            np.zeros(len(faces), np.int32)
        parts.append((node.get("name") or mesh.get("name") or "mesh", vertices, world, faces,
                      labels, tuple(names)))
    return parts, colors


def _node_matrix(node):
    """A node's local 4x4 matrix from ``matrix`` or translation / rotation / scale."""
    if "matrix" in node:
        return np.array(node["matrix"], dtype=np.float64).reshape(4, 4).T
    x, y, z, w = node.get("rotation", [0.0, 0.0, 0.0, 1.0])
    rotation = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                         [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                         [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    matrix = np.eye(4)
    matrix[:3, :3] = rotation * np.asarray(node.get("scale", [1.0, 1.0, 1.0]))
    matrix[:3, 3] = node.get("translation", [0.0, 0.0, 0.0])
    return matrix


def _accessor(doc, binary, index):
    """An accessor's elements as an (N, width) or (N,) array: a read-only view of the
    file's bytes."""
    accessor = doc["accessors"][index]
    dtype = np.dtype(_COMPONENTS[accessor["componentType"]]).newbyteorder("<")
    width, count = _WIDTH[accessor["type"]], accessor["count"]
    view = doc["bufferViews"][accessor["bufferView"]]
    start = view.get("byteOffset", 0) + accessor.get("byteOffset", 0)
    stride = view.get("byteStride") or dtype.itemsize * width
    rows = np.ndarray((count, width), dtype, buffer=binary, offset=start,
                      strides=(stride, dtype.itemsize))
    return rows[:, 0] if width == 1 else rows
