"""Issue 7's bad-input matrix: every documented error through the Python API and the CLI.

One table of cases drives both. Each case writes its input files into a fresh folder and
names the API call that must raise (with its cadpipe error type) and the arguments of
``python -m cadpipe`` that must exit 1 with one line on stderr and no traceback. Both
share a message fragment, and neither may leave anything behind: no output file, no
output folder, no temporary file.
"""

import json
import math
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path as FilePath

import pytest
import trimesh

import cadpipe
from cadpipe import ExportError, InputError, MeshError, Pipe, SpecError, primitives

FOLDER = object()                 # a files entry that makes a folder, not a file
OUT = "out/result.stl"            # every case's output target, relative to its folder
LINE = [[0, 0, 0], [1, 0, 0], [1, 1, 0]]
ARM = FilePath(__file__).parent.parent / "assets" / "robots" / "arm6" / "arm6.urdf"


@dataclass(frozen=True)
class Case:
    """One bad input: files to write, the API call and the CLI arguments it breaks."""

    id: str
    error: type                   # the cadpipe error the API raises
    message: str                  # in the API's error and in the CLI's line
    api: Callable                 # api(folder) must raise ``error``
    argv: tuple                   # CLI arguments, "{}" standing for the folder
    files: dict = field(default_factory=dict)   # name -> text, bytes or FOLDER


def pipe_case(id, error, message, path=LINE, radius=0.1, sides=16, **options):
    """``Pipe(path, radius, sides).mesh()`` in Python, the same pipe in a spec for the CLI."""
    spec = {"parts": [{"kind": "pipe", "path": path, "radius": radius, "sides": sides,
                       **options}]}
    # json writes a NaN that Python's reader takes back, as TOML's nan
    return Case(id, error, message,
                lambda folder: Pipe(path, radius, sides=sides, **options).mesh(),
                ("build", "{}/pipe.json", "-o", "{}/" + OUT), {"pipe.json": json.dumps(spec)})


def spec_case(id, message, text, files=None, name="spec.toml", command="build"):
    """A spec file that :func:`cadpipe.spec.read` refuses with a SpecError."""
    argv = (command, "{}/" + name) + (("-o", "{}/" + OUT) if command == "build" else ())
    return Case(id, SpecError, message, lambda folder: cadpipe.spec.read(folder / name),
                argv, {name: text, **(files or {})})


GOOD_SPEC = {"spec.toml": '[[parts]]\nkind = "box"\nsize = 1\n'}


def output_case(id, error, message, target, files=None):
    """A good spec written to ``target``: ``Assembly.export`` in Python, ``build -o``."""
    return Case(id, error, message,
                lambda folder: cadpipe.load(folder / "spec.toml").export(folder / target),
                ("build", "{}/spec.toml", "-o", "{}/" + target), {**GOOD_SPEC, **(files or {})})


def mesh_case(id, error, message, content, command=("check",), name="part.stl"):
    """A mesh file ``name`` that :meth:`cadpipe.Mesh.load` (and ``command``) refuses."""
    return Case(id, error, message, lambda folder: cadpipe.Mesh.load(folder / name),
                (*command[:1], "{}/" + name, *command[1:]), {name: content})


BOX = trimesh.creation.box()
BOX_STL = BOX.export(file_type="stl")
OPEN_STL = trimesh.Trimesh(BOX.vertices, BOX.faces[:-2], process=False).export(file_type="stl")
NAN_STL = BOX_STL[:96] + b"\x00\x00\xc0\x7f" + BOX_STL[100:]   # a corner's x is NaN

CASES = [
    # paths and pipes: cadpipe.Pipe in Python, a pipe part for `cadpipe build`
    pipe_case("nan-point", InputError, "point 1 is not finite",
              path=[[0, 0, 0], [math.nan, 0, 0], [1, 1, 0]]),
    pipe_case("one-point", InputError, "expected at least 2 points, got 1", path=[[0, 0, 0]]),
    pipe_case("radius-zero", InputError, "radius: must be finite and > 0, got 0", radius=0),
    pipe_case("radius-negative", InputError, "radius: must be finite and > 0, got -0.1",
              radius=-0.1),
    pipe_case("sides-2", InputError, "sides: must be between 3 and 4096, got 2", sides=2),
    pipe_case("sides-huge", InputError, "sides: must be between 3 and 4096, got 1000000000",
              sides=10 ** 9),
    pipe_case("self-intersecting-bend", cadpipe.GeometryError, "the pipe intersects itself",
              path=[[0, 0, 0], [1, 0, 0], [1, 0.05, 0], [0, 0.05, 0]], strict=True),
    pipe_case("radius-wrong-type", InputError, "radius: expected", radius="thick"),
    pipe_case("sides-wrong-type", InputError, "sides: expected a whole number, got 12.5",
              sides=12.5),
    # spec files
    spec_case("unknown-key", "parts[0].colour: unknown key",
              '[[parts]]\nkind = "box"\nsize = 1\ncolour = "red"\n'),
    spec_case("unknown-kind", "parts[0].kind: unknown part kind 'teapot'",
              '[[parts]]\nkind = "teapot"\n'),
    spec_case("wrong-type", "parts[0].size: expected a number or a list, got 'big'",
              '[[parts]]\nkind = "box"\nsize = "big"\n'),
    spec_case("missing-key", "parts[0].radius: missing",
              '[[parts]]\nkind = "sphere"\n'),
    spec_case("not-toml", "not valid TOML", "[[parts]\nkind = 'box'\n"),
    spec_case("binary-garbage", "not valid TOML", b"\xff\xfe\x00\x81garbage\x00"),
    spec_case("invalid-utf8-json", "not valid JSON", b'{"parts": "\xff"}', name="spec.json"),
    spec_case("folder-as-spec", "is a folder, not a spec file", FOLDER),
    spec_case("unknown-spec-format", "use .toml or .json", "parts: []", name="spec.yaml"),
    spec_case("binary-csv-path", "parts[0].path: route.csv: not a text file",
              '[[parts]]\nkind = "pipe"\npath = "route.csv"\nradius = 0.1\n',
              {"route.csv": b"\xff\xfe\x00\x81"}),
    spec_case("missing-mesh-part", "parts[0].file: no such file 'flange.stl'",
              '[[parts]]\nkind = "mesh"\nfile = "flange.stl"\n'),
    spec_case("cell-unknown-object", "allow[0].b: unknown object 'ghost'",
              '[[parts]]\nname = "a"\nkind = "box"\nsize = 1\n[[allow]]\na = "a"\nb = "ghost"\n',
              command="collide"),
    spec_case("robot-joint-limit", "robot.joints: j2=3.0 is outside its limits",
              f'[robot]\nurdf = "{ARM}"\njoints = [0, 3, 0, 0, 0, 0]\n', command="collide"),
    Case("missing-spec", SpecError, "missing.toml: no such spec file",
         lambda folder: cadpipe.load(folder / "missing.toml"),
         ("build", "{}/missing.toml", "-o", "{}/" + OUT)),
    # mesh files
    mesh_case("missing-mesh", ExportError, "part.stl: no such file", None),
    mesh_case("folder-as-mesh", ExportError, "is a folder, not a mesh file", FOLDER),
    mesh_case("truncated-stl", MeshError, "holds no triangles", BOX_STL[:300]),
    mesh_case("garbage-stl", MeshError, "holds no triangles", b"\x00\x01 not a mesh " * 9),
    mesh_case("empty-obj", MeshError, "holds no triangles", b"", name="part.obj"),
    mesh_case("comment-only-obj", MeshError, "holds no triangles", b"# nothing\n",
              name="part.obj"),
    mesh_case("nan-stl", MeshError, "NaN or infinite", NAN_STL, ("view", "-o", "{}/out")),
    Case("non-closed-imported-mesh", MeshError, "lid.stl: not a closed solid",
         lambda folder: primitives.imported(folder / "lid.stl"),
         ("build", "{}/spec.toml", "-o", "{}/" + OUT),
         {"spec.toml": '[[parts]]\nkind = "mesh"\nfile = "lid.stl"\n', "lid.stl": OPEN_STL}),
    # outputs
    output_case("unknown-suffix", InputError, "unknown output format", "out/result.weird"),
    output_case("no-suffix", InputError, "no file suffix", "out/result"),
    output_case("parent-is-a-file", ExportError, "is a file, not a folder", "block/result.stl",
                {"block": "a file where the output folder should be"}),
    output_case("target-is-a-folder", ExportError, "is a folder", "result.stl",
                {"result.stl": FOLDER}),
]


def make(folder, files):
    """Write ``files`` (a None entry is left missing) and return every path below ``folder``."""
    for name, content in files.items():
        path = folder / name
        if content is FOLDER:
            path.mkdir()
        elif isinstance(content, bytes):
            path.write_bytes(content)
        elif content is not None:
            path.write_text(content)
    return everything(folder)


def everything(folder):
    return sorted(p.relative_to(folder) for p in folder.rglob("*"))


def ids(cases):
    return [c.id for c in cases]


def test_the_case_ids_are_unique():
    assert len(set(ids(CASES))) == len(CASES)


@pytest.mark.parametrize("case", CASES, ids=ids(CASES))
def test_the_api_raises_its_cadpipe_error_and_writes_nothing(case, tmp_path):
    before = make(tmp_path, case.files)
    with pytest.raises(case.error) as raised:
        case.api(tmp_path)
    assert case.message in str(raised.value)
    assert "\n" not in str(raised.value)
    assert everything(tmp_path) == before


@pytest.fixture(scope="module")
def cli_runs(tmp_path_factory):
    """Every case through ``python -m cadpipe``, a few processes at a time."""
    def run(case):
        folder = tmp_path_factory.mktemp(case.id)
        before = make(folder, case.files)
        argv = [a.replace("{}", str(folder)) for a in case.argv]
        done = subprocess.run([sys.executable, "-m", "cadpipe", *argv], cwd=folder,
                              capture_output=True, text=True, timeout=300)
        return case.id, (folder, before, argv, done)

    with ThreadPoolExecutor(max_workers=4) as pool:
        return dict(pool.map(run, CASES))


@pytest.mark.parametrize("case", CASES, ids=ids(CASES))
def test_the_cli_prints_one_line_exits_1_and_writes_nothing(case, cli_runs):
    folder, before, argv, done = cli_runs[case.id]
    err = done.stderr
    assert done.returncode == 1, err
    assert "Traceback" not in err and err.count("\n") == 1, err
    assert err.startswith(f"cadpipe {argv[0]}: error: ") and case.message in err
    named = [a for a in argv[1:] if a.startswith(str(folder))]
    assert any(str(FilePath(a).relative_to(folder)) in err for a in named), err
    assert everything(folder) == before            # no output, no output folder, no temp file
