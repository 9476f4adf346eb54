"""STL for 3D printing: binary by default, ASCII on request, written from numpy in one go.

STL has no units, names or colours: every part of the scene goes into one
triangle soup in world coordinates. Corners are cast to float32 first and the
facet normals are computed from those float32 corners, so each record's normal
matches the triangle the file actually holds.
"""

import numpy as np

from cadpipe.io.scene import as_scene
from cadpipe.io.files import atomic_path
from cadpipe.io.flatten import flatten

_RECORD = np.dtype([("normal", "<f4", 3), ("corners", "<f4", (3, 3)), ("attr", "<u2")])
#: faces per block of :func:`stl_records` (its temporaries fit in L2 cache)
_BLOCK = 1 << 16


def write_stl(obj, path, *, ascii=False):
    """Write ``obj`` (Mesh, Pipe, Assembly or Scene) as STL, atomically.

    Parameters
    ----------
    ascii : bool
        Write the text form (about 5x larger and slower to read) instead of binary.
    """
    scene = as_scene(obj)
    mesh = flatten(scene).mesh
    records = stl_records(mesh.vertices, mesh.faces)
    with atomic_path(path) as tmp:
        if ascii:
            _write_ascii(records, tmp, scene.name)
        else:
            header = f"binary STL from cadpipe: {scene.name}".encode("ascii", "replace")[:80]
            with open(tmp, "wb") as fh:
                fh.write(header.ljust(80, b" "))
                fh.write(np.uint32(len(records)).tobytes())
                fh.write(records.data)


def stl_records(vertices, faces):
    """(F,) binary STL records: float32 unit normal, three float32 corners, zero attribute.

    The corners are gathered straight into the records and the normals computed
    from them there, a block of faces at a time so the temporaries stay in the
    CPU cache: a million triangles take a few tens of milliseconds.
    """
    v32 = np.asarray(vertices, dtype=np.float32)
    records = np.empty(len(faces), dtype=_RECORD)
    for start in range(0, len(faces), _BLOCK):
        _fill(v32, faces[start:start + _BLOCK], records[start:start + _BLOCK])
    return records


def _fill(v32, faces, records):
    corners = records["corners"]                            # (F, 3, 3) view, 50-byte rows
    np.take(v32, faces, axis=0, out=corners, mode="wrap")   # faces are in range: no wrap
    u, v = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    cross = (u[:, 1] * v[:, 2] - u[:, 2] * v[:, 1], u[:, 2] * v[:, 0] - u[:, 0] * v[:, 2],
             u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0])
    length = np.sqrt(cross[0] ** 2 + cross[1] ** 2 + cross[2] ** 2)
    length[length == 0] = 1.0                               # degenerate facet: zero normal
    normal = records["normal"]
    for axis in range(3):
        np.divide(cross[axis], length, out=normal[:, axis])
    records["attr"] = 0


def _write_ascii(records, tmp, name):
    rows = np.concatenate([records["normal"][:, None, :], records["corners"]], axis=1)
    facet = ("facet normal {:.9g} {:.9g} {:.9g}\n outer loop\n"
             "  vertex {:.9g} {:.9g} {:.9g}\n  vertex {:.9g} {:.9g} {:.9g}\n"
             "  vertex {:.9g} {:.9g} {:.9g}\n endloop\nendfacet\n")
    body = (facet * len(rows)).format(*rows.ravel().tolist())
    solid = "".join(c if c.isalnum() or c in "-_." else "_" for c in name) or "cadpipe"
    with open(tmp, "w", encoding="ascii") as fh:
        fh.write(f"solid {solid}\n{body}endsolid {solid}\n")
