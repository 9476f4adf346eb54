"""What Blender makes of a file: run by Blender's own Python (the ``bpy`` module).

    .tools/blender/bin/python tests/blender_probe.py OUT FILE [FILE ...]

Each FILE (.glb through Blender's glTF importer, .usd* through its USD importer, with
their default options, as a user's File > Import does) goes into an empty scene; then
OUT/<file name>.json holds, per mesh object, its parent and its materials (name, base
colour), and OUT/<file name>.npz, per object, its corners in world space in loop order
(``<name>/corners``: positions, ``<name>/normals``: the shading normals Blender draws),
its polygons' loop starts and the number of polygons on each of its edges
(``<name>/loop_start``, ``<name>/edge_faces``). ``tests/test_consumers.py`` runs it.
"""

import json
import sys
from pathlib import Path

import bpy
import numpy as np


def import_file(path):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    if path.suffix == ".glb":
        bpy.ops.import_scene.gltf(filepath=str(path))
    else:
        bpy.ops.wm.usd_import(filepath=str(path))


def base_colour(material):
    bsdf = next(n for n in material.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
    return list(bsdf.inputs["Base Color"].default_value)[:3]


def corners(obj):
    """World positions and normals of ``obj``'s corners, in loop order."""
    mesh = obj.data
    co = np.empty(3 * len(mesh.vertices))
    mesh.vertices.foreach_get("co", co)
    vertex = np.empty(len(mesh.loops), np.int64)
    mesh.loops.foreach_get("vertex_index", vertex)
    normals = np.empty(3 * len(mesh.loops))
    mesh.corner_normals.foreach_get("vector", normals)
    matrix = np.array(obj.matrix_world)
    points = co.reshape(-1, 3)[vertex] @ matrix[:3, :3].T + matrix[:3, 3]
    turned = normals.reshape(-1, 3) @ np.linalg.inv(matrix[:3, :3])   # inverse transpose
    return points, turned / np.linalg.norm(turned, axis=1, keepdims=True)


def probe(path, out):
    import_file(path)
    objects, arrays = {}, {}
    for obj in bpy.data.objects:
        if obj.type != "MESH":
            continue
        mesh = obj.data
        objects[obj.name] = {
            "parent": obj.parent.name if obj.parent else None,
            "materials": [[m.name, base_colour(m)] for m in mesh.materials if m]}
        points, normals = corners(obj)
        loop_start = np.empty(len(mesh.polygons), np.int64)
        mesh.polygons.foreach_get("loop_start", loop_start)
        edge = np.empty(len(mesh.loops), np.int64)
        mesh.loops.foreach_get("edge_index", edge)
        arrays.update({f"{obj.name}/corners": points, f"{obj.name}/normals": normals,
                       f"{obj.name}/loop_start": loop_start,
                       f"{obj.name}/edge_faces": np.bincount(edge, minlength=len(mesh.edges))})
    (out / f"{path.name}.json").write_text(json.dumps(objects))
    np.savez(out / f"{path.name}.npz", **arrays)


if __name__ == "__main__":
    folder = Path(sys.argv[1])
    for name in sys.argv[2:]:
        probe(Path(name), folder)
