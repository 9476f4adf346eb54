"""Property tests: every pipe over random smooth paths is a closed, outward solid."""

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cadpipe import GeometryError, Path, Pipe

coords = st.floats(-1.0, 1.0, allow_nan=False)


def smooth_enough(points, closed=False):
    """Control polygons with spaced points and no near-reversal (a spline cusp)."""
    p = np.array(points)
    d = np.diff(np.vstack([p, p[:1]]) if closed else p, axis=0)
    n = np.linalg.norm(d, axis=1)
    if n.min() <= 0.3:
        return False
    d /= n[:, None]
    nxt = np.roll(d, -1, axis=0) if closed else d[1:]
    return bool((np.einsum("ij,ij->i", nxt, d[: len(nxt)]) > -0.7).all())


control_points = st.lists(st.tuples(coords, coords, coords), min_size=3, max_size=6).filter(
    smooth_enough)
loop_points = st.lists(st.tuples(coords, coords, coords), min_size=3, max_size=6).filter(
    lambda p: smooth_enough(p, closed=True))


def assert_valid_solid(mesh):
    assert mesh.is_watertight
    assert mesh.is_winding_consistent
    assert mesh.volume > 0
    # outward: face normals point away from the solid (winding number just outside is 0)
    tri = mesh.triangles
    i = np.argsort(-mesh.face_areas)[:20]
    outside = tri[i].mean(axis=1) + 1e-4 * mesh.face_normals[i]
    assert (mesh.winding_numbers(outside) < 0.5).all()
    solid = mesh.to_manifold()
    assert abs(solid.volume() - mesh.volume) <= 1e-6 * mesh.volume


def build(pipe):
    """The mesh, or (for a genuinely self-intersecting tube) the repaired solid."""
    try:
        return pipe.mesh()
    except GeometryError:
        return pipe.replace(strict=False).mesh()


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(control_points, st.floats(0.005, 0.08), st.integers(3, 24),
       st.sampled_from(["flat", "round"]), st.booleans())
def test_open_spline_pipes_are_solids(points, radius, sides, caps, envelope):
    path = Path.spline(points, step=0.05)
    assert_valid_solid(build(Pipe(path, radius, sides=sides, caps=caps, envelope=envelope)))


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(loop_points, st.floats(0.005, 0.05), st.integers(3, 16))
def test_closed_spline_pipes_are_solids(points, radius, sides):
    path = Path.spline(points, step=0.05, closed=True)
    mesh = build(Pipe(path, radius, sides=sides))
    assert_valid_solid(mesh)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(control_points, st.lists(st.floats(0.01, 0.06), min_size=6, max_size=6),
       st.integers(3, 12))
def test_polyline_pipes_with_varying_radius_are_solids(points, radii, sides):
    path = Path(points)
    radius = np.interp(np.linspace(0, 1, len(path)), np.linspace(0, 1, 6), radii)
    try:
        mesh = Pipe(path, radius, sides=sides, miter_limit=50).mesh()
    except GeometryError:
        mesh = Pipe(path, radius, sides=sides, miter_limit=50, strict=False).mesh()
    assert_valid_solid(mesh)
