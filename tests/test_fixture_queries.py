"""Fixture queries against brute-force references, and trajectories to pipes and USD."""

from pathlib import Path as FilePath

import numpy as np
import pytest

from cadpipe import InputError, Path, Pipe
from cadpipe.collision import Robot
from cadpipe.collision.fixture import leaves, locate

PANDA = FilePath(__file__).parent.parent / "assets" / "robots" / "panda"


def _helix(points=300, turns=3.0):
    t = np.linspace(0.0, 2 * np.pi * turns, points)
    return np.stack([np.cos(t), np.sin(t), 0.1 * t], axis=1)


def _reference(points, centres, radii):
    """Brute force over every segment: centreline distance, segment, parameter, and
    the signed distance to the union of round cones (sampled finely along each)."""
    a, b = centres[:-1], centres[1:]
    axis = b - a
    t = np.clip(np.einsum("mki,ki->mk", points[:, None] - a, axis)
                / np.einsum("ki,ki->k", axis, axis), 0.0, 1.0)
    d = np.linalg.norm(points[:, None] - (a + t[..., None] * axis), axis=2)
    seg = np.argmin(d, axis=1)
    # the round cone is the union of balls along the segment: sample it densely
    s = np.linspace(0.0, 1.0, 201)
    balls = (a[:, None] + s[:, None] * axis[:, None]).reshape(-1, 3)
    ball_r = (radii[:-1, None] + s * (radii[1:] - radii[:-1])[:, None]).ravel()
    wall = (np.linalg.norm(points[:, None] - balls, axis=2) - ball_r).min(axis=1)
    return d[np.arange(len(points)), seg], seg, t[np.arange(len(points)), seg], wall


@pytest.mark.parametrize("tapered", [False, True])
def test_locate_matches_brute_force(tapered):
    centres = _helix(120)
    radii = np.linspace(0.05, 0.12, len(centres)) if tapered else np.full(len(centres), 0.08)
    pipe = Pipe(Path(centres), radius=radii) if tapered else Pipe(Path(centres), radius=0.08)
    ring = pipe.ring_radii
    rng = np.random.default_rng(3)
    near = centres[rng.integers(0, len(centres), 1500)] + rng.normal(0, 0.08, (1500, 3))
    far = rng.uniform([-1.5, -1.5, -0.5], [1.5, 1.5, 2.4], (500, 3))
    points = np.concatenate([near, far])
    found = locate(pipe, points)
    dist, seg, t, wall = _reference(points, centres, ring)
    np.testing.assert_allclose(np.linalg.norm(points - found.nearest, axis=1), dist,
                               atol=1e-12)
    # sampled balls under-cover a cone by a hair: the reference wall is an upper bound
    assert np.all(found.signed_distance <= wall + 1e-12)
    assert np.all(found.signed_distance >= wall - 2e-4)
    assert np.array_equal(found.inside, found.signed_distance <= 0)
    assert found.inside[:1500].mean() > 0.2 and not found.inside[1500:].all()
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(centres, axis=0), axis=1))])
    expected = arc[seg] + t * (arc[seg + 1] - arc[seg])
    same = np.abs(found.arc_length - expected) <= 1e-9
    assert same.mean() > 0.99
    # elsewhere two stretches of the helix are equally near: a tie, not an error
    on_found = np.linalg.norm(points - found.nearest, axis=1)
    np.testing.assert_allclose(on_found[~same], dist[~same], atol=1e-12)
    np.testing.assert_allclose(found.nearest, centres[found.segment] + (
        (found.arc_length - arc[found.segment]) / (arc[found.segment + 1] - arc[found.segment])
    )[:, None] * (centres[found.segment + 1] - centres[found.segment]), atol=1e-12)
    direction = centres[found.segment + 1] - centres[found.segment]
    np.testing.assert_allclose(found.tangent, direction / np.linalg.norm(direction, axis=1,
                                                                          keepdims=True))


def test_locate_agrees_with_world_inside_and_moves_with_the_pipe():
    from cadpipe import CollisionWorld

    pipe = Pipe(Path(_helix(80)), radius=0.1)
    pose = np.eye(4)
    pose[:3, 3] = 0.5, -0.2, 1.0
    world = CollisionWorld()
    world.add("pipe", pipe, transform=pose)
    rng = np.random.default_rng(9)
    points = rng.uniform([-1.0, -1.5, 0.8], [2.0, 1.5, 3.0], (800, 3))
    found = locate(pipe, points, transform=pose)
    # the world's pipe is the chain that holds the mesh (miter tips too), a superset of
    # the centreline's round cones that locate measures against
    held = world.inside("pipe", points).signed_distance
    assert (held <= found.signed_distance + 1e-12).all()
    tips = float((pipe.miter_stretch.max() - 1) * pipe.ring_radii.max())
    assert (found.signed_distance - held <= tips + 1e-12).all()
    with pytest.raises(InputError, match="expected a cadpipe Pipe"):
        locate(pipe.mesh(), points)
    with pytest.raises(InputError, match="not finite"):
        locate(pipe, [[0.0, np.nan, 0.0]])


def test_leaves_finds_where_an_ordered_path_first_leaves():
    centres = _helix(60)
    pipe = Pipe(Path(centres), radius=np.linspace(0.06, 0.1, len(centres)))
    rng = np.random.default_rng(5)
    kinds = []
    for trial in range(20):
        # a wandering tool path: along the whole helix the straight moves cut its
        # bends; along a short stretch they stay inside unless noise carries a point out
        span = len(centres) - 1 if trial % 2 else 4.0
        at = np.sort(rng.uniform(0, span, 12)) + rng.uniform(0, len(centres) - 1 - span)
        k = at.astype(int)
        base = centres[k] + (at - k)[:, None] * (centres[np.minimum(k + 1, len(centres) - 1)]
                                                  - centres[k])
        path = base + rng.normal(0, 0.005 + 0.01 * (trial % 3), base.shape)
        found = leaves(pipe, path)
        kinds.append("inside" if found.all_inside else "between" if found.inside[0]
                     else "first")
        np.testing.assert_allclose(found.signed_distance, locate(pipe, path).signed_distance,
                                   atol=1e-12)
        # the reference: the path sampled densely, each sample against every segment
        t = np.linspace(0.0, 1.0, 400)
        dense = (path[:-1, None] + t[:, None] * (path[1:] - path[:-1])[:, None]).reshape(-1, 3)
        wall = _reference(dense, centres, pipe.ring_radii)[3]
        # sampled balls under-cover a cone by a hair: outside by more than that is outside
        out = np.flatnonzero(wall > 1e-3)
        if found.all_inside:
            assert out.size == 0
            continue
        exit_at = found.exit_segment + found.exit_fraction
        sample_at = np.repeat(np.arange(len(path) - 1), len(t)) + np.tile(t, len(path) - 1)
        assert out.size and sample_at[out[0]] >= exit_at - 1e-9
        # just past the exit the tool is outside
        k, f = found.exit_segment, min(found.exit_fraction + 1e-6, 1.0)
        after = path[k] + f * (path[k + 1] - path[k])
        assert locate(pipe, after[None]).signed_distance[0] > 0 or f == 1.0
    assert kinds.count("inside") >= 3 and kinds.count("between") >= 3, kinds
    with pytest.raises(InputError, match="expected a cadpipe Pipe"):
        leaves(pipe.mesh(), path)


@pytest.fixture(scope="module")
def panda():
    return Robot.from_urdf(PANDA / "panda.urdf")


WAYPOINTS = np.array([[1.2, -0.3, 0.0, -2.4, 0.0, 2.1, 0.8, 0.02],
                      [0.3, 0.2, 0.4, -1.9, 0.3, 2.0, 0.8, 0.02],
                      [0.0, 0.45, 0.0, -1.2, 0.0, 1.65, 0.8, 0.02],
                      [0.0, 0.45, 0.0, -1.2, 0.0, 1.65, 2.8, 0.02]])


@pytest.mark.parametrize("point", [None, (0.0, 0.0, 0.0), (0.3, -0.2, 0.25)])
def test_trajectory_path_follows_the_motion_within_half_a_step(panda, point):
    """Of the frame's origin, or of a point fixed in the frame (a tool centre point 0.45
    from the origin: the wrist's turns move it faster than the origin)."""
    step = 0.01
    path = panda.frame_path(WAYPOINTS, frame="panda_hand_tcp", step=step,
                                point=point)
    t = np.linspace(0.0, 1.0, 3001)
    dense = np.concatenate([a + t[:, None] * (b - a) for a, b in
                            zip(WAYPOINTS[:-1], WAYPOINTS[1:])])
    offset = np.zeros(3) if point is None else np.array(point)
    poses = panda.frame_poses(dense, "panda_hand_tcp")
    truth = poses[:, :3, :3] @ offset + poses[:, :3, 3]
    samples = path.points
    gap = np.min(np.linalg.norm(truth[:, None] - samples[None], axis=2), axis=1)
    assert gap.max() <= step / 2 + 1e-12
    # the waypoints' own positions are on the path, in order
    assert np.linalg.norm(samples[[0, -1]] - truth[[0, -1]], axis=1).max() <= 1e-12
    # a safety pipe around it is one valid solid however the hand turned
    mesh = Pipe(path, radius=0.05).mesh()
    assert mesh.is_watertight and mesh.volume > 0
    with pytest.raises(InputError, match="step"):
        panda.frame_path(WAYPOINTS, frame="panda_hand_tcp", step=0)
    with pytest.raises(InputError, match="no such link"):
        panda.frame_path(WAYPOINTS, frame="tool0", step=0.01)
    with pytest.raises(InputError, match="point") as caught:
        panda.frame_path(WAYPOINTS, frame="panda_hand_tcp", step=0.01,
                             point=(0, 1))
    assert caught.value.key == "point"


@pytest.mark.slow
def test_a_safety_pipe_holds_the_motion_however_tight_the_wrist_turns(panda):
    """A wrist flip (only the last joints move far) bends the hand's path tightly and
    folds its tube onto itself: the envelope pipe is still one valid solid, and
    every point within ``r - step / 2`` of the true motion of the hand is inside it
    (trimesh's ray test as the reference)."""
    import trimesh

    from cadpipe.solids.validity import check_mesh

    rng = np.random.default_rng(1)
    lo, hi = panda.limits
    step, radius = 0.01, 0.03
    for _ in range(2):
        q = rng.uniform(lo, hi, (3, len(lo)))
        q[:, :4] = q[0, :4]
        path = panda.frame_path(q, frame="panda_hand_tcp", step=step)
        mesh = Pipe(path, radius=radius, envelope=True, sides=12).mesh()
        assert check_mesh(mesh)["valid"], check_mesh(mesh)["problems"]
        t = np.linspace(0.0, 1.0, 2001)
        dense = np.concatenate([a + t[:, None] * (b - a) for a, b in zip(q[:-1], q[1:])])
        curve = panda.frame_poses(dense, "panda_hand_tcp")[:, :3, 3]
        away = rng.normal(size=(5000, 3))
        away *= (radius - step / 2) * rng.uniform(0.0, 1.0, (5000, 1)) ** (1 / 3) \
            / np.linalg.norm(away, axis=1)[:, None]
        points = curve[rng.integers(0, len(curve), 5000)] + away
        assert trimesh.Trimesh(mesh.vertices, mesh.faces).contains(points).all()


def test_trajectory_usd_animates_every_link_with_its_own_op(panda, tmp_path):
    from pxr import Usd, UsdGeom

    from cadpipe.io.usd_animation import write_trajectory_usd

    target = tmp_path / "motion.usda"
    frames = write_trajectory_usd(target, panda, WAYPOINTS, times=[0.0, 1.0, 1.5, 3.0],
                                  fps=10, extras={"pipe": Pipe(Path(_helix(20)), radius=0.1)})
    assert frames == 31
    stage = Usd.Stage.Open(str(target))
    assert stage.GetEndTimeCode() == 30 and stage.GetTimeCodesPerSecond() == 10
    for link in panda.link_meshes:
        prim = stage.GetPrimAtPath(f"/panda/{link}")
        ops = UsdGeom.Xformable(prim).GetOrderedXformOps()
        assert len(ops) == 1 and len(ops[0].GetTimeSamples()) == 31, link
    # at 1.5 s the robot is at waypoint 2, the world pose of every link matches FK
    expected = panda.link_poses(WAYPOINTS[2])
    for link, pose in expected.items():
        prim = UsdGeom.Xformable(stage.GetPrimAtPath(f"/panda/{link}"))
        got = np.array(prim.ComputeLocalToWorldTransform(Usd.TimeCode(15))).T
        np.testing.assert_allclose(got, pose, atol=1e-9)
    assert stage.GetPrimAtPath("/panda/pipe").IsValid()
    with pytest.raises(InputError, match="increasing"):
        write_trajectory_usd(tmp_path / "bad.usda", panda, WAYPOINTS, times=[0, 1, 1, 2])
    assert not (tmp_path / "bad.usda").exists()
    with pytest.raises(InputError, match="usda"):
        write_trajectory_usd(tmp_path / "bad.stl", panda, WAYPOINTS)
