"""Hostile files through the Python API: a cadpipe error naming the file (and the part
where there is one), never another exception, and no RuntimeWarning leaking out of
numpy (the CLI silences warnings; the API must not need to)."""

import struct
import warnings

import numpy as np
import pytest

import cadpipe
from cadpipe.errors import CadpipeError
from cadpipe.core.formats import load_mesh

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


def _spec(folder, text, name="s.toml"):
    path = folder / name
    path.write_text(text)
    return path


def _read(folder, text, **options):
    from cadpipe.spec import read

    return read(_spec(folder, text), **options)


BOX = '[[parts]]\nkind = "box"\nsize = 1\n'

#: (id, call(folder), fields the error must carry: name -> value, or callable(folder))
ERRORS = [
    ("export-no-suffix", lambda f: cadpipe.primitives.box(1).export(f / "x"),
     {"file": lambda f: str(f / "x")}),
    ("export-unknown-suffix", lambda f: cadpipe.primitives.box(1).export(f / "x.exe"),
     {"file": lambda f: str(f / "x.exe")}),
    ("export-to-a-folder", lambda f: cadpipe.primitives.box(1).export(f),
     {"file": lambda f: str(f)}),
    ("export-under-a-file", lambda f: (_spec(f, "x", "a.txt"),
                                       cadpipe.primitives.box(1).export(f / "a.txt" / "b.stl")),
     {"file": lambda f: str(f / "a.txt" / "b.stl")}),
    ("export-missing-folder", lambda f: cadpipe.primitives.box(1).export(f / "no" / "b.stl"),
     {"file": lambda f: str(f / "no" / "b.stl")}),
    ("spec-radius", lambda f: _read(f, '[[parts]]\nkind = "pipe"\npath = [[0,0,0],[1,0,0]]\n'
                                       'radius = -1\n'),
     {"key": "parts[0].radius", "file": lambda f: str(f / "s.toml")}),
    ("spec-kind", lambda f: _read(f, '[[parts]]\nkind = "blob"\n'),
     {"key": "parts[0].kind"}),
    ("spec-output-escape", lambda f: _read(f, 'outputs = ["../x.stl"]\n' + BOX),
     {"key": "outputs[0].file"}),
    ("spec-limit-key", lambda f: _read(f, "max_parts = 0\n" + BOX), {"key": "max_parts"}),
    ("spec-csv-nan-row", lambda f: (_spec(f, "0,0,0\n1,nan,0\n2,0,0\n", "p.csv"),
                                    _read(f, '[[parts]]\nkind = "pipe"\npath = "p.csv"\n'
                                             'radius = 0.1\n')),
     {"key": "parts[0].path", "index": 1}),
    ("glb-cycle", lambda f: load_mesh(_glb_cycle(f)), {"file": lambda f: str(f / "c.glb")}),
    ("glb-limit", lambda f: _under(load_mesh, _glb_with_points(f, [0, 0, 0]), max_triangles=5),
     {"file": lambda f: str(f / "h.glb")}),
    ("world-name", lambda f: cadpipe.CollisionWorld().add("", cadpipe.primitives.box(1)),
     {"key": "name"}),
    ("world-unknown", lambda f: cadpipe.CollisionWorld().set_pose("ghost", np.eye(4)),
     {"part": "ghost"}),
    ("world-check-many", lambda f: _world().check_many([1, 2]), {"key": "poses"}),
    ("world-check-many-shapes", lambda f: _world().check_many(
        {"a": np.tile(np.eye(4), (3, 1, 1)), "b": np.tile(np.eye(4), (2, 1, 1))}),
     {"key": "poses"}),
    ("world-transform", lambda f: cadpipe.CollisionWorld().add("a", cadpipe.primitives.box(1),
                                                               np.eye(3)),
     {"part": "a", "key": "transform"}),
    ("limits-unknown", lambda f: cadpipe.limits.using(max_fun=1).__enter__(),
     {"key": "max_fun"}),
]


def _under(call, *args, **budgets):
    with cadpipe.limits.using(**budgets):
        return call(*args)


def _world():
    world = cadpipe.CollisionWorld()
    world.add("a", cadpipe.primitives.box(1))
    world.add("b", cadpipe.primitives.box(1), np.diag([1.0, 1, 1, 1]))
    return world


def _glb_cycle(folder):
    import json

    path = folder / "c.glb"
    cadpipe.primitives.box(1).export(path)
    data = path.read_bytes()
    length = struct.unpack_from("<I", data, 12)[0]
    doc = json.loads(data[20:20 + length])
    doc["nodes"][1]["children"] = [0]
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    body = struct.pack("<I4s", len(text), b"JSON") + text + data[20 + length:]
    path.write_bytes(struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body)
    return path


@pytest.mark.parametrize("case", [e[0] for e in ERRORS])
def test_errors_carry_what_they_are_about_as_fields(tmp_path, case):
    _, call, fields = next(e for e in ERRORS if e[0] == case)
    with pytest.raises(CadpipeError) as caught:
        call(tmp_path)
    for name, want in fields.items():
        want = want(tmp_path) if callable(want) else want
        assert getattr(caught.value, name) == want, (name, caught.value)
    assert "\n" not in str(caught.value)
