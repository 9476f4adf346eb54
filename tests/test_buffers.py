"""Recycled output memory: meshes a user keeps are never overwritten, dropped ones are reused."""

import gc
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
import trimesh

from cadpipe import Pipe, splice
from cadpipe.geometry import buffers

POINTS, SIDES, RADIUS = 12_000, 16, 0.05      # 192,000 vertices: 4.6 MB, faces 9.2 MB


def helix(turns=40.0, rise=0.5):
    t = np.linspace(0, 2 * np.pi * turns * POINTS / 100_000, POINTS)
    return np.c_[np.cos(t), np.sin(t), rise * t / (2 * np.pi)]


def address(a):
    return a.__array_interface__["data"][0]


def snapshot(mesh):
    return mesh.vertices.copy(), mesh.faces.copy()


@pytest.fixture(autouse=True)
def empty_pool():
    gc.collect()
    buffers.release()
    yield
    gc.collect()
    buffers.release()


def test_large_arrays_come_from_blocks_small_ones_do_not():
    small = buffers.empty(1000)
    large = buffers.empty((200_000, 3), np.int64)
    assert small.base is None
    assert large.shape == (200_000, 3) and large.dtype == np.int64
    assert large.flags.writeable and large.flags.c_contiguous
    assert large.base.nbytes >= large.nbytes


def test_a_block_in_use_is_never_handed_out_again():
    a = buffers.empty((300_000, 3))
    a[:] = 1.0
    b = buffers.empty((300_000, 3))
    assert not np.shares_memory(a, b)
    tail = a[-10:]                      # a view is enough to keep the block in use
    del a
    c = buffers.empty((300_000, 3))
    c[:] = 2.0
    assert np.all(tail == 1.0)
    del tail, b, c
    d = buffers.empty((300_000, 3))
    assert buffers.retained_bytes() > 0 and d.base is not None


def test_unused_blocks_are_reused_and_released():
    a = buffers.empty((300_000, 3))
    where, size = address(a), a.base.nbytes
    del a
    assert buffers.retained_bytes() == size
    assert address(buffers.empty((299_000, 3))) == where     # within the slack: reused
    assert buffers.release() == size
    assert buffers.retained_bytes() == 0


def test_kept_pipe_mesh_is_unchanged_by_the_next_one():
    first = Pipe(helix(), RADIUS, sides=SIDES).mesh()
    before = snapshot(first)
    second = Pipe(helix(rise=0.7), RADIUS, sides=SIDES).mesh()
    third = Pipe(helix(rise=0.9), RADIUS, sides=SIDES).mesh()
    for mesh, other in ((first, second), (second, third), (first, third)):
        assert not np.shares_memory(mesh.vertices, other.vertices)
        assert not np.shares_memory(mesh.faces, other.faces)
    assert np.array_equal(first.vertices, before[0]) and np.array_equal(first.faces, before[1])
    assert not np.array_equal(first.vertices, second.vertices)
    assert not first.vertices.flags.writeable and not first.faces.flags.writeable


def test_dropped_mesh_memory_serves_the_next_mesh_with_the_same_result():
    path = helix()
    fresh = Pipe(path, RADIUS, sides=SIDES).mesh()
    reference = snapshot(fresh)
    where = address(fresh.faces)
    del fresh
    reused = Pipe(path, RADIUS, sides=SIDES).mesh()
    assert address(reused.faces) == where
    assert np.array_equal(reused.vertices, reference[0])
    assert np.array_equal(reused.faces, reference[1])
    peer = trimesh.Trimesh(reused.vertices, reused.faces, process=False)
    assert peer.is_watertight and peer.is_winding_consistent
    assert peer.volume == pytest.approx(reused.volume, rel=1e-9)


def test_kept_splices_stay_distinct_with_their_part_labels():
    def chain(rise):
        pipes = [Pipe(helix(rise=rise)[k * 4000:(k + 1) * 4000 - 200], RADIUS, sides=s)
                 for k, s in enumerate((16, 12, 8))]
        return splice(*pipes)

    first = chain(0.5)
    vertices, faces = snapshot(first)
    labels = first.face_part.copy()
    second = chain(0.6)
    assert not np.shares_memory(first.faces, second.faces)
    assert not np.shares_memory(first.face_part, second.face_part)
    assert np.array_equal(first.vertices, vertices) and np.array_equal(first.faces, faces)
    assert np.array_equal(first.face_part, labels)
    assert first.is_watertight and second.is_watertight


def test_meshes_built_in_threads_equal_those_built_one_by_one():
    rises = [0.5, 0.6, 0.7, 0.8, 0.5, 0.6]
    expected = [snapshot(Pipe(helix(rise=r), RADIUS, sides=SIDES).mesh()) for r in rises]
    with ThreadPoolExecutor(3) as pool:
        meshes = list(pool.map(lambda r: Pipe(helix(rise=r), RADIUS, sides=SIDES).mesh(), rises))
    for mesh, (vertices, faces) in zip(meshes, expected):
        assert np.array_equal(mesh.vertices, vertices) and np.array_equal(mesh.faces, faces)
    for i in range(len(meshes)):
        for j in range(i):
            assert not np.shares_memory(meshes[i].faces, meshes[j].faces)


def test_memory_left_behind_stays_within_the_limit(monkeypatch):
    monkeypatch.setattr(buffers, "RETAIN_BYTES", 3 * (8 << 20))
    kept = [buffers.empty((1 << 20,)) for _ in range(6)]       # 8 MiB each, all in use
    for a in kept:
        a[:] = 1.0
    assert len({address(a) for a in kept}) == 6
    del kept
    assert buffers.retained_bytes() <= buffers.RETAIN_BYTES
    monkeypatch.setattr(buffers, "RETAIN_BYTES", 0)              # recycling off
    buffers.release()
    buffers.empty((1 << 20,))
    assert buffers.retained_bytes() == 0


def test_unused_blocks_of_other_sizes_are_dropped_behind_one_in_use(monkeypatch):
    monkeypatch.setattr(buffers, "RETAIN_BYTES", 24 << 20)
    kept = buffers.empty(1 << 20)                  # 8 MiB, in use, first in the list
    dropped = buffers.empty(2 << 20)               # 16 MiB, then unused
    del dropped
    bigger = buffers.empty(3 << 19)                # 12 MiB: too small a fit, so a new block
    assert not np.shares_memory(kept, bigger)
    assert buffers.retained_bytes() == 0           # the unused 16 MiB went to make room
    del bigger
    assert buffers.release() == 12 << 20
    assert kept.base is not None and buffers.retained_bytes() == 0
