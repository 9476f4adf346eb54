"""Steps S2-S4: pipes are closed, outward solids with the analytic volume and no twist."""

import manifold3d
import numpy as np
import pytest

import cadpipe
from cadpipe import GeometryError, InputError, Path, Pipe
from cadpipe.geometry.pipe import sides_for_tolerance


def ngon_area(r, n):
    return 0.5 * n * r * r * np.sin(2 * np.pi / n)


def frustum(a1, a2, h):
    return h / 3 * (a1 + a2 + np.sqrt(a1 * a2))


def round_cap_volume(r, n, m):
    lat = (np.pi / 2) * np.arange(m) / m
    areas = ngon_area(r * np.cos(lat), n)
    heights = r * np.sin(lat)
    slabs = frustum(areas[:-1], areas[1:], np.diff(heights)).sum()
    return slabs + areas[-1] * (r - heights[-1]) / 3


def assert_solid(mesh):
    assert mesh.is_watertight
    assert mesh.is_winding_consistent
    assert mesh.volume > 0
    assert mesh.n_bodies == 1
    solid = mesh.to_manifold()
    assert solid.volume() == pytest.approx(mesh.volume, rel=1e-9)


@pytest.mark.parametrize("sides", [3, 4, 7, 16, 64])
def test_straight_pipe_volume_is_the_ngon_prism(sides):
    mesh = Pipe([[0, 0, 0], [0.3, -0.2, 1.1]], 0.07, sides=sides).mesh()
    assert_solid(mesh)
    length = np.linalg.norm([0.3, -0.2, 1.1])
    assert mesh.volume == pytest.approx(ngon_area(0.07, sides) * length, rel=1e-9)
    assert len(mesh.vertices) == 2 * sides          # flat caps add no vertices
    assert mesh.genus == 0


@pytest.mark.parametrize("sides, segments", [(8, 2), (12, 3), (16, 4)])
def test_round_caps_add_the_polyhedral_hemispheres(sides, segments):
    mesh = Pipe([[0, 0, 0], [0, 0, 2.0]], 0.1, sides=sides, caps="round",
                cap_segments=segments).mesh()
    assert_solid(mesh)
    expected = ngon_area(0.1, sides) * 2.0 + 2 * round_cap_volume(0.1, sides, segments)
    assert mesh.volume == pytest.approx(expected, rel=1e-9)


def test_variable_radius_is_an_ngon_frustum():
    mesh = Pipe([[0, 0, 0], [0, 0, 1.5]], [0.2, 0.05], sides=10).mesh()
    assert_solid(mesh)
    assert mesh.volume == pytest.approx(frustum(ngon_area(0.2, 10), ngon_area(0.05, 10), 1.5),
                                        rel=1e-9)


def test_rmf_twist_matches_parallel_transport_on_a_helix():
    a, b = 1.0, 0.3                                    # helix radius, rise per radian
    t = np.linspace(0, 4 * np.pi, 4001)                # two turns
    pts = np.c_[a * np.cos(t), a * np.sin(t), b * t]
    pipe = Pipe(pts, 0.05, sides=12)
    c = np.hypot(a, b)
    tangent = np.c_[-a * np.sin(t), a * np.cos(t), b + 0 * t] / c
    normal = np.c_[-np.cos(t), -np.sin(t), 0 * t]
    binormal = np.cross(tangent, normal)
    n = pipe.normals
    theta = np.unwrap(np.arctan2(np.einsum("ij,ij->i", n, binormal),
                                 np.einsum("ij,ij->i", n, normal)))
    torsion = b / c ** 2
    expected = theta[0] - torsion * c * t             # Bishop frame: theta' = -torsion
    assert np.degrees(np.abs(theta - expected)).max() <= 0.1
    assert np.degrees(torsion * c * t[-1]) > 100       # the helix really does twist Frenet


def test_closed_trefoil_seam_closes():
    s = np.linspace(0, 2 * np.pi, 300, endpoint=False)
    knot = np.c_[np.sin(s) + 2 * np.sin(2 * s), np.cos(s) - 2 * np.cos(2 * s), -np.sin(3 * s)]
    pipe = Pipe(Path(knot, closed=True), 0.25, sides=10)
    mesh = pipe.mesh()
    assert_solid(mesh)
    assert mesh.genus == 1
    rings = pipe.rings()
    # the last ring's vertex k meets the first ring's vertex k + shift: the seam band is short
    seam = np.linalg.norm(rings[-1] - np.roll(rings[0], -pipe.seam_shift, axis=0), axis=1)
    band = np.linalg.norm(rings[1:] - rings[:-1], axis=2).max()
    assert seam.max() <= band * 1.5


def test_miter_corner_keeps_full_radius():
    r = 0.1
    pipe = Pipe([[0, 0, 0], [1, 0, 0], [1, 1, 0]], r, sides=16)
    ring = pipe.rings()[1]
    to_incoming = np.hypot(ring[:, 1], ring[:, 2])          # distance to the x axis
    to_outgoing = np.hypot(ring[:, 0] - 1, ring[:, 2])      # distance to the line x=1, z=0
    assert np.allclose(to_incoming, r) and np.allclose(to_outgoing, r)
    mesh = pipe.mesh()
    assert_solid(mesh)
    # mitered tube volume: two prisms measured along their axes to the corner point
    assert mesh.volume == pytest.approx(ngon_area(r, 16) * 2.0, rel=1e-9)


def test_a_filleted_path_bends_the_pipe_in_arcs():
    path = Path([[0, 0, 0], [1, 0, 0], [1, 1, 0]]).filleted(0.3)
    pipe = Pipe(path, 0.1, sides=12, corners="round")
    assert_solid(pipe.mesh())
    assert len(pipe.path) > 3
    assert pipe.path.turning_angles.max() < np.radians(6)


@pytest.mark.parametrize("degrees", [60, 90, 110, 120])
def test_round_corners_are_ball_joints_around_the_corner_point(degrees):
    """0.1 rounded the path: the corner point ended 0.17 r inside at 90 degrees and
    2.3 r outside at 150."""
    r, sides = 0.1, 16
    a = np.radians(degrees)
    points = [[-1, 0, 0], [0, 0, 0], [np.cos(a), np.sin(a), 0]]
    pipe = Pipe(points, r, sides, corners="round")
    mesh = pipe.mesh()
    assert_solid(mesh)
    assert np.allclose(pipe.path.points, points)                  # the path is kept
    # the corner's ball is inside up to the polygons' chordal sag (16 sides, 4 steps
    # per quarter turn: 0.96 r); the rounded path held only 0.17 r at 90 degrees
    rng = np.random.default_rng(degrees)
    v = rng.normal(size=(2000, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    assert mesh.contains(0.95 * r * v).all()
    # and no miter tip: every vertex lies within r of the path, as a miter's does not
    def reach(m):
        return np.minimum(_distance_to_segment(m.vertices, points[0], points[1]),
                          _distance_to_segment(m.vertices, points[1], points[2])).max()
    assert reach(mesh) <= r * (1 + 1e-9) < reach(Pipe(points, r, sides).mesh())


def _distance_to_segment(p, a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    t = np.clip((p - a) @ (b - a) / ((b - a) @ (b - a)), 0, 1)
    return np.linalg.norm(p - a - t[:, None] * (b - a), axis=1)


def test_sharp_corner_beyond_miter_limit_is_refused_strictly_and_a_ball_joint_by_default():
    corner = [[0, 0, 0], [1, 0, 0], [0, 0.1, 0]]
    with pytest.raises(GeometryError, match="miter_limit"):
        Pipe(corner, 0.01, strict=True).mesh()
    mesh = Pipe(corner, 0.01).mesh()
    assert_solid(mesh)
    # the swept solid: the corner point is covered by a ball, not a miter spike
    assert mesh.contains(np.array([[1.0 + 0.0099, 0, 0]]))[0]
    assert np.linalg.norm(mesh.vertices - [1, 0, 0], axis=1).max() < 1.0 + 0.02


def _random_offsets(pipe, count, fraction, rng):
    path = pipe.path
    j = rng.integers(0, len(path.segments), count)
    t = rng.uniform(0.0, 1.0, count)
    d = path.directions[j]
    v = rng.normal(size=(count, 3))
    v -= np.einsum("ij,ij->i", v, d)[:, None] * d
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    base = path.points[j] + t[:, None] * path.segments[j]
    return base + fraction * pipe.radii[j, None] * v


def test_envelope_encloses_the_round_tube():
    rng = np.random.default_rng(1)
    path = Path.spline([[0, 0, 0], [0.5, 0.2, 0], [1, 0, 0.3], [1.5, 0.4, 0.3]], step=0.04)
    inside = Pipe(path, 0.1, sides=8, envelope=True)
    points = _random_offsets(inside, 1500, 0.999, rng)
    assert inside.mesh().contains(points).all()
    # without the envelope the 8-gon lies inside the circle, so some such points are outside
    assert not Pipe(path, 0.1, sides=8).mesh().contains(points).all()


def test_patent_frame_is_the_source_rule_and_refuses_where_undefined():
    pts = np.array([[1.0, 0, 0], [1, 1, 0], [1, 2, 0]])
    pipe = Pipe(pts, 0.1, sides=6, frame="patent")
    expected = np.cross(pts, [0, 1, 0])
    expected /= np.linalg.norm(expected, axis=1, keepdims=True)
    assert np.allclose(pipe.normals, expected)
    # a path pointing at the origin has no OP x L: refused, not silently replaced
    radial = Pipe([[1.0, 1, 1], [2, 2, 2]], 0.1, sides=6, frame="patent")
    with pytest.raises(cadpipe.InputError, match="undefined at path point 0") as info:
        radial.mesh()
    assert info.value.key == "frame" and info.value.index == 0


def test_sides_from_chordal_tolerance():
    n = sides_for_tolerance(1.0, 1e-3)
    assert 1 - np.cos(np.pi / n) <= 1e-3 < 1 - np.cos(np.pi / (n - 1))
    assert Pipe([[0, 0, 0], [1, 0, 0]], 1.0, tolerance=1e-3).sides == n


@pytest.mark.parametrize("tolerance", [1e-7, 1e-12, 1e-300, 5e-324])
def test_sides_from_tiny_tolerances(tolerance):
    """A tolerance far below the radius: the analytic count (the chord's sagitta
    ``r (1 - cos(pi / n))`` against ``tolerance``, in extended precision) or, beyond
    4,096 sides, an InputError about the tolerance; never an OverflowError."""
    radius = 0.05
    angle = np.arccos(np.longdouble(1) - np.longdouble(tolerance) / radius)
    exact = int(np.ceil(np.pi / angle)) if angle * 4097 > np.pi else None
    if exact is not None:
        assert sides_for_tolerance(radius, tolerance) == exact
        return
    with pytest.raises(cadpipe.InputError, match="more than 4096 sides") as info:
        Pipe([[0, 0, 0], [1, 0, 0], [1, 1, 0]], radius, tolerance=tolerance)
    assert info.value.key == "tolerance"


def test_local_self_intersection_is_reported_with_its_place():
    s = np.linspace(0, np.pi, 60)
    arc = np.c_[0.2 * np.cos(s), 0.2 * np.sin(s), 0 * s]        # bend radius 0.2
    with pytest.raises(GeometryError, match="bend radius") as info:
        Pipe(arc, 0.25, strict=True).mesh()
    assert "path point" in str(info.value) and info.value.fix == {"strict": False}
    assert_solid(Pipe(arc, 0.15).mesh())
    merged = Pipe(arc, 0.25).mesh()
    assert_solid(merged)
    assert merged.attributes["merged"].startswith("path points")


def test_distant_self_intersection_and_repair():
    crossing = np.array([[0, 0, 0], [2, 0, 0], [2, 2, 0], [1, 2, 0], [1, -1, 0.1]])
    with pytest.raises(GeometryError, match="passes within") as info:
        Pipe(crossing, 0.2, strict=True).mesh()
    assert "path point 0" in str(info.value) and "path point 3" in str(info.value)
    mesh = Pipe(crossing, 0.2).mesh()
    assert_solid(mesh)
    assert "path points 0..1" in mesh.attributes["merged"]


@pytest.mark.parametrize("kwargs, word", [
    ({"radius": 0}, "radius"),
    ({"radius": -1}, "radius"),
    ({"radius": np.nan}, "radius"),
    ({"radius": [0.1, 0.2, 0.3]}, "radius"),
    ({"sides": 2}, "sides"),
    ({"sides": 10 ** 6}, "sides"),
    ({"sides": 4.5}, "sides"),
    ({"caps": "square"}, "caps"),
    ({"frame": "frenet"}, "frame"),
    ({"normal": [1, 0, 0]}, "normal"),
])
def test_bad_pipe_arguments_name_the_argument(kwargs, word):
    args = {"radius": 0.1, **kwargs}
    with pytest.raises(InputError, match=word):
        Pipe([[0, 0, 0], [1, 0, 0]], **args).mesh()


def test_mesh_interop_with_trimesh_and_manifold():
    mesh = Pipe(Path.spline([[0, 0, 0], [1, 1, 0], [2, 0, 1]], step=0.05), 0.1).mesh()
    tm = mesh.to_trimesh()
    assert tm.is_watertight and tm.is_winding_consistent and tm.volume > 0
    assert tm.volume == pytest.approx(mesh.volume, rel=1e-12)
    back = cadpipe.Mesh.from_manifold(mesh.to_manifold())
    assert back.volume == pytest.approx(mesh.volume, rel=1e-9)
    assert isinstance(mesh.to_manifold(), manifold3d.Manifold)


def test_radius_below_the_path_resolution_or_too_thin_to_check_is_refused():
    # 1e-127 of a unit path: every ring vertex rounds onto the axis
    with pytest.raises(InputError, match="radius"):
        Pipe([[0, 0.75, 0], [0, 0, 1]], 5.9e-127, sides=3)
    # representable: a thin pipe costs what its segments cost, at any length / radius
    assert_solid(Pipe([[0, 0, 0], [1e-3, 0, 0]], 1e-7).mesh())
    # but at 1 from the origin float32 files (steps of 1.2e-7 there) would weld it shut
    with pytest.raises(GeometryError, match="float32"):
        Pipe([[0, 0, 0], [1, 0, 0]], 1e-7).mesh()


def test_fillets_that_consume_a_segment_make_a_pipe():
    """0.1: a numpy broadcast ValueError when two arcs used up the segment between them."""
    points = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [2, 1, 0]]
    pipe = Pipe(Path(points).filleted(0.5), 0.1, 8)
    assert pipe.radii.shape == (len(pipe.path),)
    assert_solid(pipe.mesh())
