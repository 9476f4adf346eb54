"""STL for 3D printing: binary by default, ASCII on request, written from numpy.

STL has no units, names or colours: every part of the scene goes into one
triangle soup in world coordinates. Slicers (PrusaSlicer, Cura, ...) read STL
as millimetres, so it is written in millimetres unless ``units`` says
otherwise. Records are built and written a block at a time: the file costs
no memory beyond one block. Corners are cast to float32 first and the
facet normals are computed from those float32 corners, so each record's normal
matches the triangle the file actually holds.
"""

from pathlib import Path as FilePath

import numpy as np

from cadpipe import limits
from cadpipe.core import formats
from cadpipe.io.files import atomic_path, file_mesh, read_trimesh
from cadpipe.io.flatten import flatten
from cadpipe.solids.scene import Scene, ScenePart, as_scene

_RECORD = np.dtype([("normal", "<f4", 3), ("corners", "<f4", (3, 3)), ("attr", "<u2")])
#: faces per block of :func:`_blocks` (its temporaries fit in L2 cache)
_BLOCK = 1 << 16


@formats.writer("stl")
def write_stl(obj, path, *, ascii=False, units="mm", layout="scene"):
    """Write ``obj`` (Mesh, Pipe, Assembly or Scene) as STL, atomically.

    Parameters
    ----------
    ascii : bool
        Write the text form (about 5x larger and slower to read) instead of binary.
    units : str
        Length unit of the file's coordinates (a key of ``cadpipe.core.units.UNITS``);
        millimetres, as slicers read STL.
    layout : {"scene", "print"}
        See :func:`~cadpipe.solids.scene.as_scene`.
    """
    scene = as_scene(obj, layout=layout)
    mesh = flatten(scene, scene.scale_to(units)).mesh
    with atomic_path(path) as tmp, open(tmp, "w" if ascii else "wb") as fh:
        if ascii:
            solid = "".join(c if c.isalnum() or c in "-_." else "_" for c in scene.name)
            fh.write(f"solid {solid or 'cadpipe'}\n")
        else:
            header = f"binary STL from cadpipe ({units}): {scene.name}"
            fh.write(header.encode("ascii", "replace")[:80].ljust(80, b" "))
            fh.write(np.uint32(len(mesh.faces)).tobytes())
        for records in _blocks(mesh.vertices, mesh.faces):
            fh.write(_ascii(records) if ascii else records.data)
        if ascii:
            fh.write(f"endsolid {solid or 'cadpipe'}\n")


def _blocks(vertices, faces):
    """Binary STL records (float32 unit normal, three float32 corners, zero attribute),
    a block of faces at a time.

    The corners are gathered straight into the records and the normals computed
    from them there, so the temporaries stay in the CPU cache: a million
    triangles take a few tens of milliseconds.
    """
    v32 = np.asarray(vertices, dtype=np.float32)
    records = np.empty(min(len(faces), _BLOCK), dtype=_RECORD)
    for start in range(0, len(faces), _BLOCK):
        block = faces[start:start + _BLOCK]
        _fill(v32, block, records[:len(block)])
        yield records[:len(block)]


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


def _ascii(records):
    rows = np.concatenate([records["normal"][:, None, :], records["corners"]], axis=1)
    facet = ("facet normal {:.9g} {:.9g} {:.9g}\n outer loop\n"
             "  vertex {:.9g} {:.9g} {:.9g}\n  vertex {:.9g} {:.9g} {:.9g}\n"
             "  vertex {:.9g} {:.9g} {:.9g}\n endloop\nendfacet\n")
    return (facet * len(rows)).format(*rows.ravel().tolist())


@formats.reader("stl")
def read_stl(path):
    """An STL file as a one-part :class:`~cadpipe.solids.scene.Scene` in millimetres (as
    slicers read STL; ``units_assumed``): binary STL read here, ASCII STL by trimesh."""
    path = FilePath(path)                  # 50 bytes a triangle in binary, more in text
    limits.check("max_triangles", path.stat().st_size / 50, "this STL file", file=path)
    return read_binary_stl(path) or read_trimesh(path)


def read_binary_stl(path):
    """A binary STL file as a one-part :class:`~cadpipe.solids.scene.Scene` in
    millimetres, or None when it is not binary STL (its size is not 84 + 50 bytes per
    triangle).

    The records are read straight into numpy; every corner is its own vertex until
    :func:`~cadpipe.io.files.file_mesh` welds them.
    """
    path = FilePath(path)
    size = path.stat().st_size
    with open(path, "rb") as fh:
        head = fh.read(84)
        if len(head) < 84 or size != 84 + 50 * int(np.frombuffer(head[80:84], "<u4")[0]):
            return None
        records = np.fromfile(fh, dtype=_RECORD)
    vertices = records["corners"].reshape(-1, 3)
    faces = np.arange(len(vertices), dtype=np.int64).reshape(-1, 3)
    mesh = file_mesh(vertices, faces, path, path.stem,
                     attributes={"source": str(path), "units": "mm", "units_assumed": True})
    return Scene(name=path.stem, parts=(ScenePart(path.stem, mesh),), units="mm")
