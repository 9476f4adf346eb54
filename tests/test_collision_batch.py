"""Batched checks: check_path / check_many and the pose-batched chain gaps give, for
every configuration, exactly what the one-at-a-time calls give."""

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from cadpipe import CollisionWorld, InputError, Mesh, Path, Pipe
from cadpipe.collision import STAGES, Box, CollisionReports, Joint, Robot, Sphere
from cadpipe.collision.capsules import Chain, unit_pair_gap
from cadpipe.collision.hierarchy import CHUNK, chain_gaps


def arm():
    """Four capsule-like links: a turning base, then three folding joints."""
    link = Mesh.from_trimesh(trimesh.creation.capsule(height=0.5, radius=0.07, count=[8, 8]))
    link = link.transformed(trimesh.transformations.translation_matrix([0, 0, 0.25]))
    up = shift(0, 0, 0.5)
    names = ["base", "l0", "l1", "l2", "l3"]
    joints = [Joint(f"j{k}", "revolute", names[k], names[k + 1], up if k else np.eye(4),
                    np.array([0.0, 0.0, 1.0] if k == 0 else [0.0, 1.0, 0.0]), -2.8, 2.8)
              for k in range(4)]
    return Robot("arm", joints, dict.fromkeys(names[1:], link))


def shift(x, y, z):
    m = np.eye(4)
    m[:3, 3] = (x, y, z)
    return m


def cell():
    """The arm beside a big block (links end up wholly inside it: containment), a
    torus, a ball and two pipes, one of them tapered."""
    world = CollisionWorld()
    world.add_robot(arm())
    world.add("block", Box((0.9, 0.9, 0.7)), transform=shift(0.7, 0.0, 0.6))
    world.add("ring", Mesh.from_trimesh(trimesh.creation.torus(0.3, 0.08, major_sections=24,
                                                               minor_sections=12)),
              transform=shift(-0.5, 0.4, 1.0))
    world.add("ball", Sphere(0.15), transform=shift(0.0, -0.6, 0.9))
    world.add("duct", Pipe(Path.spline([[-0.8, -0.5, 0.2], [0.0, -0.2, 1.2], [0.6, 0.6, 1.6]],
                                       step=0.05), 0.06, caps="round"))
    world.add("hose", Pipe([[-0.6, 0.6, 0.1], [-0.2, 0.1, 0.8], [0.3, -0.5, 1.3]],
                           [0.04, 0.1, 0.05], caps="round"))
    return world


def answers(report):
    return [(p.a, p.b, p.decided_by, p.colliding, p.phase) for p in report.pairs]


def one_by_one(world, configurations, **options):
    out = []
    for q in configurations:
        world.set_joints("arm", q)
        out.append(world.check(**options))
    return out


@pytest.mark.parametrize("options", [{}, {"stop_after_self": True}])
def test_check_path_equals_check_in_a_loop(options):
    world = cell()
    q = np.random.default_rng(8).uniform(-2.8, 2.8, (400, 4))
    batch = world.check_path("arm", q, **options)
    assert isinstance(batch, CollisionReports) and len(batch) == len(q)
    singles = one_by_one(world, q, **options)
    for c, single in enumerate(singles):
        assert answers(batch[c]) == answers(single)
        assert batch[c].stopped_after_self == single.stopped_after_self
        assert [(a, b) for a, b, _ in batch[c].collisions] == \
            [(a, b) for a, b, _ in single.collisions]
    np.testing.assert_array_equal(batch.colliding, [bool(s.collisions) for s in singles])
    stages = {p.decided_by for s in singles for p in s.pairs}
    # the comparison covers every stage, containment and self-collision included
    assert {"aabb", "kdop", "obb", "fcl", "containment", "analytic"} <= stages
    assert any(d.phase == "self" for s in singles for _, _, d in s.collisions)
    if options:
        assert batch.stopped_after_self.any() and not batch.stopped_after_self.all()
    assert sum(batch.counts().values()) == batch.decided_by.size
    assert set(batch.counts()) <= set(STAGES)


def test_check_path_with_certificates_equals_the_loop():
    world = cell()
    q = np.random.default_rng(9).uniform(-2.8, 2.8, (12, 4))
    batch = world.check_path("arm", q, certify=True)
    singles = one_by_one(world, q, certify=True)
    for c, single in enumerate(singles):
        assert answers(batch[c]) == answers(single)
        for mine, theirs in zip(batch[c].pairs, single.pairs):
            assert (mine.certificate is None) == (theirs.certificate is None)
    assert any(p.decided_by == "certificate" for s in singles for p in s.pairs)


def test_check_many_moves_any_objects_and_equals_the_loop():
    world = cell()
    rng = np.random.default_rng(10)
    count = 300
    poses = {}
    for name, spread in (("hose", 0.5), ("ball", 0.8)):
        m = np.tile(np.eye(4), (count, 1, 1))
        m[:, :3, :3] = Rotation.random(count, random_state=rng).as_matrix()
        m[:, :3, 3] = world.pose(name)[:3, 3] + rng.uniform(-spread, spread, (count, 3))
        poses[name] = m
    batch = world.check_many(poses)
    hits = set()
    for c in range(count):
        for name, m in poses.items():
            world.set_pose(name, m[c])
        single = world.check()
        assert answers(batch[c]) == answers(single)
        hits |= {(a, b, d.decided_by) for a, b, d in single.collisions}
    # chains against chains, meshes and the ball inside the block all occur
    assert ("duct", "hose", "analytic") in hits
    assert ("block", "ball", "containment") in hits


def test_one_pose_of_one_pair_equals_the_batched_narrow_phase():
    # collide_at settles chain pairs in the compiled walks of the per-state kernel and
    # leaves the rest (meshes, a ball perhaps inside the block, tapered units) to the
    # batched narrow phase; either way the verdict is the batch's
    from cadpipe.collision import narrow

    world = cell()
    rng = np.random.default_rng(12)
    pairs = [("duct", "hose"), ("hose", "duct"), ("ball", "block"), ("block", "ball"),
             ("ring", "duct"), ("ball", "ring"), ("block", "ring"), ("l0", "l1"),
             ("duct", "l2"), ("hose", "ball")]
    seen = set()
    for a, b in pairs:
        count = 150
        poses = np.tile(np.eye(4), (count, 2, 1, 1))
        poses[:, 1, :3, :3] = Rotation.random(count, random_state=rng).as_matrix()
        poses[:, :, :3, 3] = world.pose(a)[:3, 3] + rng.uniform(-0.4, 0.4, (count, 2, 3))
        touching, contained = narrow.collide(world.body(a), poses[:, 0], world.body(b),
                                             poses[:, 1])
        single = [world.collide_at(a, b, m_a, m_b) for m_a, m_b in poses]
        np.testing.assert_array_equal(single, touching)
        seen |= {(a, b, kind) for kind, found in (("hit", touching & ~contained),
                                                  ("inside", contained), ("apart", ~touching))
                 if found.any()}
    assert {("ball", "block", "inside"), ("duct", "hose", "hit"), ("ring", "duct", "apart"),
            ("block", "ring", "hit")} <= seen


def test_check_path_leaves_the_robot_where_it_was():
    world = cell()
    world.set_joints("arm", [0.3, 0.2, -0.4, 0.1])
    before = world.check()
    world.check_path("arm", np.zeros((3, 4)))
    assert answers(world.check()) == answers(before)
    assert len(world.check_path("arm", [0.3, 0.2, -0.4, 0.1])) == 1


def test_batches_larger_than_a_chunk_are_stitched_together():
    world = cell()
    q = np.random.default_rng(12).uniform(-2.8, 2.8, (5, 4))
    q = np.repeat(q, 900, axis=0)                 # 4,500 configurations, > 2 chunks
    batch = world.check_path("arm", q)
    first = [answers(batch[c]) for c in range(0, len(q), 900)]
    for c in range(len(q)):
        assert batch.decided_by[c].tolist() == batch.decided_by[c // 900 * 900].tolist()
    assert first == [answers(r) for r in one_by_one(world, q[::900])]


def test_bad_batches_are_refused():
    world = cell()
    with pytest.raises(InputError, match="mapping of object names"):
        world.check_many([np.eye(4)])
    with pytest.raises(InputError, match="unknown object 'ghost'"):
        world.check_many({"ghost": np.eye(4)[None]})
    with pytest.raises(InputError, match="same C"):
        world.check_many({"ball": np.tile(np.eye(4), (2, 1, 1)), "hose": np.eye(4)[None]})
    with pytest.raises(InputError, match="rigid"):
        world.check_many({"ball": np.diag([2.0, 1, 1, 1])[None]})
    with pytest.raises(InputError, match="no robot in group 'crane'"):
        world.check_path("crane", np.zeros((2, 4)))
    with pytest.raises(InputError, match="has 4 joints"):
        world.check_path("arm", np.zeros((2, 3)))
    with pytest.raises(InputError, match="outside its limits"):
        world.check_path("arm", [[0, 0, 0, 3.5]])


def test_link_pose_array_is_link_poses_for_each_configuration():
    robot = arm()
    q = np.random.default_rng(13).uniform(-2.8, 2.8, (20, 4))
    stacked = robot.link_pose_array(q)
    assert stacked.shape == (20, 4, 4, 4)
    for c in range(20):
        np.testing.assert_array_equal(stacked[c], np.array(list(robot.link_poses(q[c]).values())))


# -- the pose-batched chain gaps ----------------------------------------------------
def brute(a, b, pose):
    """Every unit pair's gap, b moved by pose."""
    moved = b.moved(pose)
    i, j = np.meshgrid(np.arange(len(a.edges)), np.arange(len(b.edges)), indexing="ij")
    i, j = i.ravel(), j.ravel()
    return unit_pair_gap(a.starts[i], a.ends[i], a.start_radii[i], a.end_radii[i],
                         moved.starts[j], moved.ends[j], moved.start_radii[j],
                         moved.end_radii[j])[0].min()


def walk(rng, n, step):
    return np.cumsum(rng.normal(0, step, (n, 3)), axis=0)


def chains(seed):
    """Open, closed, tapered, single-ball and disconnected chains."""
    rng = np.random.default_rng(seed)
    broken = Chain(walk(rng, 12, 0.2), rng.uniform(0.03, 0.1, 12),
                   np.array([[0, 1], [1, 2], [4, 5], [5, 6], [6, 7], [9, 10], [10, 11], [3, 3]]))
    return [Chain.along(walk(rng, 40, 0.1), 0.08),
            Chain.along(walk(rng, 17, 0.2), rng.uniform(0.02, 0.15, 17)),
            Chain.along(walk(rng, 9, 0.3), 0.05, closed=True),
            Chain.along(np.zeros((1, 3)), 0.2),
            broken]


def random_poses(rng, count, spread):
    m = np.tile(np.eye(4), (count, 1, 1))
    m[:, :3, :3] = Rotation.random(count, random_state=rng).as_matrix()
    m[:, :3, 3] = rng.uniform(-spread, spread, (count, 3))
    return m


def meshes(rng):
    """A torus, a long strip (centroids in sorted order), a stack of one triangle
    repeated (every centroid equal), one triangle, and a random soup."""
    torus = trimesh.creation.torus(0.3, 0.1, major_sections=20, minor_sections=8)
    x = np.repeat(np.linspace(0.0, 2.0, 60), 2)
    strip = np.c_[x, np.tile([0.0, 0.1], 60), 0.01 * x ** 2]
    strip_faces = np.array([[k, k + 1, k + 2] for k in range(len(strip) - 2)])
    one = np.array([[0.0, 0.0, 0.0], [0.3, 0.0, 0.0], [0.0, 0.3, 0.1]])
    soup = rng.uniform(-0.5, 0.5, (90, 3))
    return [(torus.vertices, torus.faces), (strip, strip_faces),
            (one, np.zeros((40, 3), np.int64) + [0, 1, 2]), (one, np.array([[0, 1, 2]])),
            (soup, np.arange(90).reshape(30, 3))]


def test_triangle_trees_hold_every_triangle_and_lose_no_minimum():
    from cadpipe.collision.chain_mesh import TriangleTree, segment_triangle, walk as mesh_walk

    rng = np.random.default_rng(5)
    chain = Chain.along(walk(rng, 14, 0.1), 0.04)
    tree = chain.tree
    for vertices, faces in meshes(rng):
        found = TriangleTree(vertices, faces)
        corners = np.asarray(vertices, float)[faces].reshape(-1, 9)
        held = found.order[found.order >= 0]
        np.testing.assert_array_equal(np.sort(held), np.arange(len(faces)))
        # every node's box holds the triangles of its leaves
        leaves = 2 ** found.depth
        for node in range(2 * leaves - 1):
            level = int(np.log2(node + 1))
            width = leaves >> level
            first = (node - (2 ** level - 1)) * width
            inside = found.order[first:first + width]
            points = corners[inside[inside >= 0]].reshape(-1, 3)
            if len(points):
                assert np.all(points >= found.boxes[node, :3]) and \
                    np.all(points <= found.boxes[node, 3:6])
            if len(points) and node < leaves - 1:
                # and its oriented box (centre, axes as rows, half extents) holds them too
                centre, axes, half = (found.frames[node, :3], found.frames[node, 3:12]
                                      .reshape(3, 3), found.frames[node, 12:])
                assert np.all(np.abs((points - centre) @ axes.T) <= half)
        poses = random_poses(rng, 40, 0.6)
        gap, unit = np.empty(len(poses)), np.empty(len(poses), np.int64)
        near, far = np.empty((len(poses), 3)), np.empty((len(poses), 3))
        mesh_walk(found.boxes, found.frames, found.triangles, found.depth, tree.table,
                  tree.index, tree.points, tree.depth, poses, False, gap, unit, near, far)
        for p, m in enumerate(poses):
            moved = chain.moved(m)
            expected = min(segment_triangle(moved.starts[u], moved.ends[u], t, np.empty(3),
                                            np.empty(3)) - moved.start_radii[u]
                           for u in range(len(moved.edges)) for t in corners)
            if expected > 1e-12:              # a penetration's value is only its sign
                assert gap[p] == pytest.approx(expected, abs=1e-12)
            else:
                assert gap[p] <= 1e-12


def test_mesh_walk_drops_no_touching_pair_at_grazing_poses():
    """The pipe-mesh walk drops node pairs by boxes, oriented boxes and a
    triangle's plane; none of it may lose a contact. At random poses, and at
    poses moved so that their closest unit and triangle are 1e-9 apart or 1e-9
    into each other, its yes/no answer and its gap are those of every unit
    against every triangle, and a pose moved into contact collides."""
    from cadpipe.collision.chain_mesh import TriangleTree, segment_triangle, walk as mesh_walk

    rng = np.random.default_rng(11)
    chain = Chain.along(walk(rng, 14, 0.1), rng.uniform(0.02, 0.06, 14))
    tree = chain.tree
    radius = np.maximum(chain.start_radii, chain.end_radii)     # the walk's capsules

    def every_pair(corners, pose):
        moved = chain.moved(pose)
        best, near, far = np.inf, np.empty(3), np.empty(3)
        for u in range(len(moved.edges)):
            for t in corners:
                a, b = np.empty(3), np.empty(3)
                d = segment_triangle(moved.starts[u], moved.ends[u], t, a, b) - radius[u]
                if d < best:
                    best, near, far = d, a, b
        return best, near, far

    grazing = 0
    for vertices, faces in meshes(rng):
        found = TriangleTree(vertices, faces)
        corners = np.asarray(vertices, float)[faces].reshape(-1, 9)
        poses, touching = list(random_poses(rng, 12, 0.6)), []
        for m in list(poses):
            gap, near, far = every_pair(corners, m)
            if gap > 0:
                towards = (far - near) / np.linalg.norm(far - near)
                for left in (1e-9, -1e-9):          # that pair's gap becomes ``left``
                    moved = m.copy()
                    moved[:3, 3] += (gap - left) * towards
                    poses.append(moved)
                    if left < 0:
                        touching.append(len(poses) - 1)
        poses = np.array(poses)
        expected = np.array([every_pair(corners, m)[0] for m in poses])
        count = len(poses)
        for yes_no in (True, False):
            gap, unit = np.empty(count), np.empty(count, np.int64)
            near, far = np.empty((count, 3)), np.empty((count, 3))
            mesh_walk(found.boxes, found.frames, found.triangles, found.depth, tree.table,
                      tree.index, tree.points, tree.depth, poses, yes_no, gap, unit, near, far)
            np.testing.assert_array_equal(gap <= 0, expected <= 0)
            assert np.all(gap[touching] <= 0)
            if not yes_no:
                apart = expected > 0
                np.testing.assert_allclose(gap[apart], expected[apart], rtol=0, atol=1e-12)
        grazing += np.sum(np.abs(expected) < 2e-9)
    assert grazing >= 40


@pytest.mark.parametrize("seed", [1, 2])
def test_chain_gaps_are_the_exact_minimum_at_every_pose(seed):
    rng = np.random.default_rng(seed)
    every = chains(seed)
    for a in every:
        for b in every:
            poses = random_poses(rng, 25, 1.0)
            expected = np.array([brute(a, b, m) for m in poses])
            gap, near, far = a.gaps(b, poses)
            np.testing.assert_allclose(gap, expected, atol=1e-12)
            apart = gap > 0
            np.testing.assert_allclose(np.linalg.norm(far - near, axis=1)[apart], gap[apart],
                                       atol=1e-9)
            touching = a.gaps(b, poses, stop_below=0.0)[0] <= 0
            np.testing.assert_array_equal(touching, expected <= 0)
            assert a.gap(b, poses[3])[0] == pytest.approx(expected[3], abs=1e-12)


def test_chain_gaps_over_many_chunks():
    rng = np.random.default_rng(3)
    a, b = chains(3)[:2]
    poses = random_poses(rng, 2 * CHUNK + 17, 1.2)
    batched = chain_gaps(a, b, poses, stop_below=0.0)[0] <= 0
    single = np.array([a.gap(b, m, stop_below=0.0)[0] <= 0 for m in poses[::37]])
    np.testing.assert_array_equal(batched[::37], single)
    assert 0 < batched.sum() < len(batched)


point = st.lists(st.floats(-1, 1), min_size=3, max_size=3)


@settings(max_examples=60, deadline=None)
@given(st.lists(point, min_size=2, max_size=12), st.lists(st.floats(0.01, 0.3), min_size=12,
                                                          max_size=12), st.integers(0, 2 ** 32 - 1))
def test_tree_radii_bound_every_node(points, radii, seed):
    """Each node's outer capsule holds its units; its inner one lies in their union."""
    chain = Chain.along(np.array(points), np.array(radii[:len(points)]))
    tree = chain.tree
    rng = np.random.default_rng(seed)
    for node in range(len(tree.p0)):
        if not np.isfinite(tree.outer[node]):
            continue
        depth = int(np.log2(node + 1))
        j = node - 2 ** depth + 1
        lo, hi = j * len(chain.edges) // 2 ** depth, (j + 1) * len(chain.edges) // 2 ** depth
        a, u = tree.start[node], tree.chord[node]
        # points on the units' surfaces lie within the outer radius of the chord
        s = rng.uniform(0, 1, 64)
        unit = rng.integers(lo, hi, 64)
        centre = chain.starts[unit] + s[:, None] * (chain.ends[unit] - chain.starts[unit])
        radius = chain.start_radii[unit] + s * (chain.end_radii[unit] - chain.start_radii[unit])
        direction = rng.normal(size=(64, 3))
        surface = centre + radius[:, None] * direction / np.linalg.norm(direction, axis=1,
                                                                        keepdims=True)
        t = np.clip((surface - a) @ u / max(u @ u, 1e-300), 0, 1)
        assert np.all(np.linalg.norm(surface - a - t[:, None] * u, axis=1)
                      <= tree.outer[node] + 1e-12)
        # points within the inner radius of the chord are inside the run's units
        if tree.inner[node] > 0:
            t = rng.uniform(0, 1, 64)
            offset = rng.normal(size=(64, 3))
            offset *= tree.inner[node] * rng.uniform(0, 1, (64, 1)) / np.linalg.norm(
                offset, axis=1, keepdims=True)
            inside = a + t[:, None] * u + offset
            run = Chain(chain.centers, chain.radii, chain.edges[lo:hi])
            assert np.all(run.signed_distance(inside) <= 1e-12)


def test_first_hit_gives_the_same_verdict_and_stops_early():
    world = cell()
    q = np.random.default_rng(13).uniform(-2.8, 2.8, (300, 4))
    stopped_early = 0
    batch = world.check_path("arm", q)
    for c, single in enumerate(q):
        world.set_joints("arm", single)
        quick = world.check(first_hit=True)
        full = batch[c]
        assert bool(quick) == bool(full)
        # what it did decide, it decided as the full check did
        for mine, theirs in zip(quick.pairs, full.pairs):
            assert mine.decided_by in (theirs.decided_by, "not checked")
        if quick:
            assert len(quick.collisions) >= 1
            stopped_early += any(p.decided_by == "not checked" for p in quick.pairs)
        # a full check afterwards decides the rest, as the batch did
        assert answers(world.check()) == answers(full)
    assert stopped_early > 10


@pytest.mark.parametrize("seed", [13, 14])
def test_check_path_first_hit_stops_at_the_first_colliding_configuration(seed):
    world = cell()
    rng = np.random.default_rng(seed)
    random = rng.uniform(-2.8, 2.8, (400, 4))
    free = random[~world.check_path("arm", random).colliding]
    # 40 free configurations first (more than a first chunk), then random ones
    q = np.concatenate([free[:40], random[:200]])
    full = world.check_path("arm", q)
    quick = world.check_path("arm", q, first_hit=True)
    first = int(np.argmax(full.colliding))
    assert full.colliding.any() and first >= 40
    assert int(np.argmax(quick.colliding)) == first and quick.colliding.sum() == 1
    for c in range(first + 1):                 # up to the hit, what the full check says
        assert answers(quick[c]) == answers(full[c])
    after = quick.decided_by[first + 1:]
    assert np.all((after == STAGES.index("not checked")) | (after == STAGES.index("allowed")))
    assert (after == STAGES.index("not checked")).any()
    quick, full = (world.check_path("arm", free, first_hit=hit) for hit in (True, False))
    assert len(free) > 40 and not quick.colliding.any()
    assert [answers(r) for r in quick] == [answers(r) for r in full]


def test_only_a_group_leaves_obstacle_pairs_unchecked():
    world = cell()
    world.set_joints("arm", [0.3, 0.2, -0.4, 0.1])
    full, robot = world.check(), world.check(only="arm")
    for mine, theirs in zip(robot.pairs, full.pairs):
        involves = "arm" in (world.group(mine.a), world.group(mine.b))
        assert mine.decided_by == (theirs.decided_by if involves or theirs.decided_by ==
                                   "allowed" else "not checked")
    with pytest.raises(InputError, match="no object in that group"):
        world.check(only="crane")


def test_answers_are_kept_by_version_not_by_hand():
    world = cell()
    scene_before = world.layout_version
    world.check()
    versions = world.pose_versions.copy()
    world.set_joints("arm", [0.1, 0.2, 0.3, 0.4])
    moved = world.pose_versions - versions
    assert moved.tolist() == [1 if world.group(n) == "arm" else 0 for n in world.names]
    assert world.layout_version == scene_before
    with pytest.raises(ValueError):
        world.pose_versions[0] = 7          # read-only: only the scene's calls move things
    world.add("late", Sphere(0.1), transform=shift(5, 5, 5))
    assert world.layout_version == scene_before + 1
    report = world.check()
    assert len(report.pairs) == len(world.names) * (len(world.names) - 1) // 2
