"""Exports killed with SIGKILL at random points: the target is the old file or the new
one, never a partial one, and the next run's write to it leaves no temporary file.

Each kill is a real process: it imports cadpipe, builds its mesh, says so on stdout,
then exports over a target that already holds an older file; the test kills it after a
seeded random delay within the time an export takes. The next write comes from a
fresh process, as a user's next run would (a temporary file younger than the running
process may belong to a live writer, so only a later run removes it).
"""

import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import cadpipe
from cadpipe.core.formats import load_mesh

KILLS = 8                       # per format
WRITER = """
import sys, cadpipe
mesh = cadpipe.Pipe(cadpipe.Path.spline([[0,0,0],[1,0,0],[1,1,0],[2,1,1]], 0.002), 0.05,
                    sides=int(sys.argv[2])).mesh()
print("ready", flush=True)
mesh.export(sys.argv[1])
print("done", flush=True)
"""


def _export(target, sides):
    """Run the writer to the end; seconds from "ready" to "done"."""
    proc = subprocess.Popen([sys.executable, "-c", WRITER, str(target), str(sides)],
                            stdout=subprocess.PIPE, text=True)
    assert proc.stdout.readline() == "ready\n"
    start = time.monotonic()
    assert proc.stdout.readline() == "done\n"
    took = time.monotonic() - start
    assert proc.wait(timeout=120) == 0
    return took


def _temporaries(folder):
    return sorted(p.name for p in folder.iterdir() if ".tmp" in p.name)


def _faces(path):
    return len(load_mesh(path).faces)


@pytest.mark.slow
@pytest.mark.parametrize("suffix", ["stl", "glb", "3mf", "usdc"])
def test_an_export_killed_anywhere_leaves_the_old_file_or_the_new_one(tmp_path, suffix):
    rng = np.random.default_rng(12)
    target = tmp_path / f"part.{suffix}"
    reference = tmp_path / "reference"
    reference.mkdir()
    took = _export(reference / target.name, 64)          # what a finished write leaves
    new_faces = _faces(reference / target.name)
    cadpipe.primitives.box(1).export(target)              # the old file
    old_bytes, old_faces = target.read_bytes(), _faces(target)
    seen = set()
    for _ in range(KILLS):
        proc = subprocess.Popen([sys.executable, "-c", WRITER, str(target), "64"],
                                stdout=subprocess.PIPE, text=True)
        assert proc.stdout.readline() == "ready\n"
        time.sleep(float(rng.uniform(0, 1.2 * took)))
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=60)
        faces = _faces(target)                            # reads whole, or raises
        assert faces in (old_faces, new_faces), faces
        if faces == old_faces:
            assert target.read_bytes() == old_bytes
        seen.add("new" if faces == new_faces else "old")
        if faces == new_faces:                            # start again from the old file
            cadpipe.primitives.box(1).export(target)
            old_bytes = target.read_bytes()
    assert "old" in seen                                  # some kills landed mid-export
    _export(target, 64)                                   # the next run's write
    assert _temporaries(tmp_path) == [], "a temporary file was left"
    assert _faces(target) == new_faces


@pytest.mark.slow
def test_a_killed_build_leaves_nothing_the_next_build_does_not_remove(tmp_path):
    spec = tmp_path / "cell.toml"
    spec.write_text("".join(f'[[parts]]\nkind = "sphere"\nradius = 1\nsegments = 160\n'
                            f'transform = {{translate = [{0.5 * i}, 0, 0]}}\n'
                            for i in range(12)))
    out = tmp_path / "out" / "cell.stl"
    argv = [sys.executable, "-m", "cadpipe", "build", str(spec), "-o", str(out)]
    rng = np.random.default_rng(3)
    for _ in range(4):
        proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        while "writing" not in (line := proc.stdout.readline()) and line:
            pass
        time.sleep(float(rng.uniform(0, 0.3)))
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=60)
        assert not out.exists() or len(load_mesh(out).faces) > 0
    done = subprocess.run(argv, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert _temporaries(out.parent) == []
    assert load_mesh(out).is_watertight
