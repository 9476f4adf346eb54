"""Where a tube would cut through itself.

Three ways a swept tube folds: a corner sharper than the miter limit, rings that
overlap within one segment (the radius exceeds the local bend radius), and two
parts of the tube that are far apart along the path but closer in space than the
sum of their radii. All three are vectorized over the path.
"""

import numpy as np

from ._vec import dot, norm


def tube_self_intersections(pipe):
    """Findings (strings naming path points and arc lengths) for ``pipe``; empty if none."""
    return _miter_limit(pipe) or _local_overlaps(pipe) or _distant_overlaps(pipe)


def _where(path, i):
    return f"path point {i} at arc length {path.arc_length[i]:.6g}"


def _miter_limit(pipe):
    bad = np.flatnonzero(pipe.miter_stretch > pipe.miter_limit)
    path = pipe.path
    return [f"{_where(path, i)}: a {np.degrees(path.turning_angles[i]):.1f} degree corner needs "
            f"a miter stretch of {pipe.miter_stretch[i]:.3g} > miter_limit={pipe.miter_limit:g} "
            "(use corners='round' or a larger miter_limit)" for i in bad[:10]]


def _local_overlaps(pipe):
    """Within a segment, the two end rings' planes must not meet inside the tube.

    Across segment j (direction d, length L), the ring plane at each end sits at an
    axial offset ``y . g`` for a lateral offset y, where g is the tangent's part
    across d divided by its part along d. The planes meet inside a tube of radius
    rho exactly when ``rho * |g_start - g_end| >= L``.
    """
    path = pipe.path
    d = path.directions
    j = np.arange(len(d))
    k = (j + 1) % len(path)
    t = path.tangents

    def g(tangent):
        along = dot(tangent, d)
        return -(tangent - along[:, None] * d) / along[:, None]

    spread = norm(g(t[j]) - g(t[k]))
    rho = np.maximum(pipe.ring_radii[j], pipe.ring_radii[k])
    bad = np.flatnonzero(rho * spread >= path.segment_lengths * (1 - 1e-9))
    return [f"{_where(path, i)}: radius {pipe.ring_radii[i]:.6g} exceeds the local bend radius "
            f"(about {path.segment_lengths[i] / spread[i]:.6g})" for i in bad[:10]]


def _distant_overlaps(pipe):
    """Pairs of path samples closer than their radii where the distance along the
    path has a local minimum (a chord across the tube, not along it).

    Samples every quarter of the smallest radius keep the detection error to a few
    thousandths of the radius.
    """
    from scipy.spatial import cKDTree      # imported here: the CLI starts faster without it

    path = pipe.path
    rho = pipe.ring_radii
    step = 0.25 * float(rho.min())
    closed = path.closed
    s_pts = np.append(path.arc_length, path.length) if closed else path.arc_length
    count = max(int(np.ceil(path.length / step)), 2)
    s = np.linspace(0.0, path.length, count, endpoint=not closed)
    pts_ext = np.vstack([path.points, path.points[:1]]) if closed else path.points
    rho_ext = np.append(rho, rho[0]) if closed else rho
    samples = np.stack([np.interp(s, s_pts, pts_ext[:, c]) for c in range(3)], axis=1)
    r = np.interp(s, s_pts, rho_ext)
    pairs = cKDTree(samples).query_pairs(2.0 * float(rho.max()), output_type="ndarray")
    if len(pairs) == 0:
        return []
    i, j = pairs[:, 0], pairs[:, 1]
    dist = norm(samples[i] - samples[j])
    close = dist < r[i] + r[j]
    i, j, dist = i[close], j[close], dist[close]
    n = len(samples)
    local_min = np.ones(len(i), bool)
    for di, dj in ((-1, 0), (1, 0), (0, -1), (0, 1)):
        ii, jj = i + di, j + dj
        if closed:
            ii, jj = ii % n, jj % n
            valid = np.ones(len(i), bool)
        else:
            valid = (ii >= 0) & (ii < n) & (jj >= 0) & (jj < n)
        ii, jj = ii.clip(0, n - 1), jj.clip(0, n - 1)
        other = norm(samples[ii] - samples[jj])
        local_min &= ~valid | (other >= dist)
    gap = np.abs(s[i] - s[j])
    if closed:
        gap = np.minimum(gap, path.length - gap)
    hits = np.flatnonzero(local_min & (gap > 2.0 * step))
    out = []
    for h in hits[:10]:
        a = int(np.searchsorted(path.arc_length, s[i[h]], side="right") - 1)
        b = int(np.searchsorted(path.arc_length, s[j[h]], side="right") - 1)
        out.append(f"{_where(path, a)} and {_where(path, b)}: the tube passes within "
                   f"{dist[h]:.6g} of itself, less than its radii {r[i[h]]:.6g} + {r[j[h]]:.6g}")
    return out
