"""Thread-safe from the first call: threads started right after ``import cadpipe`` that
mesh, union, check a robot and write and read files all finish, in every fresh process
(before: 8 such threads hung at 0 CPU in 3 of 5 processes, two native libraries'
loaders waiting on each other)."""

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

SCRIPT = """
import os, sys, tempfile, threading
import cadpipe
from cadpipe.collision import Robot

out, errors = tempfile.mkdtemp(), []

def pipe():
    path = cadpipe.Path.spline([[0, 0, 0], [1, 0, 0], [1, 1, 0.5]], step=0.02)
    assert cadpipe.Pipe(path, 0.05, sides=12, caps="round").mesh().is_watertight

def union():
    asm = cadpipe.Assembly()
    asm.add("p", cadpipe.Pipe([[0, 0, 0], [1, 0, 0], [1, 1, 0]], 0.1, sides=12))
    asm.add("b", cadpipe.primitives.box([0.3, 0.3, 0.3]))
    assert asm.union().is_watertight

def check():
    robot = Robot.from_urdf("assets/robots/panda/panda.urdf",
                            srdf="assets/robots/panda/panda.srdf")
    world = cadpipe.CollisionWorld()
    world.add_robot(robot)
    world.check()

def files(k):
    mesh = cadpipe.Pipe([[0, 0, 0], [1, 0, 0]], 0.1, sides=8).mesh()
    for suffix in ("stl", "glb", "usda", "3mf"):
        path = os.path.join(out, f"t{k}.{suffix}")
        mesh.export(path)
        assert len(cadpipe.Mesh.load(path).faces) == len(mesh.faces)

def run(job):
    try:
        job()
    except Exception as exc:
        errors.append(repr(exc))

jobs = [pipe, union, check, lambda: files(0), pipe, union, check, lambda: files(1)]
threads = [threading.Thread(target=run, args=(job,), daemon=True) for job in jobs]
for t in threads:
    t.start()
for t in threads:
    t.join(60)
print(sum(t.is_alive() for t in threads), errors)
sys.stdout.flush()
os._exit(0)
"""


@pytest.mark.slow
def test_eight_threads_right_after_import_finish_in_twenty_fresh_processes():
    for _ in range(20):
        done = subprocess.run([sys.executable, "-c", SCRIPT], cwd=ROOT, capture_output=True,
                              text=True, timeout=90)
        assert done.stdout.strip() == "0 []", done.stdout + done.stderr
