"""Batched geometry: many pipes in one set of arrays give what each pipe gives alone."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import cadpipe
from cadpipe import Path, Pipe, splice
from cadpipe.core.distance import segment_distance
from cadpipe.geometry.clearance import RIGHT_ANGLE, _units_meet, distant_pairs, reach
from cadpipe.geometry.loft import Surface
from cadpipe.geometry.surfaces import tubes_of
from cadpipe.geometry.ragged import Groups
from cadpipe.geometry.rings import ring_basis


def per_item(counts, closed, values):
    """Successor, predecessor and running sum of each row, item by item in Python."""
    following, preceding, running, sums = [], [], [], []
    start = 0
    for n, loop in zip(counts, closed):
        item = list(values[start:start + n])
        following += item[1:] + [item[0] if loop else item[-1]]
        preceding += [item[-1] if loop else item[0]] + item[:-1]
        running += list(np.concatenate([[0.0], np.cumsum(item)[:-1]]))
        sums.append(sum(item))
        start += n
    return np.array(following), np.array(preceding), np.array(running), np.array(sums)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.integers(1, 6), st.booleans()), min_size=1, max_size=6),
       st.data())
def test_groups_shift_and_sum_within_items(items, data):
    counts, closed = zip(*items)
    groups = Groups(counts, closed)
    values = np.arange(groups.size) * 1.5 + 1.0
    following, preceding, running, sums = per_item(counts, closed, values)
    assert np.array_equal(groups.following(values), following)
    assert np.array_equal(groups.preceding(values), preceding)
    assert np.allclose(groups.exclusive_cumsum(values), running, rtol=0, atol=1e-12)
    assert np.allclose(groups.sums(values), sums)
    start = data.draw(st.integers(0, groups.size - 1))
    stop = data.draw(st.integers(start + 1, groups.size))
    vectors = np.stack([values, -values, 2 * values])          # component-first (3, N)
    assert np.array_equal(groups.following(vectors, start, stop), np.stack(
        [following, -following, 2 * following])[:, start:stop])
    assert np.array_equal(groups.preceding(values, start, stop), preceding[start:stop])


def assorted_pipes():
    t = np.linspace(0, 4 * np.pi, 400)
    helix = np.c_[np.cos(t), np.sin(t), 0.3 * t]
    s = np.linspace(0, 2 * np.pi, 120, endpoint=False)
    knot = np.c_[np.sin(s) + 2 * np.sin(2 * s), np.cos(s) - 2 * np.cos(2 * s), -np.sin(3 * s)]
    return [
        Pipe(helix, 0.05, sides=16),
        Pipe(Path(knot, closed=True), 0.2, sides=9, envelope=True),
        Pipe(helix[:150] + [3, 0, 0], np.linspace(0.03, 0.06, 150), sides=6,
             normal=[0, 0, 1], end_normal=[0, 1, 0], caps="round"),
        Pipe(helix[:90] + [0, 4, 0], 0.04, sides=5, frame="patent"),
        Pipe([[0, 0, 0], [1, 0, 0], [1, 1, 0], [2, 1, 1]], 0.1, sides=12, corners="round"),
        Pipe([[0, 0, 0], [1, 0, 0], [1, 1, 0]], 0.1, sides=4),
        Pipe([[0, 0, 0], [2, 0, 0], [2, 2, 0], [1, 2, 0], [1, -1, 0.1]], 0.2, sides=7),
    ]


def test_a_batch_of_pipes_matches_each_pipe_alone():
    pipes = assorted_pipes()
    batch = tubes_of(pipes)
    findings = batch.self_intersection_findings()
    for g, pipe in enumerate(pipes):
        alone = tubes_of([pipe])
        rows = slice(batch.groups.first[g], batch.groups.last[g] + 1)
        scale = np.abs(alone.axes).max()
        assert np.allclose(batch.axes[rows], alone.axes, rtol=0, atol=1e-12 * scale)
        assert np.allclose(batch.normals[:, rows], alone.normals, rtol=0, atol=1e-12)
        assert batch.seam_shift[g] == alone.seam_shift[0]
        assert np.array_equal(batch.lines.arc_length[rows] > 0, alone.lines.arc_length > 0)
        assert findings[g] == pipe.self_intersection_findings()
    assert findings[-1] and "passes within" in findings[-1][0]      # the crossing path


def triangles(vertices, faces):
    """Each face as its corner coordinates, rotated to start at its smallest corner."""
    tri = np.round(vertices[faces], 9)
    first = np.array([min(range(3), key=lambda k: tuple(t[k])) for t in tri])
    tri = tri[np.arange(len(tri))[:, None], (first[:, None] + np.arange(3)) % 3]
    return tri[np.lexsort(tri.reshape(len(tri), -1).T[::-1])]


@pytest.mark.parametrize("transition", ["lcm", "merge"])
def test_spliced_pipes_keep_their_own_surfaces(transition):
    pipes = [Pipe(np.c_[np.linspace(3 * i, 3 * i + 2, 20), np.sin(np.linspace(0, 2, 20)) * 0.3,
                        np.zeros(20)], 0.1 + 0.02 * i, sides=sides, caps="round")
             for i, sides in enumerate([5, 8, 5, 12])]
    mesh = splice(*pipes, transition=transition)
    assert mesh.is_watertight and mesh.volume > 0
    last = len(pipes) - 1
    for i, pipe in enumerate(pipes):
        own = pipe.surface(cap_start=i == 0, cap_end=i == last)
        part = mesh.faces[mesh.face_part == mesh.part_names.index(f"pipe{i}")]
        assert np.array_equal(triangles(mesh.vertices, part), triangles(*own))


def brute_force_pairs(tubes):
    """Every pair of non-adjacent segments whose capsules meet, whose joining
    stretches both turn by a right angle or more and whose units overlap, from
    full matrices."""
    lines, groups = tubes.lines, tubes.groups
    r = reach(tubes)
    found = set()
    for g in range(len(groups)):
        lo, n, loop = groups.first[g], groups.counts[g], groups.closed[g]
        m = n if loop else n - 1                                  # segments
        rad = np.maximum(r[lo:lo + n], np.roll(r[lo:lo + n], -1))[:m]
        turn = np.cumsum(lines.turning_angles[lo:lo + n])
        i, j = np.triu_indices(m, 2)
        forward = turn[j] - turn[i]
        bent = forward >= RIGHT_ANGLE
        if loop:
            bent &= (turn[-1] - forward >= RIGHT_ANGLE) & ~((i == 0) & (j == m - 1))
        i, j = i[bent] + lo, j[bent] + lo
        d = segment_distance(lines.xyz[:, i], lines.segments[:, i], lines.xyz[:, j],
                             lines.segments[:, j], axis=0)
        close = d < rad[i - lo] + rad[j - lo]
        i, j = i[close], j[close]
        meet = _units_meet(tubes, i, j)
        found |= set(zip(i[meet].tolist(), j[meet].tolist()))
    return found


@settings(max_examples=15, deadline=None)
@given(st.floats(0.05, 0.6), st.floats(0.03, 0.15), st.integers(2, 4), st.booleans())
def test_distant_pairs_are_exactly_the_brute_force_ones(pitch, radius, turns, closed):
    """The capsule tree's pruning misses no pair and invents none."""
    t = np.linspace(0, turns * np.pi, 25 * turns)
    coil = np.c_[np.cos(t), np.sin(t), pitch * t / np.pi]
    crossing = [[0, 0, 0], [2, 0, 0], [2, 2, 0], [1, 2, 0], [1, -1, 0.1]]
    hairpin = [[0, 0, 0], [1, 0, 0], [1, radius, 0], [0, radius, 0]]   # legs closer than 2r
    paths = [Path(coil), Path(crossing, closed=closed), Path(coil[::3], closed=closed),
             Path(hairpin, closed=closed)]
    tubes = tubes_of([Pipe(p, radius * np.linspace(1, 1.6, len(p)), miter_limit=1e6)
                      for p in paths])
    i, j, _, _ = distant_pairs(tubes)
    assert set(zip(i.tolist(), j.tolist())) == brute_force_pairs(tubes)


def test_surface_groups_runs_by_size_and_keeps_each_run():
    rng = np.random.default_rng(3)
    runs = [rng.normal(size=(n, 3, 3)) for n in (4, 2, 5, 3, 1)]
    sides = [3, 5, 3, 5, 7]                  # a lone ring has no side faces of its own
    surface = Surface()
    first = surface.add_rings(runs, sides)
    vertices, faces, _ = surface.build()
    assert list(first) == [0, 4 * 3 + 5 * 3, 4 * 3, 4 * 3 + 5 * 3 + 2 * 5, 27 + 25]  # by size
    for run, size, start in zip(runs, sides, first):
        rings = np.matmul(ring_basis(size), run).reshape(-1, 3)
        assert np.array_equal(vertices[start:start + len(rings)], rings)
    assert len(faces) == sum(2 * s * (len(r) - 1) for r, s in zip(runs, sides))
    # every vertex is used but the lone ring's
    assert np.array_equal(np.unique(faces), np.arange(len(vertices) - 7))


def test_single_pipe_surface_is_laid_out_as_documented():
    pipe = Pipe([[0, 0, 0], [0, 0, 1], [0, 1, 2]], 0.1, sides=6, caps="round", cap_segments=3)
    vertices, faces = pipe.surface()
    rings = pipe.rings().reshape(-1, 3)
    cap_rings = (pipe.cap_segments - 1) * pipe.sides
    # start cap rings, the pipe's own rings, end cap rings, then the two poles
    assert np.allclose(vertices[cap_rings:cap_rings + len(rings)], rings, atol=1e-15)
    assert len(vertices) == len(rings) + 2 * cap_rings + 2
    mesh = cadpipe.Mesh(vertices, faces)
    assert mesh.is_watertight and mesh.volume > 0
