"""Step S1: paths are validated, resampled, fitted and filleted as a user expects."""

import numpy as np
import pytest

import cadpipe
from cadpipe import InputError, Path


def test_duplicates_are_dropped_and_closed_end_merged():
    p = Path([[0, 0, 0], [0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 0, 0]], closed=True)
    assert len(p) == 3
    assert p.closed
    assert p.length == pytest.approx(2 + np.sqrt(2))


@pytest.mark.parametrize("points, words", [
    ([[0, 0, np.nan], [1, 0, 0]], ["points", "not finite"]),
    ([[0, 0, np.inf], [1, 0, 0]], ["points", "not finite"]),
    ([[0, 0, 0]], ["points", "at least 2"]),
    ([[1, 2, 3]] * 5, ["points", "distinct"]),
    ([[0, 0], [1, 1]], ["points", "shape"]),
    ("abc", ["points"]),
])
def test_bad_points_name_the_argument(points, words):
    with pytest.raises(InputError) as info:
        Path(points)
    assert isinstance(info.value, ValueError)
    for word in words:
        assert word in str(info.value)


def test_resample_keeps_corners_and_respects_step():
    p = Path([[0, 0, 0], [1, 0, 0], [1, 0.35, 0]]).resample(0.1)
    assert p.segment_lengths.max() <= 0.1 + 1e-12
    assert any(np.allclose(q, [1, 0, 0]) for q in p.points)
    assert p.length == pytest.approx(1.35)


def test_spline_interpolates_control_points_and_step():
    control = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0.5], [0, 2, 1.0]])
    p = Path.spline(control, step=0.01)
    assert p.segment_lengths.max() <= 0.01 * 1.01
    # every control point lies on the discretized curve (within one chord's sag)
    d = np.linalg.norm(p.points[:, None] - control[None], axis=2).min(axis=0)
    assert d.max() < 0.01
    assert np.allclose(p.points[[0, -1]], control[[0, -1]])


def test_spline_chordal_tolerance_bounds_the_deviation():
    from scipy.interpolate import make_interp_spline

    control = np.array([[0, 0, 0], [1, 0.2, 0], [1.5, 1, 0.3], [0.5, 1.5, 0.0]])
    tol = 1e-4
    p = Path.spline(control, tolerance=tol)
    chord = np.linalg.norm(np.diff(control, axis=0), axis=1)
    curve = make_interp_spline(np.concatenate([[0], np.cumsum(chord)]), control, k=3)
    dense = curve(np.linspace(0, chord.sum(), 20000))
    # distance from dense curve samples to the polyline
    a, b = p.points[:-1], p.points[1:]
    ab = b - a
    t = np.clip(np.einsum("pij,ij->pi", dense[:, None] - a[None], ab) /
                np.einsum("ij,ij->i", ab, ab), 0, 1)
    dist = np.linalg.norm(a[None] + t[..., None] * ab[None] - dense[:, None], axis=2).min(axis=1)
    assert dist.max() <= tol * 1.1
    # and it is not absurdly dense: within 3x of the optimal count for this tolerance
    assert len(p) < 3 * (p.length / np.sqrt(8 * tol * 0.5) + 10)


def test_closed_spline_is_periodic():
    s = np.linspace(0, 2 * np.pi, 7, endpoint=False)
    p = Path.spline(np.c_[np.cos(s), np.sin(s), 0 * s], step=0.05, closed=True)
    assert p.closed
    assert np.linalg.norm(p.points[0] - p.points[-1]) <= 0.05 * 1.01
    r = np.linalg.norm(p.points[:, :2], axis=1)
    assert np.allclose(r, 1, atol=0.02)


def test_fillet_replaces_corner_with_tangent_arc():
    corner = Path([[0, 0, 0], [1, 0, 0], [1, 1, 0]])
    p, source = corner.filleted(0.25), corner.fillet_sources(0.25)
    assert len(source) == len(p)
    centre = np.array([0.75, 0.25, 0])
    arc = source == 1
    assert np.allclose(np.linalg.norm(p.points[arc] - centre, axis=1), 0.25)
    assert np.allclose(p.points[0], [0, 0, 0]) and np.allclose(p.points[-1], [1, 1, 0])
    assert p.length == pytest.approx(2 - 2 * 0.25 + np.pi / 2 * 0.25, rel=1e-3)


def test_fillet_too_large_for_segment_is_an_error():
    with pytest.raises(cadpipe.GeometryError, match="bend_radius"):
        Path([[0, 0, 0], [0.1, 0, 0], [0.1, 0.1, 0]]).filleted(1.0)


def test_a_reversal_has_a_tangent_across_the_path():
    """A path that turns back has no bisector; its tangent there is a unit vector across
    the segment (the pipe turns round in a ball joint), not an error."""
    path = Path([[0, 0, 0], [1, 0, 0], [0, 0, 0.0]])
    t = path.tangents[1]
    assert np.isclose(np.linalg.norm(t), 1) and abs(t @ [1, 0, 0]) < 1e-12
    assert np.isinf(path._lines.miter_stretch[1])


def test_fillet_and_trimmed_return_paths_like_resample():
    corner = Path([[0, 0, 0], [1, 0, 0], [1, 1, 0]])
    assert len(corner.fillet_sources(0.25)) == len(corner.filleted(0.25))
    piece = corner.trimmed(0.3, 0.2)
    assert isinstance(piece, Path) and isinstance(corner.resample(0.1), Path)
    # the documented arc-length relation: point i sits at start + arc_length[i]
    on_corner = np.stack([np.interp(0.3 + piece.arc_length, corner.arc_length,
                                    corner.points[:, c]) for c in range(3)], axis=1)
    assert np.allclose(on_corner, piece.points)
