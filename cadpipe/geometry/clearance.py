"""Where a tube would cut through itself.

Three ways a swept tube folds: a corner sharper than the miter limit, rings that
overlap within one segment (the radius exceeds the local bend radius), and two
parts of the tube that are far apart along the path but closer in space than the
sum of their radii. All three run over a whole batch of tubes at once
(:class:`~cadpipe.geometry.rings.Tubes`): one pass over all points, one KD-tree over
chunks of all tubes' samples.
"""

import numpy as np

from cadpipe._vec import norm
from cadpipe.errors import InputError
from cadpipe.geometry.ragged import Groups

#: findings reported per tube and kind of fold
MAX_FINDINGS = 10
#: path samples a batch may need (each a quarter of its tube's smallest radius apart)
MAX_SAMPLES = 10_000_000


def tube_self_intersections(tubes):
    """Per tube, findings (strings naming path points and arc lengths); empty if none.

    A tube's findings all come from the first check that finds anything for it:
    miter limits, then local overlaps, then distant ones; at most
    :data:`MAX_FINDINGS` each.
    """
    findings = [[] for _ in range(len(tubes.groups))]
    for check in (_miter_limit, _local_overlaps, _distant_overlaps):
        tube, describe = check(tubes)         # hits in path order, so tube is sorted
        rank = np.arange(len(tube)) - np.searchsorted(tube, tube)
        fresh = np.array([not f for f in findings], bool)[tube]
        for hit in np.flatnonzero(fresh & (rank < MAX_FINDINGS)).tolist():
            findings[tube[hit]].append(describe(hit))
    return findings


def _where(lines, row):
    local = row - lines.groups.first[lines.groups.index[row]]
    return f"path point {local} at arc length {lines.arc_length[row]:.6g}"


def _miter_limit(tubes):
    lines = tubes.lines
    stretch = tubes.miter_stretch
    limit = tubes.miter_limit[lines.groups.index]
    bad = np.flatnonzero(stretch > limit)

    def describe(hit):
        i = bad[hit]
        return (f"{_where(lines, i)}: a {np.degrees(lines.turning_angles[i]):.1f} degree "
                f"corner needs a miter stretch of {stretch[i]:.3g} > miter_limit={limit[i]:g} "
                "(use corners='round' or a larger miter_limit)")

    return lines.groups.index[bad], describe


def _local_overlaps(tubes):
    """Within a segment, the two end rings' planes must not meet inside the tube.

    Across segment j (direction d, length L), the ring plane at each end sits at an
    axial offset ``y . g`` for a lateral offset y, where g is the tangent's part
    across d divided by its part along d. The planes meet inside a tube of radius
    rho exactly when ``rho * |g_start - g_end| >= L``.
    """
    lines = tubes.lines
    groups = lines.groups
    # with t the bisector of the segments at a point, t.d = cos(turn / 2) = 1 / stretch
    # for both segments there, so g = d - t * stretch and the difference across segment
    # j is the change of t * stretch from point j to point j + 1
    with np.errstate(invalid="ignore"):                        # folds: found by _miter_limit
        lean = lines.tangents * lines.miter_stretch
        spread = norm(groups.following(lean) - lean, 0)
    rho = tubes.ring_radii
    is_segment = np.ones(len(rho), bool)
    is_segment[groups.last] = groups.closed
    bad = np.flatnonzero(is_segment & (np.maximum(rho, groups.following(rho)) * spread
                                       >= lines.segment_lengths * (1 - 1e-9)))

    def describe(hit):
        i = bad[hit]
        return (f"{_where(lines, i)}: radius {rho[i]:.6g} exceeds the local bend radius "
                f"(about {lines.segment_lengths[i] / spread[i]:.6g})")

    return groups.index[bad], describe


def _samples(tubes, step):
    """Points and radii every ``step`` (per tube) along each tube's path.

    Returns the sample groups, their (3, S) positions, arc lengths and radii.
    """
    lines = tubes.lines
    groups = lines.groups
    closed = groups.closed
    length = lines.lengths
    count = np.maximum(np.ceil(length / step), 2)
    if count.sum() > MAX_SAMPLES:
        g = int(np.argmax(count))
        raise InputError(f"{4 * step[g]:g} is too small for a path {length[g]:.6g} long: "
                         f"checking the tube for self-intersection would take {count[g]:.3g} "
                         "samples; use a larger radius or a shorter path", key="radius")
    count = count.astype(np.int64)
    samples = Groups(count, closed)
    k = samples.local()
    s = k * samples.spread(length / np.where(closed, count, count - 1))
    s[samples.last[~closed]] = length[~closed]                 # as np.linspace does
    # the segment each sample lies on: sort samples among path points, tube by tube
    offset = np.concatenate([[0.0], np.cumsum(length + 1.0)])[:-1]
    row = np.searchsorted(lines.arc_length + groups.spread(offset), s + samples.spread(offset),
                          side="right") - 1
    last_segment = np.where(closed, groups.last, groups.last - 1)
    row = np.clip(row, samples.spread(groups.first), samples.spread(last_segment))
    frac = (s - lines.arc_length[row]) / lines.segment_lengths[row]
    points = lines.xyz[:, row] + frac * lines.segments[:, row]
    rho = tubes.ring_radii
    radii = rho[row] + frac * (groups.following(rho)[row] - rho[row])
    return samples, points, s, radii


def _distant_overlaps(tubes):
    """Pairs of path samples closer than their radii where the distance along the
    path has a local minimum (a chord across the tube, not along it); see
    :func:`distant_pairs`."""
    lines = tubes.lines
    groups = lines.groups
    samples, s, radii, i, j, dist = distant_pairs(tubes)
    tube = samples.index[i]

    def point_at(sample):
        """The path point starting the segment a sample lies on."""
        g = samples.index[sample]
        first, last = groups.first[g], groups.last[g]
        return first + int(np.searchsorted(lines.arc_length[first:last + 1], s[sample],
                                           side="right")) - 1

    def describe(hit):
        a, b = i[hit], j[hit]
        return (f"{_where(lines, point_at(a))} and {_where(lines, point_at(b))}: the tube "
                f"passes within {dist[hit]:.6g} of itself, less than its radii "
                f"{radii[a]:.6g} + {radii[b]:.6g}")

    return tube, describe


def distant_pairs(tubes):
    """Sample pairs, one tube's each, closer than their radii where the distance
    along the path has a local minimum over the sample grid and the samples are more
    than two steps apart along the path.

    Samples every quarter of each tube's smallest radius keep the detection error to
    a few thousandths of the radius. Candidate pairs come from two sources that
    together cover every pair within reach (twice the largest radius): pairs a few
    samples apart (:func:`_band_pairs`) and pairs of chunks of samples a KD-tree
    finds close (:func:`_chunk_pairs`); neither enumerates the many trivial pairs
    of neighbours along the tube that a KD-tree over all samples would.
    """
    lines = tubes.lines
    groups = lines.groups
    rho = tubes.ring_radii
    reach = 2.0 * np.maximum.reduceat(rho, groups.first)      # the farthest a pair can reach
    step = 0.25 * np.minimum.reduceat(rho, groups.first)
    samples, points, s, radii = _samples(tubes, step)
    spacing = lines.lengths / np.where(samples.closed, samples.counts, samples.counts - 1)
    near = np.ceil(reach / spacing).astype(np.int64)   # samples a straight run stays in reach
    chunk = np.maximum(near // 2, 1)
    # beyond this many samples apart, chunks whose middles are within reach are not
    # neighbours along the tube; a tube is never farther apart than this around it
    count = samples.counts
    band = np.minimum(near + 2 * chunk, np.where(samples.closed, count // 2, count - 1))
    i, j = (np.concatenate(p) for p in zip(_band_pairs(samples, points, radii, band),
                                           _chunk_pairs(samples, points, reach, spacing,
                                                        chunk, band)))
    i, j = np.minimum(i, j), np.maximum(i, j)
    points = np.ascontiguousarray(points.T)                   # rows: fast to gather pairs of
    tube = samples.index[i]
    length = lines.lengths[tube]
    gap = np.abs(s[i] - s[j])
    gap = np.where(samples.closed[tube], np.minimum(gap, length - gap), gap)
    keep = np.flatnonzero(gap > 2.0 * step[tube])
    i, j = i[keep], j[keep]
    dist = norm(points[i] - points[j])
    keep = np.flatnonzero(dist < radii[i] + radii[j])
    i, j, dist = i[keep], j[keep], dist[keep]
    # a local minimum over the sample grid
    first, count = samples.first, samples.counts
    for di, dj in ((1, 0), (-1, 0), (0, -1), (0, 1)):
        tube = samples.index[i]
        start, n = first[tube], count[tube]
        ii, jj = i + di - start, j + dj - start
        closed = samples.closed[tube]
        valid = closed | ((ii >= 0) & (ii < n) & (jj >= 0) & (jj < n))
        ii, jj = start + ii % n, start + jj % n
        keep = np.flatnonzero(~valid | (norm(points[ii] - points[jj]) >= dist))
        i, j, dist = i[keep], j[keep], dist[keep]
    order = np.lexsort((j, i))
    return samples, s, radii, i[order], j[order], dist[order]


def _band_pairs(samples, points, radii, band):
    """Pairs of samples at most ``band`` (per tube) apart along their tube (around a
    closed one), each pair once, that could be a local minimum of distance: closer
    than their radii, and no farther apart than the pair one sample shorter.

    Each tube's samples are followed by ``band`` more (its first ones again if it
    is closed), so the pairs ``m`` apart are two shifted slices of one array. Tubes
    are laid out widest band first: the tubes still taking part at each ``m`` are a
    prefix of it. The loop's arrays are allocated once and reused.
    """
    order = np.argsort(-band, kind="stable")
    n, width = samples.counts[order], band[order]
    ext = Groups(n + width + 1)
    local = ext.local()
    count = ext.spread(n)
    src = ext.spread(samples.first[order]) + local % count
    # the largest m at which a sample still starts a new pair: an open tube ends; around
    # a closed one, the pair m apart is the pair count - m apart the other way
    closed = ext.spread(samples.closed[order])
    halfway = (count - 1) // 2 + ((count % 2 == 0) & (local < count // 2))
    reach_m = np.where(local >= count, -1, np.where(closed, halfway, count - 1 - local))
    p, r = points[:, src], radii[src]
    slack = 1.0 + 1e-9                  # a sieve: the exact test of the candidates follows
    diff = np.empty((3, ext.size))
    d2, previous = np.empty(ext.size), np.zeros(ext.size)   # previous: one sample shorter
    bound = np.empty(ext.size)
    keep, test = np.empty(ext.size, bool), np.empty(ext.size, bool)
    pairs_i, pairs_j = [], []
    for m in range(1, int(width.max(initial=0)) + 1):
        end = int(ext.starts[np.searchsorted(-width, -m, side="right")])   # tubes with band >= m
        size = end - m
        dv, d, lim, ok, t = diff[:, :size], d2[:size], bound[:size], keep[:size], test[:size]
        np.subtract(p[:, m:end], p[:, :size], out=dv)
        np.einsum("i...,i...->...", dv, dv, out=d)
        np.greater_equal(reach_m[:size], m, out=ok)
        np.multiply(previous[:size], slack, out=lim)
        ok &= np.less_equal(d, lim, out=t)
        np.add(r[:size], r[m:end], out=lim)
        np.square(lim, out=lim)
        lim *= slack
        ok &= np.less(d, lim, out=t)
        q = np.flatnonzero(ok)
        pairs_i.append(src[q])
        pairs_j.append(src[q + m])
        d2, previous = previous, d2
    return np.concatenate(pairs_i, dtype=np.int64), np.concatenate(pairs_j, dtype=np.int64)


def _chunk_pairs(samples, points, reach, spacing, chunk, band):
    """Pairs of samples more than ``band`` apart along their tube that may lie within
    ``reach``: all pairs from two chunks of ``chunk`` consecutive samples whose
    middle samples are within ``reach`` plus a chunk's length.

    One KD-tree holds every tube's chunks, each tube scaled by that distance and laid
    apart from the others, so a single query radius finds each tube's own pairs.
    """
    from scipy.spatial import cKDTree  # imported here: the CLI starts faster without it

    n = samples.counts
    chunks = Groups(-(-n // chunk), samples.closed)
    k = chunks.spread(chunk)
    start = chunks.spread(samples.first) + chunks.local() * k
    size = np.minimum(k, chunks.spread(samples.first + n) - start)
    middle = start + np.minimum(k // 2, size - 1)
    scaled = np.ascontiguousarray((points[:, middle] / chunks.spread(reach + chunk * spacing)).T)
    low = np.minimum.reduceat(scaled[:, 0], chunks.first)
    high = np.maximum.reduceat(scaled[:, 0], chunks.first)
    scaled[:, 0] += chunks.spread(np.concatenate([[0.0], np.cumsum(high - low + 2.0)])[:-1] - low)
    a, b = cKDTree(scaled).query_pairs(1.0 + 1e-9, output_type="ndarray").T
    band_of = band[chunks.index]
    keep = np.flatnonzero((b - a + 1) * k[a] - 1 > band_of[a])   # else all within the band
    a, b = a[keep], b[keep]
    # every sample of chunk a with every sample of chunk b
    pairs = Groups(size[a] * size[b])
    offset = pairs.local()
    width = pairs.spread(size[b])
    i = pairs.spread(start[a]) + offset // width
    j = pairs.spread(start[b]) + offset % width
    m = j - i
    count = n[samples.index[i]]
    m = np.where(samples.closed[samples.index[i]], np.minimum(m, count - m), m)
    keep = np.flatnonzero(m > band[samples.index[i]])
    return i[keep], j[keep]
