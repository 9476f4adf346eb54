"""Issue 12's seeded fuzz: 10,000 cases, each result judged by independent checks.

Six families (pipes, splices, hollow parts, assemblies, mutated specs, collision
poses), drawn from one fixed seed with numpy, a fifth to a third of each hostile
(NaN, zero, huge and tiny values, wrong types, far from the origin, micrometre
scale). Every case must end one of two ways:

* a result, which the judges accept: trimesh says watertight, consistently wound
  and of positive volume, manifold3d accepts it as a manifold, and the test-only
  triangle-triangle oracle (``tests/oracle.py``) finds no crossing faces; a
  collision answer agrees with manifold3d's intersection volume and FCL's distance;
* a :class:`cadpipe.CadpipeError`.

Anything else is counted and reported: a wrong result, a non-cadpipe exception,
a case slower than ``HANG_S``. All three counts must be 0, and the valid part of
each family must mostly build (the rate is asserted), so a change that made
every input raise fails too. ``pytest --fuzz-long`` runs ten times as many.
"""

import json
import math
import time
import warnings

import fcl
import manifold3d
import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

import cadpipe
from cadpipe import CadpipeError
from oracle import fcl_bvh, self_intersections

SEED = 20261201
HANG_S = 20.0
#: triangles per case: a case asking for more must be refused (a LimitError), fast
BUDGET = 200_000
COUNTS = {"pipes": 2500, "splices": 800, "hollow": 800, "assemblies": 500, "specs": 2000,
          "poses": 3402}                           # 10,002 cases in all
#: a pose case "collides" for the oracle above this fraction of the smaller volume
OVERLAP_FRACTION = 1e-6

HOSTILE_NUMBERS = [0.0, -1.0, math.nan, math.inf, -math.inf, 1e308, -1e308, 1e-300, 1e15,
                   10 ** 40, 2 ** 63, True, "x", None, [], [1, 2]]


class Tally:
    """Outcomes of one family; ``problems`` lists what must never happen."""

    def __init__(self, family):
        self.family, self.built, self.refused, self.valid, self.valid_built = family, 0, 0, 0, 0
        self.problems = []

    def run(self, case, make, judge, valid):
        start = time.perf_counter()
        try:
            with warnings.catch_warnings(), cadpipe.limits.using(max_triangles=BUDGET):
                warnings.simplefilter("ignore", DeprecationWarning)
                warnings.simplefilter("error", RuntimeWarning)   # numpy's overflow/invalid
                result = make()
        except CadpipeError:
            self.refused += 1
            result = None
        except Exception as exc:  # noqa: BLE001 (what the test is looking for)
            self.problems.append(f"{self.family} {case}: {type(exc).__name__}: {exc}"[:300])
            result = None
        else:
            self.built += 1
            self.valid_built += valid
            for why in judge(result):
                self.problems.append(f"{self.family} {case}: wrong result: {why}")
        self.valid += valid
        if time.perf_counter() - start > HANG_S:
            self.problems.append(f"{self.family} {case}: took {time.perf_counter() - start:.0f} s")

    def check(self, min_rate):
        problems = self.problems
        assert not problems, f"{len(problems)} problems, e.g.\n" + "\n".join(problems[:10])
        rate = self.valid_built / max(self.valid, 1)
        assert rate >= min_rate, f"{self.family}: only {rate:.0%} of valid cases built"


def judge_mesh(mesh):
    """What is wrong with ``mesh`` as a solid, by trimesh, manifold3d and the oracle."""
    vertices, faces = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    if not len(faces):
        return ["no triangles"]
    tm = trimesh.Trimesh(vertices, faces, process=False)
    wrong = []
    if not tm.is_watertight:
        wrong.append("trimesh: not watertight")
    if not tm.is_winding_consistent:
        wrong.append("trimesh: winding not consistent")
    if not tm.volume > 0:
        wrong.append(f"trimesh: volume {tm.volume:.3g}")
    solid = manifold3d.Manifold(manifold3d.Mesh(vert_properties=vertices.astype(np.float32),
                                                tri_verts=faces.astype(np.uint32)))
    if solid.status() != manifold3d.Error.NoError:
        wrong.append(f"manifold3d: {solid.status()}")
    crossing = self_intersections(vertices, faces)
    if crossing:
        wrong.append(f"{crossing} pairs of faces cross")
    return wrong


@pytest.fixture(scope="module")
def scale(request):
    return 10 if request.config.getoption("--fuzz-long") else 1


def _length_scale(rng):
    """Mostly unit size; sometimes micrometres or kilometres, sometimes far away."""
    return float(10.0 ** rng.choice([0, 0, 0, -6, -3, 3])), \
        rng.choice([0.0, 0.0, 1.0, 1e3]) * rng.normal(size=3)


def _pipe_args(rng, hostile):
    size, offset = _length_scale(rng)
    count = int(rng.integers(2, 7))
    points = offset + size * rng.uniform(-1, 1, (count, 3))
    args = {"path": points, "radius": size * float(rng.uniform(0.005, 0.15)),
            "sides": int(rng.integers(3, 17)), "caps": str(rng.choice(["flat", "round"])),
            "corners": str(rng.choice(["miter", "miter", "round"])),
            "envelope": bool(rng.integers(2))}
    if hostile:
        key = str(rng.choice(["path", "radius", "sides", "caps", "miter_limit", "cap_segments"]))
        value = HOSTILE_NUMBERS[int(rng.integers(len(HOSTILE_NUMBERS)))]
        if key == "path":
            points = points.copy()
            points[int(rng.integers(count))] = value if isinstance(value, float) else 1e300
            value = points
        args[key] = value
    return args


def _pipe(args):
    args = dict(args)
    return cadpipe.Pipe(cadpipe.Path(args.pop("path")), **args)


@pytest.mark.slow
def test_pipes(scale):
    rng, tally = np.random.default_rng(SEED), Tally("pipes")
    for case in range(COUNTS["pipes"] * scale):
        hostile = rng.random() < 0.25
        args = _pipe_args(rng, hostile)
        tally.run(case, lambda args=args: _pipe(args).mesh(), judge_mesh, not hostile)
    tally.check(min_rate=0.5)


@pytest.mark.slow
def test_splices(scale):
    rng, tally = np.random.default_rng(SEED + 1), Tally("splices")
    for case in range(COUNTS["splices"] * scale):
        hostile = rng.random() < 0.2
        size, offset = _length_scale(rng)
        start, pipes = offset, []
        for _ in range(int(rng.integers(2, 4))):
            step = size * rng.uniform(0.5, 1.0, (int(rng.integers(1, 3)), 3))
            points = np.vstack([start, start + np.cumsum(step, axis=0)])
            pipes.append({"path": points, "radius": size * float(rng.uniform(0.03, 0.1)),
                          "sides": int(rng.choice([3, 4, 6, 8, 12]))})
            start = points[-1]
        if hostile:
            pipes[int(rng.integers(len(pipes)))] = _pipe_args(rng, True)
        tally.run(case, lambda pipes=pipes: cadpipe.splice(*map(_pipe, pipes)), judge_mesh,
                  not hostile)
    tally.check(min_rate=0.5)


@pytest.mark.slow
def test_hollow_parts(scale):
    rng, tally = np.random.default_rng(SEED + 2), Tally("hollow")
    for case in range(COUNTS["hollow"] * scale):
        hostile = rng.random() < 0.25
        args = _pipe_args(rng, False)
        args["sides"] = max(args["sides"], 6)
        wall = float(args["radius"] * rng.uniform(0.1, 0.6))
        ends = str(rng.choice(["open", "closed"]))
        if hostile:
            wall = HOSTILE_NUMBERS[int(rng.integers(len(HOSTILE_NUMBERS)))]
        tally.run(case, lambda a=args, w=wall, e=ends: cadpipe.HollowPipe(_pipe(a), w, e).mesh(),
                  judge_mesh, not hostile)
    tally.check(min_rate=0.35)


def _primitive(rng):
    kind = rng.choice(["box", "sphere", "cylinder", "pipe"])
    if kind == "box":
        return cadpipe.primitives.box(rng.uniform(0.2, 1.0, 3))
    if kind == "sphere":
        return cadpipe.primitives.sphere(float(rng.uniform(0.2, 0.6)), int(rng.integers(8, 33)))
    if kind == "cylinder":
        return cadpipe.primitives.cylinder(float(rng.uniform(0.1, 0.5)),
                                           float(rng.uniform(0.2, 1.0)), int(rng.integers(3, 33)))
    return _pipe({"path": rng.uniform(-0.6, 0.6, (3, 3)), "radius": 0.08, "sides": 8})


@pytest.mark.slow
def test_assemblies(scale):
    rng, tally = np.random.default_rng(SEED + 3), Tally("assemblies")
    for case in range(COUNTS["assemblies"] * scale):
        hostile = rng.random() < 0.2

        def make(hostile=hostile):
            asm = cadpipe.Assembly(units="mm")
            for k in range(int(rng.integers(2, 5))):
                move = np.eye(4)
                move[:3, :3] = Rotation.random(random_state=rng).as_matrix()
                move[:3, 3] = rng.uniform(-0.4, 0.4, 3)
                if hostile and k == 0:
                    move[int(rng.integers(3)), 3] = HOSTILE_NUMBERS[int(rng.integers(3))]
                op = "add" if k < 2 else str(rng.choice(["add", "subtract", "intersect"]))
                getattr(asm, op)(f"p{k}", _primitive(rng), move)
            return asm.union()

        tally.run(case, make, judge_mesh, not hostile)
    tally.check(min_rate=0.6)


BASE_SPECS = [
    {"parts": [{"kind": "box", "size": [1, 2, 0.5]},
               {"kind": "sphere", "radius": 0.6, "segments": 16, "op": "subtract"}]},
    {"parts": [{"kind": "pipe", "path": [[0, 0, 0], [1, 0, 0], [1, 1, 0]], "radius": 0.1,
                "sides": 8, "wall": 0.02}]},
    {"parts": [{"kind": "chain", "pipes": [
        {"path": [[0, 0, 0], [1, 0, 0]], "radius": 0.1, "sides": 6},
        {"path": [[1.3, 0, 0], [2, 0, 0]], "radius": 0.1, "sides": 8}]}]},
    {"parts": [{"kind": "cylinder", "radius": 0.3, "height": 1, "sides": 12,
                "transform": {"translate": [0, 0, 1], "rotate": [0, 30, 0]}},
               {"kind": "pipe", "radius": 0.05, "corners": "round",
                "path": {"points": [[0, 0, 0], [0.5, 0.2, 0.3], [1, 0, 1]], "spline": True}}]},
]
SPEC_VALUES = HOSTILE_NUMBERS + [-5, 3, 300, 10 ** 6, "../../x", "\x00\x07", "", {},
                                 {"a": 1}, [[0, 0, 0]], "round", "add", 1e-12, 0.5]


def _mutate(rng, spec):
    """``spec`` with one value somewhere replaced, a key added, or a key removed."""
    spec = json.loads(json.dumps(spec))
    table, key = spec, None
    while True:
        keys = list(table) if isinstance(table, dict) else list(range(len(table)))
        if not keys:
            break
        key = keys[int(rng.integers(len(keys)))]
        if not isinstance(table[key], (dict, list)) or rng.random() < 0.4:
            break
        table = table[key]
    what = rng.random()
    if what < 0.1 and isinstance(table, dict):
        table.pop(key, None)
    elif what < 0.2 and isinstance(table, dict):
        table["bogus"] = 1
    elif key is not None:
        table[key] = SPEC_VALUES[int(rng.integers(len(SPEC_VALUES)))]
    return spec


@pytest.mark.slow
def test_mutated_specs(scale, tmp_path):
    rng, tally = np.random.default_rng(SEED + 4), Tally("specs")
    for case in range(COUNTS["specs"] * scale):
        base = BASE_SPECS[case % len(BASE_SPECS)]
        valid = rng.random() < 0.2
        spec = base if valid else _mutate(rng, base)
        file = tmp_path / f"s{case % 7}.json"
        file.write_text(json.dumps(spec))
        tally.run(case, lambda file=file: cadpipe.load(file).union(), judge_mesh, valid)
    tally.check(min_rate=0.95)


@pytest.mark.slow
@pytest.mark.parametrize("size, offset", [(1e-6, 1.0), (1.0, 0.0), (1e-3, 1e3)])
def test_collision_poses(scale, size, offset):
    """Micrometre, unit and millimetre objects far out: cadpipe's answer for each pose
    against manifold3d's overlap volume and FCL's distance."""
    rng = np.random.default_rng(SEED + 5)
    count = COUNTS["poses"] * scale // 3
    ball = trimesh.creation.icosphere(1, radius=size)
    block = trimesh.creation.box(extents=[2 * size, size, 0.5 * size])
    place = np.eye(4)
    place[:3, 3] = offset
    world = cadpipe.CollisionWorld()
    world.add("ball", cadpipe.Mesh(ball.vertices, ball.faces), place)
    world.add("block", cadpipe.Mesh(block.vertices, block.faces), place)
    poses = np.tile(np.eye(4), (count, 1, 1))
    poses[:, :3, :3] = Rotation.random(count, random_state=rng).as_matrix()
    poses[:, :3, 3] = offset + size * rng.uniform(-1.8, 1.8, (count, 3))
    with warnings.catch_warnings():
        warnings.simplefilter("error")            # a RuntimeWarning is a failure here
        reports = world.check_many({"ball": poses})
    solid_a = manifold3d.Manifold(manifold3d.Mesh(
        vert_properties=(ball.vertices / size).astype(np.float32),
        tri_verts=ball.faces.astype(np.uint32)))
    solid_b = manifold3d.Manifold(manifold3d.Mesh(
        vert_properties=(block.vertices / size).astype(np.float32),
        tri_verts=block.faces.astype(np.uint32)))
    smaller = min(solid_a.volume(), solid_b.volume())
    geom_a, geom_b = fcl_bvh(ball), fcl_bvh(block)
    wrong = []
    for c in range(count):
        hit = bool(reports[c].collisions)
        unit = poses[c].copy()
        unit[:3, 3] = (unit[:3, 3] - offset) / size          # the same pose, at unit scale
        overlap = (solid_a.transform(unit[:3]) ^ solid_b).volume()
        if overlap > OVERLAP_FRACTION * smaller and not hit:
            wrong.append(f"pose {c}: overlap {overlap:.3g} but reported apart")
        if hit and overlap <= 0:
            a = fcl.CollisionObject(geom_a, fcl.Transform(poses[c][:3, :3], poses[c][:3, 3]))
            b = fcl.CollisionObject(geom_b, fcl.Transform(place[:3, :3], place[:3, 3]))
            gap = fcl.distance(a, b, fcl.DistanceRequest(), fcl.DistanceResult())
            if gap > 1e-3 * size:
                wrong.append(f"pose {c}: {gap / size:.3g} sizes apart but reported colliding")
    assert not wrong, f"{len(wrong)} wrong answers, e.g. {wrong[:5]}"
    assert 0.1 < np.mean([bool(reports[c].collisions) for c in range(count)]) < 0.9
