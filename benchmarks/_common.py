"""What the benchmarks share: interleaved timing, the python-fcl loop peer, scenes.

``bench_collision.py`` (one state at a time) and ``bench_motion.py`` (motions and
planning) time cadpipe against the same 15-line python-fcl loop of issue 11; it
lives here once so both measure the same peer.
"""

import resource
import time

import fcl
import numpy as np
import trimesh

from cadpipe import Mesh, Path, Pipe
from cadpipe.collision.bodies import as_body


def interleaved(runs, repeat, clock=time.perf_counter):
    """Median seconds of each of ``runs`` (name -> callable), timed A B A B ... after
    one untimed round (caches, lazily built trees, JIT compilation); and each run's
    last result. ``clock=time.process_time`` reads CPU time, which a shared
    machine's load inflates less than wall time."""
    results = {name: run() for name, run in runs.items()}
    times = {name: [] for name in runs}
    for _ in range(repeat):
        for name, run in runs.items():
            start = clock()
            results[name] = run()
            times[name].append(clock() - start)
    return {name: float(np.median(t)) for name, t in times.items()}, results


def fcl_object(mesh):
    bvh = fcl.BVHModel()
    bvh.beginModel(len(mesh.vertices), len(mesh.faces))
    bvh.addSubModel(np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64))
    bvh.endModel()
    return fcl.CollisionObject(bvh, fcl.Transform())


def obstacle_mesh(obj):
    return obj.mesh() if isinstance(obj, Pipe) else as_body(obj, "x").mesh


class FclLoop:
    """The python-fcl loop a user writes (issue 11): FK, then the robot's pairs (self
    pairs not allowed, links against obstacles) until the first hit."""

    def __init__(self, robot, obstacles, allowed):
        self.robot, self.links = robot, list(robot.link_meshes)
        self.objects = {n: fcl_object(m) for n, m in robot.link_meshes.items()}
        for name, (obj, pose) in obstacles.items():
            self.objects[name] = o = fcl_object(obstacle_mesh(obj))
            o.setTransform(fcl.Transform(pose[:3, :3], pose[:3, 3]))
        names = self.links + list(obstacles)
        self.pairs = [(self.objects[a], self.objects[b]) for i, a in enumerate(names)
                      for b in names[i + 1:] if frozenset((a, b)) not in allowed
                      and (a in robot.link_meshes or b in robot.link_meshes)]
        self.request = fcl.CollisionRequest()

    def __call__(self, q):
        for link, pose in zip(self.links, self.robot.link_pose_array(q)[0]):
            self.objects[link].setTransform(fcl.Transform(pose[:3, :3], pose[:3, 3]))
        for a, b in self.pairs:
            if fcl.collide(a, b, self.request, fcl.CollisionResult()):
                return True
        return False


def kdtree_baseline(tree, a, b, points, radius, k=8):
    """The glue of issue 11: nearest segments by midpoint, projected, no exactness check."""
    _, units = tree.query(points, k=k)
    axis = b[units] - a[units]
    rel = points[:, None] - a[units]
    t = np.clip(np.einsum("mki,mki->mk", rel, axis) / np.einsum("mki,mki->mk", axis, axis),
                0.0, 1.0)
    d = np.linalg.norm(rel - t[..., None] * axis, axis=2)
    return d.min(axis=1) - radius


def pipe_scene():
    """Two safety pipes and a torus mesh: the pipe-pose benchmarks' scene."""
    a = Pipe(Path.spline([[-1.0, -0.6, 0.0], [0.0, 0.4, 0.1], [1.0, -0.5, 0.0]], step=0.05),
             0.15, sides=32, caps="round")
    b = Pipe(Path.spline([[-0.8, 0.0, -0.3], [0.0, 0.3, 0.0], [0.9, 0.1, 0.2]], step=0.05),
             0.12, sides=32, caps="round")
    torus = Mesh.from_trimesh(trimesh.creation.torus(0.5, 0.15, major_sections=48,
                                                     minor_sections=16))
    return a, b, torus


def resident():
    """This process's resident memory now, in bytes (Linux /proc)."""
    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * resource.getpagesize()


def settled():
    """Hand freed memory back to the system (cadpipe's recycled blocks, glibc's heap), so
    the resident memory before a write is what is live, and memory the write takes shows."""
    import ctypes
    import gc

    from cadpipe.geometry import buffers

    gc.collect()
    buffers.release()
    ctypes.CDLL("libc.so.6").malloc_trim(0)
    return resident()
