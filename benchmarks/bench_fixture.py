"""Fixture queries: cadpipe's ``locate`` against a KD-tree baseline and trimesh.

500,000 points (``--points``) around a 300-point helix safety pipe (radius 0.1):
near the pipe (within about its radius) and anywhere in its bounding box.

* cadpipe ``fixture.locate`` (inside, signed wall distance, nearest centreline
  point, arc length, tangent; exact: the minima over every segment);
* the KD-tree glue of issue 11: scipy's ``cKDTree`` over the segments' midpoints,
  8 candidate segments per point projected, the nearest kept (signed distance
  only; unverified: it can miss the nearest segment);
* trimesh ``proximity.signed_distance`` on the pipe's mesh (on 2,000 of the points;
  its sign is the other way round: positive inside);

and the ordered query ``fixture.leaves`` on a 10,000-point tool path along the pipe.
Medians of ``--repeat`` rounds, all methods interleaved in one process (A B A B ...)
after one untimed round; the machine is shared, so read the ratios.

Run: .venv/bin/python benchmarks/bench_fixture.py [--points N] [--repeat R]
"""

import argparse
import os

import numpy as np
import trimesh
from scipy.spatial import cKDTree

from _common import interleaved, kdtree_baseline
from cadpipe import Path, Pipe
from cadpipe.collision.fixture import leaves, locate


def brute_force(centres, points, radius):
    """Every segment for every point: the exact reference for the first 20,000 points."""
    a, b = centres[:-1], centres[1:]
    axis = b - a
    out = np.empty(len(points))
    for start in range(0, len(points), 2000):
        p = points[start:start + 2000]
        t = np.clip(np.einsum("mki,ki->mk", p[:, None] - a, axis)
                    / np.einsum("ki,ki->k", axis, axis), 0.0, 1.0)
        out[start:start + 2000] = np.linalg.norm(p[:, None] - (a + t[..., None] * axis),
                                                 axis=2).min(axis=1) - radius
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=500_000)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    t = np.linspace(0, 6 * np.pi, 300)
    centres = np.stack([np.cos(t), np.sin(t), 0.1 * t], axis=1)
    radius = 0.1
    pipe = Pipe(Path(centres), radius=radius)
    rng = np.random.default_rng(0)
    n = args.points
    clouds = {"near the pipe": centres[rng.integers(0, 300, n)] + rng.normal(0, 0.08, (n, 3)),
              "in its bounding box": rng.uniform([-1.3, -1.3, -0.2], [1.3, 1.3, 2.1], (n, 3))}
    a, b = centres[:-1], centres[1:]
    tree = cKDTree(0.5 * (a + b))
    mesh = trimesh.Trimesh(pipe.mesh().vertices, pipe.mesh().faces)
    at = np.linspace(0, 299, 10_000)
    k = np.minimum(at.astype(int), 298)
    path = centres[k] + (at - k)[:, None] * (centres[k + 1] - centres[k]) \
        + rng.normal(0, 0.02, (len(at), 3))
    print(f"fixture queries: {n} points, 300-point helix pipe of radius {radius}; medians of "
          f"{args.repeat} interleaved rounds; load average {os.getloadavg()[0]:.1f} before")
    for label, points in clouds.items():
        sub = points[:2000]
        runs = {"cadpipe locate (5 answers, exact)": lambda points=points: locate(pipe, points),
                "KD-tree + projection (distance only)":
                    lambda points=points: kdtree_baseline(tree, a, b, points, radius),
                "trimesh signed_distance (mesh, 2,000 points)":
                    lambda sub=sub: trimesh.proximity.signed_distance(mesh, sub)}
        if label == "near the pipe":
            runs["cadpipe leaves (10,000-point tool path)"] = lambda: leaves(pipe, path)
        seconds, out = interleaved(runs, args.repeat)
        exact = brute_force(centres, points[:20_000], radius)
        found = out["cadpipe locate (5 answers, exact)"].signed_distance[:20_000]
        glue = out["KD-tree + projection (distance only)"][:20_000]
        print(f"  {label}:")
        base = n / seconds["KD-tree + projection (distance only)"]
        for name, s in seconds.items():
            count = 2000 if "trimesh" in name else len(path) if "leaves" in name else n
            print(f"    {name:46s} {count / s:10.0f} points/s   {count / s / base:6.2f}x the "
                  "KD-tree")
        print(f"    against brute force on 20,000 points: locate off by at most "
              f"{np.abs(found - exact).max():.1e}; the KD-tree wrong (> 1e-9) at "
              f"{int((np.abs(glue - exact) > 1e-9).sum())}")
    print(f"  load average after: {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
