"""Frames: untwisted along straight segments, a patent frame that stays valid or
refuses, end normals that never pinch the tube."""

import numpy as np
import pytest

import cadpipe
from cadpipe import Path, Pipe

# two corners in different planes, so the middle segment sits between non-coplanar bends
SKEW = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [1, 1, 1], [2, 1, 1.3]]


def sideways(pipe):
    """Per segment, the largest step of a ring vertex across the segment's direction
    between its two rings: zero when the ring does not twist along it."""
    rings, d = pipe.rings(), pipe.path.directions
    step = rings[1:] - rings[:-1]
    across = step - np.einsum("skc,sc->sk", step, d)[..., None] * d[:, None]
    return np.linalg.norm(across, axis=2).max(axis=1)


def test_straight_segments_between_non_coplanar_corners_do_not_twist():
    """Double reflection twisted the middle segments by 19.5 degrees."""
    duct = Pipe(SKEW, 0.05, 4)
    assert sideways(duct).max() <= 1e-12
    # so a square duct's side faces are flat: each quad's four corners are coplanar
    rings = duct.rings()
    a, b = rings[1:], np.roll(rings[1:], -1, axis=1)
    c, e = rings[:-1], np.roll(rings[:-1], -1, axis=1)
    normal = np.cross(b - a, c - a)
    assert np.abs(np.einsum("skc,skc->sk", normal, e - a)).max() <= 1e-12


def test_frames_still_follow_parallel_transport_on_a_smooth_curve():
    t = np.linspace(0, 4 * np.pi, 2000)
    helix = Path(np.c_[np.cos(t), np.sin(t), 0.3 * t])
    pipe = Pipe(helix, 0.05, 12)
    n, tangent = pipe.normals, pipe.path.tangents
    # a rotation-minimizing normal changes only along the tangent: n' . b = 0
    dn = np.diff(n, axis=0)
    b = np.cross(tangent[:-1], n[:-1])
    assert np.abs(np.einsum("ij,ij->i", dn, b)).max() < 1e-4


def test_patent_frame_has_no_flips_where_the_tangent_swings_through_op():
    """The raw OP x L rule flips by 180 degrees there: bow-tie quads."""
    a = np.linspace(np.pi / 3, 5 * np.pi / 3, 62)
    arc = np.c_[2 + np.cos(a), np.sin(a), np.zeros_like(a)]       # tangent passes through O
    # (at 120 and 240 degrees, between samples)
    pipe = Pipe(arc, 0.05, 6, frame="patent")
    n = pipe.normals
    assert (np.einsum("ij,ij->i", n[1:], n[:-1]) > 0.5).all()
    raw = np.cross(arc, pipe.path.tangents)
    assert (raw[:, 2] > 0).any() and (raw[:, 2] < 0).any()        # the rule's sign does flip
    mesh = pipe.mesh()
    assert mesh.is_watertight and mesh.is_oriented
    assert mesh.volume == pytest.approx(Pipe(arc, 0.05, 6).mesh().volume, rel=1e-3)


def test_patent_frame_refuses_where_op_is_parallel_to_the_path():
    pipe = Pipe([[1, 1, 1], [2, 2, 2], [3, 2, 2]], 0.05, 6, frame="patent")
    with pytest.raises(cadpipe.InputError) as info:
        pipe.mesh()
    assert info.value.key == "frame" and info.value.index == 0


def test_end_normal_is_refused_on_a_closed_loop():
    t = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    loop = Path(np.c_[np.cos(t), np.sin(t), 0 * t], closed=True)
    with pytest.raises(cadpipe.InputError) as info:
        Pipe(loop, 0.1, 8, end_normal=[0, 0, 1])
    assert info.value.key == "end_normal"


def test_end_normal_that_would_pinch_a_short_pipe_is_refused_and_otherwise_honoured():
    """Three sides, two points, a 60-degree twist: the tube lost 16-42% of its volume."""
    short = Pipe([[0, 0, 0], [1, 0, 0]], 0.1, 3, normal=[0, 0, 1], end_normal=[0, 1, 0])
    with pytest.raises(cadpipe.InputError, match="pinch") as info:
        short.mesh()
    assert info.value.key == "end_normal" and info.value.index == 0
    fine = short.replace(path=Path([[0, 0, 0], [1, 0, 0]]).resample(0.1))
    mesh = fine.mesh()
    target = np.array([0, 1, 0])
    last = fine.rings()[-1] - [1, 0, 0]
    angles = np.degrees(np.arccos(last @ target / np.linalg.norm(last, axis=1)))
    assert angles.min() < 1e-6                                   # a vertex meets the normal
    straight = Pipe([[0, 0, 0], [1, 0, 0]], 0.1, 3).mesh()
    assert mesh.volume >= 0.99 * straight.volume                 # no pinch
