"""Previews a person looks at: a PNG picture and a self-contained 3D web page.

Both read a :class:`~cadpipe.solids.scene.Scene` (a Mesh, Pipe or Assembly via
:func:`~cadpipe.solids.scene.as_scene`), colour every part the same way and can
highlight parts (colliding ones, say) in a colour nothing else uses.

- :func:`render_png` draws offscreen with :mod:`cadpipe.io.raster` (numpy, no GPU
  or display needed) and flat Lambert + ambient shading, outlines parts and
  silhouettes, and traces highlighted parts even where others hide them.
- :func:`write_html` embeds the scene as base64 GLB in trimesh's three.js viewer
  page (three.js and its loaders are inlined in trimesh's package data, so the
  page opens without network access) beside a table of parts and a report.
"""

import base64
import html
import json
from collections.abc import Mapping
from pathlib import Path as FilePath

import numpy as np

from cadpipe._validate import as_choice, as_int
from cadpipe.errors import InputError
from cadpipe.io.files import atomic_path
from cadpipe.geometry.mesh import Mesh
from cadpipe.io.raster import rasterize
from cadpipe.core.color import parse_color
from cadpipe.core.transform import placed_points
from cadpipe.solids.scene import as_scene

#: named camera directions as (azimuth, elevation) in degrees; azimuth from +X
#: towards +Y about the up axis, so "front" looks along +Y from -Y
VIEWS = {"iso": (-60.0, 25.0), "front": (-90.0, 0.0), "back": (90.0, 0.0),
         "right": (0.0, 0.0), "left": (180.0, 0.0), "top": (-90.0, 90.0),
         "bottom": (-90.0, -90.0)}

#: part colours when a part has none (Tableau 10 without its red, kept for highlights)
PALETTE = tuple(parse_color(c) for c in (
    "#4e79a7", "#f28e2b", "#59a14f", "#76b7b2", "#edc948", "#b07aa1", "#9c755f",
    "#bab0ac", "#ff9da7"))
HIGHLIGHT = parse_color("#ff1744")

AMBIENT, DIFFUSE = 0.45, 0.55
LIGHT = np.array([-0.35, 0.55, 0.76]) / np.linalg.norm([-0.35, 0.55, 0.76])  # camera frame
SUPERSAMPLE = 2          # rendered at 2x and downsampled: smooth edges ...
CANVAS = 1 << 24         # ... unless that canvas would pass 16M pixels (memory, time)
MARGIN = 0.07            # free border around the scene, as a fraction of the image


# -- what to draw -----------------------------------------------------------------
class _Labelled:
    """The scene as one world-space mesh whose faces are labelled with part names.

    A face's label is its mesh's own part label (``Mesh.part_names``, which
    survives booleans) or else its scene part's name. Highlighting a scene part
    marks all its labels. ``solid`` marks the faces of closed, outward parts,
    whose back faces the picture can skip.
    """

    def __init__(self, scene, highlight):
        meshes, colors, marked, known = [], {}, set(), set()
        for part in scene.parts:
            mesh = part.world_mesh()
            if mesh.face_part is None:
                mesh = mesh.with_parts((part.name,))
            meshes.append(mesh)
            for name in mesh.part_names:
                colors.setdefault(name, _color_of(scene, part, name, len(colors)))
            if part.name in highlight:
                marked.update(mesh.part_names)
            known.update(mesh.part_names, (part.name,))
        unknown = sorted(set(highlight) - known)
        if unknown:
            raise InputError(f"highlight: no part named {', '.join(map(repr, unknown))}; "
                             f"the parts are {', '.join(map(repr, sorted(known)))}")
        self.mesh = Mesh.concatenate(meshes)
        # faces of closed, outward parts: their back faces can never be seen
        self.solid = np.repeat([m.is_outward for m in meshes], [len(m.faces) for m in meshes])
        if len(self.mesh.faces) == 0:
            raise InputError(f"scene {scene.name!r}: no triangles to preview")
        self.names = self.mesh.part_names
        self.colors = np.array([colors[n] for n in self.names], dtype=np.float64)
        self.marked = np.array([n in marked or n in highlight for n in self.names])

    def pieces(self):
        """``(name, vertices, faces)`` per label, vertices renumbered per piece."""
        for label, name in enumerate(self.names):
            used, faces = np.unique(self.mesh.faces[self.mesh.face_part == label],
                                    return_inverse=True)
            yield name, self.mesh.vertices[used], faces.reshape(-1, 3)

    def color(self, label):
        """Display colour of each label: highlighted ones in :data:`HIGHLIGHT`."""
        return np.where(self.marked[label, None], HIGHLIGHT, self.colors[label])


def _color_of(scene, part, name, index):
    if name in scene.colors:
        return tuple(scene.colors[name])
    if part.color is not None:
        return tuple(part.color)
    return PALETTE[index % len(PALETTE)]


# -- camera ---------------------------------------------------------------------------
#: world coordinates of a Y-up scene expressed in the Z-up frame the views are defined in
_Y_UP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


def view_rotation(view="iso", up_axis="Z"):
    """Rotation from world to camera coordinates: x right, y up, z towards the viewer.

    Parameters
    ----------
    view : str or (float, float)
        A name in :data:`VIEWS` or ``(azimuth, elevation)`` in degrees.
    up_axis : {"Z", "Y"}
        The scene's up axis, shown pointing up the picture.
    """
    if isinstance(view, str):
        azimuth, elevation = VIEWS[as_choice(view, "view", tuple(VIEWS))]
    else:
        try:
            azimuth, elevation = (float(a) for a in view)
        except (TypeError, ValueError):
            raise InputError(f"view: expected one of {', '.join(VIEWS)} or "
                             f"(azimuth, elevation) in degrees, got {view!r}") from None
        if not np.isfinite([azimuth, elevation]).all():
            raise InputError(f"view: angles must be finite, got {view!r}")
    az, el = np.radians([azimuth, elevation])
    toward = np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
    right = np.array([-np.sin(az), np.cos(az), 0.0])
    rotation = np.array([right, np.cross(toward, right), toward])
    if as_choice(up_axis, "up_axis", ("Z", "Y")) == "Y":
        rotation = rotation @ _Y_UP
    return rotation


# -- the picture ------------------------------------------------------------------------
def render_png(scene, path, *, size=(960, 720), highlight=(), view="iso"):
    """Draw ``scene`` into a PNG file, offscreen.

    Parts are flat-shaded in their colours (Lambert + ambient), outlined where
    parts or depths meet, with a legend, the axes and a caption. Parts named in
    ``highlight`` are drawn in :data:`HIGHLIGHT` while the others fade, and their
    outline is traced even where other parts hide them, so a collision is seen.

    Parameters
    ----------
    scene : Scene, Assembly, Mesh or Pipe
    path : str or pathlib.Path
        A ``.png`` file, written whole or not at all.
    size : (int, int)
        Width and height in pixels.
    highlight : iterable of str
        Part names (scene parts or labels of a unioned mesh) to draw as striking.
    view : str or (float, float)
        See :func:`view_rotation`.

    Returns
    -------
    pathlib.Path
    """
    from PIL import Image

    scene = as_scene(scene)
    path = _output_path(path, ".png", "preview image")
    width, height = (as_int(n, f"size[{i}]", low=16, high=4096)
                     for i, n in enumerate(_pair(size, "size")))
    drawn = _Labelled(scene, _names(highlight))
    rotation = view_rotation(view, scene.up_axis)
    factor = SUPERSAMPLE if width * height * SUPERSAMPLE ** 2 <= CANVAS else 1
    pixels = _shade(drawn, rotation, width * factor, height * factor)
    picture = Image.fromarray(pixels).resize((width, height), Image.Resampling.BOX)
    _annotate(picture, drawn, rotation, scene)
    with atomic_path(path) as tmp:
        picture.save(tmp, format="PNG")
    return path


def _shade(drawn, rotation, width, height):
    """(height, width, 3) uint8 shaded picture of ``drawn`` seen through ``rotation``."""
    from scipy.ndimage import binary_dilation

    mesh = drawn.mesh
    turn = np.eye(4)
    turn[:3, :3] = rotation
    camera = placed_points(mesh.vertices, turn)
    used = camera[np.bincount(mesh.faces.ravel(), minlength=len(camera)) > 0]
    lo, hi = used.min(axis=0), used.max(axis=0)
    extent = np.maximum(hi - lo, 1e-6 * max((hi - lo).max(), 1e-9))   # flat or tiny scenes
    scale = min(width * (1 - 2 * MARGIN) / extent[0], height * (1 - 2 * MARGIN) / extent[1])
    middle = (lo + hi) / 2
    screen = np.column_stack([width / 2 + (camera[:, 0] - middle[0]) * scale,
                              height / 2 - (camera[:, 1] - middle[1]) * scale,
                              (middle[2] - camera[:, 2]) * scale])      # depth in pixels
    normals = np.array(placed_points(mesh.face_normals, turn))     # shaded in place below
    drawn_faces = np.flatnonzero(~drawn.solid | (normals[:, 2] > 0))   # skip hidden backs
    index, depth = rasterize(screen[mesh.faces[drawn_faces]], width, height)
    index = np.where(index >= 0, drawn_faces[index], -1)

    normals *= np.where(normals[:, 2:] < 0, -1.0, 1.0)                  # lit from both sides
    light = AMBIENT + DIFFUSE * np.clip(normals @ LIGHT, 0.0, 1.0)
    label = mesh.face_part
    base = drawn.color(label)
    if drawn.marked.any():
        base = np.where(drawn.marked[label, None], base, 0.5 * base + 0.5 * 0.88)
    face_rgb = _bytes(base * light[:, None])

    covered = index >= 0
    rgb = np.where(covered[..., None], face_rgb[index], _background(height)[:, None, :])
    seen = np.where(covered, label[index], -1)
    edge = _outline(seen, depth, jump=0.02 * np.ptp(screen[:, :2], axis=0).max())
    rgb[edge] = rgb[edge] * 3 // 10

    if drawn.marked.any():
        # trace highlighted parts whole: tinted where others hide them, ringed outside
        marked = drawn_faces[drawn.marked[label[drawn_faces]]]
        silhouette = rasterize(screen[mesh.faces[marked]], width, height)[0] >= 0
        hidden = silhouette & ~(covered & drawn.marked[seen])
        rgb[hidden] = _bytes(0.55 / 255 * rgb[hidden] + 0.45 * np.array(HIGHLIGHT))
        ring = max(2, round(height / 360))
        rgb[binary_dilation(silhouette, iterations=ring) & ~silhouette] = \
            _bytes(HIGHLIGHT)
    return rgb


def _bytes(rgb):
    """Colours in [0, 1] as uint8."""
    return (np.clip(rgb, 0.0, 1.0) * 255 + 0.5).astype(np.uint8)


def _outline(seen, depth, jump):
    """Pixels beside a change of part or a depth step larger than ``jump``."""
    edge = np.zeros(seen.shape, bool)
    with np.errstate(invalid="ignore"):                                # inf - inf: background
        for axis in (0, 1):
            change = (np.diff(seen, axis=axis) != 0) | (np.abs(np.diff(depth, axis=axis)) > jump)
            before = (slice(None), slice(None))[:axis] + (slice(None, -1),)
            after = (slice(None), slice(None))[:axis] + (slice(1, None),)
            edge[before] |= change
            edge[after] |= change
    return edge


def _background(height):
    """Colour of each row: a soft vertical gradient, light at the top."""
    t = np.linspace(0.0, 1.0, height)[:, None]
    top, bottom = np.array([0.97, 0.98, 1.0]), np.array([0.84, 0.86, 0.9])
    return _bytes(top + t * (bottom - top))


def _annotate(picture, drawn, rotation, scene):
    """Legend (top left), axes (bottom left) and caption (bottom right), drawn in place."""
    from PIL import ImageDraw, ImageFont

    draw = ImageDraw.Draw(picture)
    font = ImageFont.load_default(size=max(11, picture.height // 48))
    line = font.size + 6
    shown = drawn.names[:16]
    for row, name in enumerate(shown):
        y = 10 + row * line
        color = drawn.color(row)
        draw.rectangle([10, y, 10 + font.size, y + font.size], fill=_rgb255(color),
                       outline=(40, 40, 40))
        text = f"{name}  (highlighted)" if drawn.marked[row] else name
        draw.text((16 + font.size, y - 1), text, font=font, fill=(30, 30, 30))
    if len(drawn.names) > len(shown):
        draw.text((10, 10 + len(shown) * line), f"... and {len(drawn.names) - len(shown)} "
                  "more parts", font=font, fill=(30, 30, 30))

    origin = np.array([14 + 2 * line, picture.height - 14 - 2 * line])
    for axis, (name, color) in enumerate((("X", (200, 40, 40)), ("Y", (40, 150, 60)),
                                          ("Z", (40, 90, 200)))):
        tip = origin + 1.6 * line * np.array([1.0, -1.0]) * rotation[:2, axis]
        draw.line([tuple(origin), tuple(tip)], fill=color, width=2)
        draw.text(tuple(tip + (2, -font.size // 2)), name, font=font, fill=color)

    caption = (f"{scene.name}  ·  {len(drawn.names)} part{'s' * (len(drawn.names) != 1)}  ·  "
               f"{len(drawn.mesh.faces):,} triangles  ·  units: {scene.units}")
    box = draw.textbbox((0, 0), caption, font=font)
    draw.text((picture.width - box[2] - 10, picture.height - box[3] - 8), caption, font=font,
              fill=(70, 70, 70))


def _rgb255(color):
    return tuple(int(round(255 * c)) for c in color)


# -- arguments --------------------------------------------------------------------------
def _pair(value, name):
    try:
        first, second = value
    except (TypeError, ValueError):
        raise InputError(f"{name}: expected (width, height), got {value!r}") from None
    return first, second


def _names(highlight):
    if isinstance(highlight, str):
        return (highlight,)
    try:
        return tuple(str(n) for n in highlight)
    except TypeError:
        raise InputError(f"highlight: expected part names, got {highlight!r}") from None


def _output_path(path, suffix, what):
    path = FilePath(path)
    if path.suffix.lower() != suffix:
        raise InputError(f"{path}: a {what} is written as {suffix}; give a path ending "
                         f"in {suffix}")
    return path


# -- the web page -------------------------------------------------------------------------
def write_html(scene, path, *, report=None, highlight=(), view="iso"):
    """Write a self-contained page that shows ``scene`` in 3D beside a report.

    The scene is embedded as base64 GLB in trimesh's three.js viewer (drag to
    rotate, scroll to zoom, right-drag to pan), which inlines three.js, so the
    page needs no network. The viewer runs in a ``srcdoc`` frame
    beside a panel listing the parts in their colours and ``report``.

    Parameters
    ----------
    scene : Scene, Assembly, Mesh or Pipe
    path : str or pathlib.Path
        An ``.html`` file, written whole or not at all.
    report : mapping, optional
        Shown as a table; nested values as JSON.
    highlight : iterable of str
        Part names to draw in :data:`HIGHLIGHT`, as in :func:`render_png`.
    view : str or (float, float)
        The starting camera direction, as in :func:`render_png`.

    Returns
    -------
    pathlib.Path
    """
    from trimesh import resources, util

    scene = as_scene(scene)
    path = _output_path(path, ".html", "preview page")
    if report is not None and not isinstance(report, Mapping):
        raise InputError(f"report: expected a mapping (dict), got {type(report).__name__}")
    drawn = _Labelled(scene, _names(highlight))
    template = util.decompress(resources.get_bytes("templates/viewer.zip"), file_type="zip")
    viewer = template["viewer.html.template"].read().decode("utf-8")
    glb = _glb(drawn, view, scene.up_axis)
    viewer = viewer.replace("$B64GLTF", base64.b64encode(glb).decode("ascii"))
    page = _PAGE.format(title=html.escape(scene.name), viewer=html.escape(viewer, quote=True),
                        parts=_parts_table(drawn), report=_report_html(report))
    with atomic_path(path) as tmp:
        tmp.write_text(page, encoding="utf-8")
    return path


def _glb(drawn, view, up_axis):
    """GLB bytes of the labelled scene for the viewer: one coloured node per part.

    glTF and three.js put +Y up, so a Z-up scene is turned to Y-up; it is also
    centred on the origin, where the viewer's headlight points. The camera looks
    from ``view`` with room to spare for any window shape.
    """
    import trimesh
    from trimesh.scene.cameras import look_at
    from trimesh.visual import TextureVisuals
    from trimesh.visual.material import PBRMaterial

    to_y_up = np.eye(3) if up_axis == "Y" else _Y_UP.T
    centre = drawn.mesh.bounds.mean(axis=0)
    tscene = trimesh.Scene()
    for label, (name, vertices, faces) in enumerate(drawn.pieces()):
        material = PBRMaterial(name=name, baseColorFactor=[*drawn.color(label), 1.0],
                               metallicFactor=0.0, roughnessFactor=0.6, doubleSided=True)
        tscene.add_geometry(trimesh.Trimesh((vertices - centre) @ to_y_up.T, faces,
                                            process=False,
                                            visual=TextureVisuals(material=material)),
                            node_name=name, geom_name=name)
    tscene.camera.z_near = 1e-3 * tscene.scale
    pose = np.eye(4)
    pose[:3, :3] = view_rotation(view, "Y").T      # camera axes in world coordinates
    tscene.camera_transform = look_at(trimesh.bounds.corners(tscene.bounds), (40.0, 40.0),
                                      rotation=pose)
    return tscene.export(file_type="glb")


def _parts_table(drawn):
    rows = []
    for label, name in enumerate(drawn.names):
        color = "#{:02x}{:02x}{:02x}".format(*_rgb255(drawn.color(label)))
        count = int(np.count_nonzero(drawn.mesh.face_part == label))
        mark = " <strong>highlighted</strong>" if drawn.marked[label] else ""
        rows.append(f'<tr><td><span class="swatch" style="background:{color}"></span>'
                    f"{html.escape(name)}{mark}</td><td>{count:,}</td></tr>")
    return "\n".join(rows)


def _report_html(report):
    if not report:
        return "<p>No report.</p>"
    rows = []
    for key, value in report.items():
        if isinstance(value, (str, int, float, bool)) or value is None:
            shown = html.escape(str(value))
        else:
            shown = f"<pre>{html.escape(json.dumps(value, indent=2, default=_plain))}</pre>"
        rows.append(f"<tr><th>{html.escape(str(key))}</th><td>{shown}</td></tr>")
    return f'<table class="report">{"".join(rows)}</table>'


def _plain(value):
    """JSON for numpy values and anything else a report may hold."""
    if isinstance(value, np.ndarray | np.generic):
        return value.tolist()
    return str(value)


_PAGE = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>{title} - cadpipe preview</title>
<style>
  html, body {{ margin: 0; height: 100%; font: 14px/1.4 system-ui, sans-serif; color: #222; }}
  body {{ display: flex; }}
  #viewer {{ flex: 1; border: 0; min-width: 0; height: 100%; }}
  aside {{ width: 340px; overflow: auto; padding: 12px 16px; background: #f4f5f7;
          border-left: 1px solid #ccd; box-sizing: border-box; }}
  h1 {{ font-size: 18px; margin: 0 0 4px; }}
  h2 {{ font-size: 15px; margin: 16px 0 6px; }}
  table {{ border-collapse: collapse; width: 100%; }}
  td, th {{ text-align: left; vertical-align: top; padding: 3px 6px;
           border-bottom: 1px solid #dde; }}
  pre {{ margin: 0; white-space: pre-wrap; font-size: 12px; }}
  .swatch {{ display: inline-block; width: 12px; height: 12px; margin-right: 6px;
            border: 1px solid #444; vertical-align: -1px; }}
  .hint {{ color: #666; margin: 0; }}
</style>
</head>
<body>
<iframe id="viewer" title="3D view" srcdoc="{viewer}"></iframe>
<aside>
<h1>{title}</h1>
<p class="hint">Drag to rotate, scroll to zoom, right-drag to pan.</p>
<h2>Parts</h2>
<table><tr><th>part</th><th>triangles</th></tr>
{parts}
</table>
<h2>Report</h2>
{report}
</aside>
</body>
</html>
"""
