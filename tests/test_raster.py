"""The numpy z-buffer: every pixel shows the nearest triangle covering its centre."""

import numpy as np
import pytest
import trimesh
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from cadpipe.io import raster
from cadpipe.io.raster import rasterize

W, H = 24, 18


def brute_force(screen, width, height):
    """Reference: test every pixel centre against every triangle, keep the nearest.

    Also marks centres that a rounding error could flip (on an edge, or with two
    triangles at the same depth), so comparisons leave them out.
    """
    y, x = np.mgrid[0:height, 0:width] + 0.5
    p = np.stack([x.ravel(), y.ravel()], axis=1)[:, None, :]             # (P, 1, 2)
    a, b, c = (screen[None, :, i, :2] for i in range(3))                 # (1, F, 2)

    def cross(u, v):
        return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]

    area = cross(b - a, c - a)
    w = np.stack([cross(c - b, p - b), cross(a - c, p - c), cross(b - a, p - a)]) / area
    inside = (w >= 0).all(axis=0)                                          # (P, F)
    depth = np.where(inside, np.einsum("kpf,fk->pf", w, screen[:, :, 2]), np.inf)
    nearest = np.where(inside.any(axis=1), depth.argmin(axis=1), -1)
    sides = np.stack([np.linalg.norm(c - b, axis=-1), np.linalg.norm(a - c, axis=-1),
                      np.linalg.norm(b - a, axis=-1)])
    near_edge = (np.abs(w * area / sides).min(axis=0) < 1e-3).any(axis=1)
    two = np.sort(depth, axis=1)[:, :2]
    with np.errstate(invalid="ignore"):                                   # inf - inf
        near_tie = (two.shape[1] == 2) & (two[:, -1] - two[:, 0] < 1e-3)
    return nearest.reshape(height, width), (near_edge | near_tie).reshape(height, width)


triangles = arrays(np.float64, st.integers(1, 12).map(lambda n: (n, 3, 3)),
                   elements=st.floats(-4.0, 28.0, allow_nan=False, width=32))


@settings(max_examples=150, deadline=None)
@given(triangles)
def test_agrees_with_brute_force(screen):
    a, b, c = (screen[:, i, :2] for i in range(3))
    area = np.cross(np.pad(b - a, ((0, 0), (0, 1))), np.pad(c - a, ((0, 0), (0, 1))))[:, 2]
    screen = screen[np.abs(area) >= 1.0]      # slivers: float32 planes lose their depth order
    assume(len(screen))
    index, depth = rasterize(screen, W, H)
    expected, ambiguous = brute_force(screen, W, H)
    assert np.array_equal(index[~ambiguous], expected[~ambiguous])
    assert np.isinf(depth[index < 0]).all() and np.isfinite(depth[index >= 0]).all()


def test_batches_do_not_change_the_picture(monkeypatch):
    sphere = trimesh.creation.icosphere(subdivisions=3)
    screen = sphere.vertices[sphere.faces] * 20 + [40, 30, 0]
    whole = rasterize(screen, 80, 60)
    monkeypatch.setattr(raster, "BATCH", 64)
    batched = rasterize(screen, 80, 60)
    assert np.array_equal(whole[0], batched[0])
    assert np.array_equal(whole[1], batched[1])


@pytest.mark.parametrize("radius", [30.0, 200.0])
def test_disc_covers_its_area(radius):
    sphere = trimesh.creation.icosphere(subdivisions=5)
    size = int(2 * radius + 20)
    index, _ = rasterize(sphere.vertices[sphere.faces] * radius + size / 2, size, size)
    # the icosphere's outline is a polygon inscribed in the circle: a hair smaller
    assert np.count_nonzero(index >= 0) == pytest.approx(np.pi * radius ** 2, rel=0.01)


def test_triangles_off_screen_or_degenerate_draw_nothing():
    screen = np.array([[[-50, -50, 0], [-40, -50, 0], [-50, -40, 0]],   # off the image
                       [[5, 5, 0], [10, 10, 0], [15, 15, 0]]], float)    # zero area
    index, depth = rasterize(screen, W, H)
    assert (index == -1).all() and np.isinf(depth).all()


def test_a_triangle_larger_than_a_batch_is_drawn_whole(monkeypatch):
    screen = np.array([[[-10, -10, 1.0], [200, -10, 2.0], [-10, 200, 3.0]]])
    whole = rasterize(screen, 100, 80)
    monkeypatch.setattr(raster, "BATCH", 50)          # smaller than one row of the box
    banded = rasterize(screen, 100, 80)
    assert (whole[0] == 0).all()
    assert np.array_equal(banded[0], whole[0])
    assert np.allclose(banded[1], whole[1], atol=1e-4)
