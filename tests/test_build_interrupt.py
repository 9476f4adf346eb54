"""Ctrl-C on ``cadpipe build``: it ends at once, also inside a long manifold3d union or a
large write, and leaves no partial or temporary file."""

import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import cadpipe

pytestmark = pytest.mark.slow


def crossing_pipes(count, seed=0):
    """A spec of ``count`` pipes crossing in one cube: one long union."""
    rng = np.random.default_rng(seed)
    parts = []
    for k in range(count):
        a, b = rng.uniform(0, 1, 3), rng.uniform(0, 1, 3)
        middle = (a + b) / 2 + rng.normal(0, 0.02, 3)
        points = ", ".join(f"[{x:.4f}, {y:.4f}, {z:.4f}]" for x, y, z in (a, middle, b))
        parts.append(f'[[parts]]\nkind = "pipe"\nname = "p{k}"\nradius = 0.02\nsides = 24\n'
                     f"path = {{points = [{points}], spline = true, step = 0.01}}\n")
    return 'name = "long"\n' + "\n".join(parts)


BIG_PIPE = """name = "big"
[[parts]]
kind = "pipe"
radius = 0.02
sides = 16
[parts.path]
points = [[0, 0, 0], [10, 0, 2], [10, 10, 4], [0, 10, 6], [0, 0, 8]]
spline = true
step = 0.0006
"""


def start(folder, body, outputs):
    spec = folder / "job.toml"
    spec.write_text(body)
    return subprocess.Popen(
        [sys.executable, "-m", "cadpipe", "build", str(spec), "--max-triangles", "20000000",
         *[arg for name in outputs for arg in ("-o", str(folder / name))]],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=folder)


def interrupt_after(proc, fragment, delay):
    """Send SIGINT ``delay`` seconds after a stdout line holding ``fragment``; returns
    the lines seen before it and the seconds from the signal to the exit."""
    seen = []
    for line in proc.stdout:
        seen.append(line)
        if fragment in line:
            break
    time.sleep(delay)
    assert proc.poll() is None, f"ended before the interrupt: {proc.stderr.read()}"
    sent = time.monotonic()
    proc.send_signal(signal.SIGINT)
    try:
        proc.wait(timeout=30)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
    return seen, time.monotonic() - sent


def leftovers(folder):
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


def test_ctrl_c_inside_a_long_union_ends_the_build_at_once(tmp_path):
    proc = start(tmp_path, crossing_pipes(300), ["long.stl", "long.glb"])
    seen, waited = interrupt_after(proc, "union of", 3.0)
    assert waited < 2.0
    # ended by SIGINT as the shell expects (it reports 130), before writing anything
    assert proc.returncode in (-signal.SIGINT, 130)
    assert not any("writing" in line for line in seen)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["job.toml"]


def test_ctrl_c_while_writing_exits_130_and_leaves_whole_files_only(tmp_path):
    names = ["big.obj", "big.ply", "big.stl", "big.glb"]
    proc = start(tmp_path, BIG_PIPE, names)
    seen, waited = interrupt_after(proc, "writing big.obj", 0.3)
    assert waited < 2.0
    assert proc.returncode == 130
    assert proc.stderr.read().strip().splitlines() == ["cadpipe build: interrupted"]
    assert leftovers(tmp_path) == []                     # no temporary file
    for name in names:                                   # any file written is whole
        if (tmp_path / name).exists():
            assert cadpipe.Mesh.load(tmp_path / name).is_watertight
    assert not (tmp_path / names[-1]).exists()
