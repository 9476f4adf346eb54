"""Issue 12's hostile command lines, run as real subprocesses under a memory and time limit.

Each case writes its inputs into a fresh folder ``case/`` beside a ``victim.obj`` that
must survive, then runs ``python -m cadpipe ...`` with ``RLIMIT_AS`` at 4 GiB and a
wall-clock limit. Each must exit non-zero with exactly one line on stderr and no
traceback, within the time limit (so well before the limits of a machine), and leave
every file outside ``case/out`` as it was (nothing written, nothing overwritten).
Plus: a reader that closes the pipe early, and the registry on a cold start with
threads and without installed entry points.
"""

import json
import os
import resource
import struct
import subprocess
import sys
import zipfile
from concurrent.futures import ThreadPoolExecutor

import pytest
import trimesh

MEMORY = 4 << 30
TIMEOUT = 90
BOX = '[[parts]]\nkind = "box"\nsize = 1\n'
LINE = [[0, 0, 0], [1, 0, 0], [1, 1, 0]]


def toml_pipe(path, radius=0.1, extra=""):
    return f'[[parts]]\nkind = "pipe"\npath = {path}\nradius = {radius}\n{extra}'


def zip_bomb(folder, name="bomb.3mf", claimed=3 << 30):
    """A 3MF whose model claims to unpack to ``claimed`` bytes (3 GB) from a few KB."""
    target = folder / name
    with zipfile.ZipFile(target, "w", zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("[Content_Types].xml", "<Types/>")
        archive.writestr("3D/3dmodel.model", b"\0" * (1 << 20))
    data = bytearray(target.read_bytes())
    member = data.find(b"PK\x01\x02", 0)
    while member >= 0:                    # central directory: patch the uncompressed size
        name_len = struct.unpack_from("<H", data, member + 28)[0]
        if data[member + 46:member + 46 + name_len] == b"3D/3dmodel.model":
            struct.pack_into("<I", data, member + 24, claimed)
        member = data.find(b"PK\x01\x02", member + 4)
    target.write_bytes(bytes(data))
    return target


def glb(folder, name, change=None, tail=b""):
    """A GLB of a 2,048-triangle sphere, its JSON edited by ``change(doc)``, ``tail``
    appended (or, as bytes returned by ``change``, the whole JSON chunk replaced)."""
    import cadpipe

    path = folder / name
    cadpipe.primitives.sphere(1, segments=64).export(path)
    data = path.read_bytes()
    length = struct.unpack_from("<I", data, 12)[0]
    doc, binary = json.loads(data[20:20 + length]), data[20 + length:]
    edited = change(doc) if change else None
    text = edited if isinstance(edited, bytes) else json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    body = struct.pack("<I4s", len(text), b"JSON") + text + binary + tail
    path.write_bytes(struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body)
    return path


def _repeat_nodes(doc, times=3000):
    """Every node of the scene's root points to the sphere: 6 M triangles from 80 KB."""
    doc["nodes"][0]["children"] = list(range(1, times + 1))
    doc["nodes"] += [{"mesh": 0} for _ in range(times - 1)]


def _cycle(doc):
    doc["nodes"][1]["children"] = [0]


def _shared_child(doc):
    doc["nodes"].append({"children": [1]})
    doc["scenes"][0]["nodes"].append(2)


def _huge_count(doc):
    doc["accessors"][2]["count"] = 10 ** 15


def _truncated_binary(doc):
    doc["buffers"][0]["byteLength"] = 1 << 40


GLBS = {
    "glb-nodes-repeat-a-mesh": lambda f: glb(f, "x.glb", _repeat_nodes),
    "glb-node-cycle": lambda f: glb(f, "x.glb", _cycle),
    "glb-shared-node": lambda f: glb(f, "x.glb", _shared_child),
    "glb-accessor-count-1e15": lambda f: glb(f, "x.glb", _huge_count),
    "glb-buffer-claims-1-tb": lambda f: glb(f, "x.glb", _truncated_binary),
    "glb-json-nested-100000": lambda f: glb(f, "x.glb", lambda d: b"[" * 100_000 + b"]" * 100_000),
    "glb-json-int-5000-digits": lambda f: glb(f, "x.glb", lambda d: b'{"scene": ' + b"7" * 5000
                                              + b"}"),
    "glb-json-chunk-past-the-end": lambda f: (f / "x.glb").write_bytes(
        struct.pack("<4sII", b"glTF", 2, 40) + struct.pack("<I4s", 1 << 31, b"JSON") + b"{}  "),
    "glb-empty": lambda f: (f / "x.glb").write_bytes(b""),
    "glb-header-only": lambda f: (f / "x.glb").write_bytes(b"glTF\x02\0\0\0"),
}


def huge_obj(folder):
    (folder / "huge.obj").write_text("v 1e308 0 0\nv 0 1e308 0\nv 0 0 1e308\nv 1e308 1e308 1e308\n"
                                     "f 1 2 3\nf 1 3 4\nf 1 4 2\nf 2 4 3\n")


def links(folder):
    (folder / "link").symlink_to("/tmp")
    (folder / "zero.stl").symlink_to("/dev/zero")
    (folder / "zero.toml").symlink_to("/dev/zero")
    os.mkfifo(folder / "fifo.stl")
    os.mkfifo(folder / "fifo.toml")


def nested(depth, fmt):
    return ("parts = " + "[" * depth + "]" * depth) if fmt == "toml" else \
        ('{"parts": ' + "[" * depth + "]" * depth + "}")


#: (id, argv with {} for the case folder, files: name -> text | callable(folder))
CASES = [
    ("output-dotdot", ("build", "{}/spec.toml"),
     {"spec.toml": 'outputs = ["../victim.obj"]\n' + BOX}),
    ("output-absolute", ("build", "{}/spec.toml"),
     {"spec.toml": lambda f: f'outputs = ["{f.parent / "victim.obj"}"]\n' + BOX}),
    ("output-link-out", ("build", "{}/spec.toml"),
     {"spec.toml": 'outputs = ["link/cadpipe-hostile.stl"]\n' + BOX, "_": links}),
    ("output-nul", ("build", "{}/spec.json"),
     {"spec.json": json.dumps({"outputs": ["a\u0000.stl"],
                               "parts": [{"kind": "box", "size": 1}]})}),
    ("spline-step-1e-12", ("build", "{}/spec.toml", "-o", "{}/out/x.stl"),
     {"spec.toml": toml_pipe(f"{{points = {LINE}, spline = true, step = 1e-12}}")}),
    ("coordinates-1e308", ("build", "{}/spec.toml", "-o", "{}/out/x.stl"),
     {"spec.toml": toml_pipe("[[0, 0, 0], [1e308, 0, 0], [1e308, 1e308, 0]]")}),
    ("radius-1e308", ("build", "{}/spec.toml", "-o", "{}/out/x.stl"),
     {"spec.toml": toml_pipe(str(LINE), radius="1e308")}),
    ("path-1e200", ("build", "{}/spec.toml", "-o", "{}/out/x.stl"),
     {"spec.toml": toml_pipe("[[0, 0, 0], [1e200, 0, 0], [1e200, 1e200, 0]]", radius="1e199")}),
    ("translate-1e308", ("build", "{}/spec.toml", "-o", "{}/out/x.stl"),
     {"spec.toml": BOX + "transform = {translate = [1e308, 0, 0]}\n"}),
    ("json-nested-100000", ("build", "{}/spec.json", "-o", "{}/out/x.stl"),
     {"spec.json": nested(100_000, "json")}),
    ("toml-nested-100000", ("build", "{}/spec.toml", "-o", "{}/out/x.stl"),
     {"spec.toml": nested(100_000, "toml")}),
    ("toml-dotted-100000", ("build", "{}/spec.toml", "-o", "{}/out/x.stl"),
     {"spec.toml": "a." * 100_000 + "b = 1\n" + BOX}),
    ("json-int-5000-digits", ("build", "{}/spec.json", "-o", "{}/out/x.stl"),
     {"spec.json": '{"parts": [{"kind": "box", "size": ' + "7" * 5000 + "}]}"}),
    ("toml-int-4000-digits", ("build", "{}/spec.toml", "-o", "{}/out/x.stl"),
     {"spec.toml": BOX.replace("size = 1", "size = " + "7" * 4000)}),
    ("sphere-segments-4096", ("build", "{}/spec.toml", "-o", "{}/out/x.stl"),
     {"spec.toml": '[[parts]]\nkind = "sphere"\nradius = 1\nsegments = 4096\n'}),
    ("million-parts", ("build", "{}/spec.json", "-o", "{}/out/x.stl"),
     {"spec.json": '{"parts": [' + ",".join(['{"kind":"box","size":1}'] * 10 ** 6) + "]}"}),
    ("spline-4096-sides", ("build", "{}/spec.toml", "-o", "{}/out/x.stl"),
     {"spec.toml": toml_pipe("{points = [[0,0,0],[1,0,0],[1,1,0],[2,1,1]], spline = true, "
                             "step = 0.002}",
                             radius=0.01, extra="sides = 4096\n")}),
    ("csv-nan-first-row", ("build", "{}/spec.toml", "-o", "{}/out/x.stl"),
     {"spec.toml": toml_pipe('"route.csv"'), "route.csv": "1,2,nan\n0,0,0\n1,0,0\n1,1,0\n"}),
    ("control-characters", ("build", "{}/spec.json", "-o", "{}/out/x.stl"),
     {"spec.json": json.dumps({"parts": [{"kind": "box", "size": "\x07big\nger",
                                          "name": "a\x07b\nc"}]})}),
    ("spec-fifo", ("build", "{}/fifo.toml", "-o", "{}/out/x.stl"), {"_": links}),
    ("spec-dev-zero", ("build", "{}/zero.toml", "-o", "{}/out/x.stl"), {"_": links}),
    ("mesh-part-dev-zero", ("build", "{}/spec.toml", "-o", "{}/out/x.stl"),
     {"spec.toml": '[[parts]]\nkind = "mesh"\nfile = "zero.stl"\n', "_": links}),
    ("check-fifo", ("check", "{}/fifo.stl"), {"_": links}),
    ("check-dev-zero", ("check", "{}/zero.stl"), {"_": links}),
    ("check-zip-bomb-3mf", ("check", "{}/bomb.3mf"), {"_": zip_bomb}),
    ("view-zip-bomb-3mf", ("view", "{}/bomb.3mf", "-o", "{}/out"), {"_": zip_bomb}),
    ("check-obj-1e308", ("check", "{}/huge.obj"), {"_": huge_obj}),
    *[(f"check-{name}", ("check", "{}/x.glb"), {"_": make}) for name, make in GLBS.items()],
    ("view-glb-nodes-repeat-a-mesh", ("view", "{}/x.glb", "-o", "{}/out"),
     {"_": GLBS["glb-nodes-repeat-a-mesh"]}),
    ("check-zip-bomb-usdz", ("check", "{}/bomb.usdz"),
     {"_": lambda f: zip_bomb(f, "bomb.usdz")}),
    *[(f"output-{n}", ("build", "{}/spec.toml"), {"spec.toml": f"outputs = [{o!r}]\n" + BOX})
      for n, o in [("dot-dotdot", "./../victim.obj"), ("inner-dotdot", "out/../../victim.obj"),
                   ("unknown-suffix", "x.exe"),
                   ("no-suffix", "x")]],
    *[(f"spec-{n}", ("build", "{}/spec.toml", "-o", "{}/out/x.stl"), {"spec.toml": t})
      for n, t in [("empty", ""), ("garbage", "\x00\x01\x02 = ="), ("unknown-kind",
                   '[[parts]]\nkind = "blob"\n'), ("kind-number", "[[parts]]\nkind = 5\n"),
                   ("parts-not-list", "parts = 3\n"), ("sides-2", toml_pipe(str(LINE),
                   extra="sides = 2\n")), ("sides-1e9", toml_pipe(str(LINE),
                   extra="sides = 1000000000\n")), ("radius-0", toml_pipe(str(LINE), radius=0)),
                   ("radius-nan", toml_pipe(str(LINE), radius="nan")),
                   ("one-point", toml_pipe("[[0, 0, 0]]")), ("units-furlong",
                   'units = "furlong"\n' + BOX), ("op-explode", BOX + 'op = "explode"\n'),
                   ("max-parts-0", "max_parts = 0\n" + BOX),
                   ("max-depth-in-spec", "max_depth = 1000\n" + BOX)]],
    ("flag-max-triangles-negative", ("build", "{}/spec.toml", "-o", "{}/out/x.stl",
                                     "--max-triangles", "-5"), {"spec.toml": BOX}),
    ("flag-max-expansion-nan", ("check", "{}/x.glb", "--max-expansion", "nan"),
     {"_": GLBS["glb-node-cycle"]}),
    ("collide-depth", ("collide", "{}/spec.json"), {"spec.json": nested(5000, "json")}),
    ("collide-output-escape", ("collide", "{}/spec.toml", "--svg", "{}/out"),
     {"spec.toml": 'outputs = ["../../victim.obj"]\n' + BOX}),
]


def _limits():
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY, MEMORY))


def snapshot(root):
    return {p: (p.stat().st_size, p.stat().st_mtime_ns) for p in root.rglob("*")
            if p.is_file() and not p.is_symlink() and "out" not in p.relative_to(root).parts}


def run_case(root, case_id, argv, files):
    folder = root / "case"
    folder.mkdir(parents=True)
    (root / "victim.obj").write_text("v 0 0 0\n")
    for name, content in files.items():
        if callable(content):
            content = content(folder)
        if isinstance(content, str):
            (folder / name).write_text(content)
    before = snapshot(root)
    args = [a.replace("{}", str(folder)) for a in argv]
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    try:
        done = subprocess.run([sys.executable, "-m", "cadpipe", *args], capture_output=True,
                              text=True, timeout=TIMEOUT, preexec_fn=_limits, env=env)
    except subprocess.TimeoutExpired:
        return case_id, None, snapshot(root) == before
    return case_id, done, snapshot(root) == before


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    base = tmp_path_factory.mktemp("hostile")
    with ThreadPoolExecutor(max_workers=2) as pool:
        found = pool.map(lambda c: run_case(base / c[0], *c), CASES)
        return {case_id: (done, untouched) for case_id, done, untouched in found}


@pytest.mark.slow
@pytest.mark.parametrize("case_id", [c[0] for c in CASES])
def test_hostile_command_line_fails_in_one_line_and_writes_nothing(runs, case_id):
    done, untouched = runs[case_id]
    assert done is not None, f"still running after {TIMEOUT} s"
    err = done.stderr
    assert done.returncode == 1, (done.returncode, err, done.stdout)
    assert "Traceback" not in err and err.count("\n") == 1 and err.startswith("cadpipe "), err
    assert "internal error" not in err, err
    assert len(err) < 600, err                    # nothing echoed whole
    assert untouched, "a file outside the output folder changed"


def test_the_limits_name_their_override(runs):
    for case_id in ("sphere-segments-4096", "spline-step-1e-12", "check-zip-bomb-3mf"):
        err = runs[case_id][0].stderr
        assert "limit of" in err and "cadpipe.limits.using(" in err, err


def test_a_closed_stdout_exits_quietly(tmp_path):
    spec = tmp_path / "cell.toml"
    spec.write_text("".join(f'[[parts]]\nname = "b{i}"\nkind = "box"\nsize = 1\n'
                            f'transform = {{translate = [{2 * i}, 0, 0]}}\n' for i in range(40)))
    done = subprocess.run(f"'{sys.executable}' -m cadpipe collide --json '{spec}' | head -c 10",
                          shell=True, capture_output=True, text=True, timeout=TIMEOUT)
    assert done.stdout and "Traceback" not in done.stderr and not done.stderr, done.stderr


THREADS = """
import threading, sys
import importlib.metadata as metadata
if sys.argv[1] == "no-entry-points":
    real = metadata.entry_points                  # a source tree that was never installed:
    metadata.entry_points = lambda **kw: [] if kw.get("group", "").startswith("cadpipe") \
        else real(**kw)                           # no cadpipe plugins
from cadpipe.core.formats import writers as exporters
from cadpipe.spec import part_kinds
barrier, found = threading.Barrier(6), []
def look():
    barrier.wait()
    try:
        found.append((exporters.get("stl").__name__, part_kinds.get("pipe").__name__,
                      len(exporters.names())))
    except Exception as exc:
        found.append(repr(exc))
threads = [threading.Thread(target=look) for _ in range(6)]
[t.start() for t in threads]
[t.join() for t in threads]
print(found)
"""


@pytest.mark.parametrize("mode", ["installed", "no-entry-points"])
def test_the_registry_answers_every_thread_on_a_cold_start(mode):
    done = subprocess.run([sys.executable, "-c", THREADS, mode], capture_output=True,
                          text=True, timeout=TIMEOUT)
    assert done.returncode == 0, done.stderr
    found = eval(done.stdout)                         # noqa: S307 (our own repr of tuples)
    assert found == [("write_stl", "pipe", 8)] * 6, found


def test_an_export_works_from_a_source_tree_without_entry_points(tmp_path):
    code = ("import importlib.metadata as m; real = m.entry_points\n"
            "m.entry_points = lambda **kw: [] if kw.get('group', '').startswith('cadpipe') "
            "else real(**kw)\n"
            "import cadpipe, sys\n"
            "cadpipe.primitives.box(1).export(sys.argv[1])\n")
    done = subprocess.run([sys.executable, "-c", code, str(tmp_path / "b.stl")],
                          capture_output=True, text=True, timeout=TIMEOUT)
    assert done.returncode == 0, done.stderr
    assert trimesh.load(tmp_path / "b.stl").is_watertight


@pytest.mark.slow
def test_ctrl_c_stops_a_build_at_once_with_130_and_no_file(tmp_path):
    import signal
    import time

    spec = tmp_path / "big.toml"
    spec.write_text("".join(f'[[parts]]\nkind = "sphere"\nradius = 1\nsegments = 200\n'
                            f'transform = {{translate = [{0.3 * i}, 0, 0]}}\n' for i in range(60)))
    out = tmp_path / "out" / "big.stl"
    proc = subprocess.Popen([sys.executable, "-m", "cadpipe", "build", str(spec), "-o", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(4.0)                                   # imported, reading or combining
    assert proc.poll() is None, proc.communicate()
    proc.send_signal(signal.SIGINT)
    sent = time.monotonic()
    _, err = proc.communicate(timeout=30)
    waited = time.monotonic() - sent
    # 130, or ended by the signal itself (no file open then: SIGINT keeps its default)
    assert proc.returncode in (130, -signal.SIGINT), err
    assert waited < 3.0, waited
    assert "Traceback" not in err and err.count("\n") <= 1, err
    assert not out.exists() and not list(tmp_path.rglob("*.tmp*"))
