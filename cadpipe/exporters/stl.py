"""Binary and ASCII STL, written from numpy in one go."""

import numpy as np

from . import as_mesh, atomic_path

_RECORD = np.dtype([("normal", "<f4", 3), ("corners", "<f4", (3, 3)), ("attr", "<u2")])


def write_stl(mesh, path, *, ascii=False):
    """Write ``mesh`` as STL (binary unless ``ascii=True``), atomically."""
    mesh = as_mesh(mesh)
    with atomic_path(path) as tmp:
        if ascii:
            _write_ascii(mesh, tmp)
        else:
            records = np.empty(len(mesh.faces), dtype=_RECORD)
            records["normal"] = mesh.face_normals
            records["corners"] = mesh.triangles
            records["attr"] = 0
            header = np.zeros(80, np.uint8)
            header[:7] = np.frombuffer(b"cadpipe", np.uint8)
            with open(tmp, "wb") as fh:
                fh.write(header.tobytes())
                fh.write(np.uint32(len(records)).tobytes())
                fh.write(records.tobytes())


def _write_ascii(mesh, tmp):
    rows = np.concatenate([mesh.face_normals[:, None, :], mesh.triangles], axis=1).reshape(-1, 12)
    facet = ("facet normal {:.9e} {:.9e} {:.9e}\n outer loop\n"
             "  vertex {:.9e} {:.9e} {:.9e}\n  vertex {:.9e} {:.9e} {:.9e}\n"
             "  vertex {:.9e} {:.9e} {:.9e}\n endloop\nendfacet\n")
    body = (facet * len(rows)).format(*rows.ravel())
    with open(tmp, "w") as fh:
        fh.write("solid cadpipe\n" + body + "endsolid cadpipe\n")
