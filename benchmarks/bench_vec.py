"""Do cadpipe.core.vec's choices pay? Each helper against numpy's own spelling, both layouts.

For N = 100,000 vectors in the component-first ``(3, N)`` layout the batch code
uses and in the row ``(N, 3)`` layout, times (interleaved A B A B, median of
REPEAT rounds, one process):

- norm:  ``sqrt(einsum)`` (``_vec.norm``) vs ``np.linalg.norm``
- dot:   ``einsum`` (``_vec.dot``) vs ``(a * b).sum``
- cross: three component rows (``_vec.cross``) vs ``np.cross``
- layout: each ``_vec`` helper on ``(3, N)`` vs the same helper on ``(N, 3)``

Prints medians in microseconds and ratios (> 1: the ``_vec`` choice is faster).
Run: .venv/bin/python benchmarks/bench_vec.py
"""

import time

import numpy as np

from cadpipe.core.vec import cross, dot, norm

N, REPEAT = 100_000, 41


def interleaved(a, b, repeat=REPEAT):
    """Median seconds of ``a`` and ``b``, run alternately."""
    ta, tb = [], []
    for _ in range(repeat):
        for func, times in ((a, ta), (b, tb)):
            start = time.perf_counter()
            func()
            times.append(time.perf_counter() - start)
    return float(np.median(ta)), float(np.median(tb))


def main():
    rng = np.random.default_rng(0)
    cols, cols2 = rng.normal(size=(3, N)), rng.normal(size=(3, N))
    rows, rows2 = np.ascontiguousarray(cols.T), np.ascontiguousarray(cols2.T)
    cases = [
        ("norm (3, N): _vec vs np.linalg.norm",
         lambda: norm(cols, 0), lambda: np.linalg.norm(cols, axis=0)),
        ("norm (N, 3): _vec vs np.linalg.norm",
         lambda: norm(rows), lambda: np.linalg.norm(rows, axis=1)),
        ("dot (3, N): _vec vs (a*b).sum",
         lambda: dot(cols, cols2, 0), lambda: (cols * cols2).sum(axis=0)),
        ("dot (N, 3): _vec vs (a*b).sum",
         lambda: dot(rows, rows2), lambda: (rows * rows2).sum(axis=1)),
        ("cross (3, N): _vec vs np.cross",
         lambda: cross(cols, cols2, 0), lambda: np.cross(cols, cols2, axis=0)),
        ("cross (N, 3): _vec vs np.cross",
         lambda: cross(rows, rows2), lambda: np.cross(rows, rows2)),
        ("layout, norm: (3, N) vs (N, 3)", lambda: norm(cols, 0), lambda: norm(rows)),
        ("layout, dot: (3, N) vs (N, 3)", lambda: dot(cols, cols2, 0), lambda: dot(rows, rows2)),
        ("layout, cross: (3, N) vs (N, 3)",
         lambda: cross(cols, cols2, 0), lambda: cross(rows, rows2)),
    ]
    print(f"{N:,} vectors, median of {REPEAT} interleaved rounds")
    print(f"{'case':<40}{'_vec/A us':>12}{'other/B us':>12}{'B/A':>8}")
    for label, ours, other in cases:
        a, b = interleaved(ours, other)
        print(f"{label:<40}{a * 1e6:>12.0f}{b * 1e6:>12.0f}{b / a:>8.2f}")


if __name__ == "__main__":
    main()
