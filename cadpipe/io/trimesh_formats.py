"""GLB, OBJ and PLY through trimesh's exporters.

- **GLB** (VR, web viewers) keeps the scene: a root node named after the scene,
  one node per part with its transform (a part with several colours, a union,
  gets a child node per colour), and a PBR material per colour. glTF is Y-up and in
  metres by definition, so the root node carries the change from the scene's up axis
  and units; a viewer shows the part upright and
  life-size. Normals follow the crease angle (hard caps, smooth tubes).
- **OBJ** and **PLY** hold one mesh: every part in world coordinates, in the
  scene's units and axes. PLY carries per-face colours; OBJ only geometry (colour
  in OBJ needs a side-car .mtl file, which would break the one-file, atomic write).
"""

import numpy as np

from cadpipe._validate import as_choice
from cadpipe.io.scene import as_scene
from cadpipe.io.files import atomic_path, unique_name
from cadpipe.io.flatten import flatten, labelled
from cadpipe.io.normals import DEFAULT_CREASE_ANGLE, split_for_normals

#: scene up axis -> rotation onto glTF's +Y up
_TO_Y_UP = {"Z": np.array([[1.0, 0, 0], [0, 0, 1], [0, -1, 0]]), "Y": np.eye(3)}


def write_glb(obj, path, *, crease_angle=DEFAULT_CREASE_ANGLE):
    """Write ``obj`` (Mesh, Pipe, Assembly or Scene) as binary glTF, atomically."""
    import trimesh
    from trimesh.exchange.gltf import export_glb

    scene = as_scene(obj)
    out = trimesh.Scene()
    root = scene.name
    out.graph.update(frame_from=out.graph.base_frame, frame_to=root, matrix=gltf_root(scene))
    names = {root}
    for part in scene.parts:
        node = unique_name(part.name, names)
        matrix = np.eye(4) if part.transform is None else np.asarray(part.transform, float)
        pieces = _colored_pieces(labelled(scene, part), crease_angle)
        if len(pieces) == 1:     # one colour: the part's node holds the geometry itself
            out.add_geometry(pieces[0][1], node_name=node, geom_name=node,
                             parent_node_name=root, transform=matrix)
            continue
        out.graph.update(frame_from=root, frame_to=node, matrix=matrix)
        for name, piece in pieces:
            child = unique_name(f"{node}/{name}", names)
            out.add_geometry(piece, node_name=child, geom_name=child, parent_node_name=node)
    data = export_glb(out, include_normals=True)
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)


def _colored_pieces(painted, crease_angle):
    """[(label, trimesh.Trimesh)]: one piece per used label, with a PBR material of its colour."""
    import trimesh

    vertices, faces, normals = split_for_normals(painted.mesh, crease_angle)
    pieces = []
    for label, (name, rgb) in enumerate(zip(painted.names, painted.colors)):
        picked = faces[painted.labels == label]
        if len(picked) == 0:
            continue
        used, local = np.unique(picked, return_inverse=True)
        material = trimesh.visual.material.PBRMaterial(
            name=name, baseColorFactor=[*map(float, rgb), 1.0], metallicFactor=0.0,
            roughnessFactor=0.5)
        pieces.append((name, trimesh.Trimesh(
            vertices[used], local.reshape(-1, 3), vertex_normals=normals[used], process=False,
            visual=trimesh.visual.TextureVisuals(material=material))))
    return pieces


def gltf_root(scene):
    """4x4 matrix from the scene's axes and units to glTF's (+Y up, metres)."""
    matrix = np.eye(4)
    up = as_choice(str(scene.up_axis).upper(), "up_axis", tuple(_TO_Y_UP))
    matrix[:3, :3] = _TO_Y_UP[up] * scene.meters_per_unit
    return matrix


def write_obj(obj, path):
    """Write ``obj`` as Wavefront OBJ (geometry only, world coordinates), atomically."""
    from trimesh.exchange.obj import export_obj

    scene = as_scene(obj)
    text = export_obj(flatten(scene).mesh.to_trimesh(), include_normals=False, include_color=False,
                      include_texture=False, digits=9, header=f"cadpipe: {scene.name}")
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def write_ply(obj, path, *, ascii=False):
    """Write ``obj`` as PLY with per-face colours (binary unless ``ascii``), atomically."""
    from trimesh.exchange.ply import export_ply

    painted = flatten(as_scene(obj))
    tm = painted.mesh.to_trimesh()
    rgb = np.round(painted.colors[painted.labels] * 255)
    tm.visual.face_colors = np.column_stack([rgb, np.full(len(rgb), 255)]).astype(np.uint8)
    data = export_ply(tm, encoding="ascii" if ascii else "binary", vertex_normal=False,
                      include_attributes=False)
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)

