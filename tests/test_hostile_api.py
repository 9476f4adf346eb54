"""Hostile files through the Python API: a cadpipe error naming the file (and the part
where there is one), never another exception, and no RuntimeWarning leaking out of
numpy (the CLI silences warnings; the API must not need to)."""

import struct
import warnings

import numpy as np
import pytest

import cadpipe
from cadpipe.errors import CadpipeError
from cadpipe.io.files import load_mesh

TETRA_FACES = "f 1 2 3\nf 1 3 4\nf 1 4 2\nf 2 4 3\n"


def _glb_with_points(folder, values):
    path = folder / "h.glb"
    cadpipe.primitives.box(1).export(path)
    data = path.read_bytes()
    length = struct.unpack_from("<I", data, 12)[0]
    binary = bytearray(data[28 + length:])
    binary[:12] = np.array(values, np.float32).tobytes()
    path.write_bytes(data[:28 + length] + bytes(binary))
    return path


def _ascii_ply(folder, x):
    path = folder / "h.ply"
    path.write_text("ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                    "property float z\nelement face 4\nproperty list uchar int vertex_indices\n"
                    f"end_header\n{x} 0 0\n0 1 0\n0 0 1\n1 1 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n"
                    "3 1 2 3\n")
    return path


def _obj(folder, x):
    path = folder / "h.obj"
    path.write_text(f"v {x} 0 0\nv 0 1 0\nv 0 0 1\nv 1 1 1\n" + TETRA_FACES)
    return path


FILES = {
    "glb-inf": lambda f: _glb_with_points(f, [np.inf, 0, 0]),
    "glb-nan": lambda f: _glb_with_points(f, [np.nan, 0, 0]),
    "glb-3e38": lambda f: _glb_with_points(f, [3e38, 3e38, 3e38]),
    "ply-ascii-3e38": lambda f: _ascii_ply(f, "3e38"),
    "ply-ascii-nan": lambda f: _ascii_ply(f, "nan"),
    "obj-1e308": lambda f: _obj(f, "1e308"),
    "obj-1e309": lambda f: _obj(f, "1e309"),
    "obj-nan": lambda f: _obj(f, "nan"),
}


@pytest.mark.parametrize("case", FILES)
def test_a_hostile_file_is_a_cadpipe_error_naming_it_without_warnings(tmp_path, case):
    path = FILES[case](tmp_path)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(CadpipeError) as caught:
            load_mesh(path)
    assert caught.value.file == str(path)
    assert caught.value.part is not None


def test_an_ascii_ply_reads():
    """The reader of ASCII PLY (trimesh keeps its faces as a dict) is not a crash."""
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as folder:
        mesh = load_mesh(_ascii_ply(Path(folder), "1"))
    assert len(mesh.faces) == 4
