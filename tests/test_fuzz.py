"""Fuzzing (issue 7): random specs and paths either build a watertight solid or raise a
cadpipe error; nothing else escapes. Over 2,000 examples in the default run."""

import json
import tempfile
from pathlib import Path as FilePath

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import cadpipe
from cadpipe import CadpipeError

FAST = settings(deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                      HealthCheck.function_scoped_fixture])
# 700 + 1000 + 400 = 2,100 examples in every default run

anything = st.one_of(st.none(), st.booleans(), st.integers(-5, 5), st.just(float("nan")),
                     st.floats(-2, 2), st.text(max_size=4), st.lists(st.integers(0, 2), max_size=3))
coordinate = st.floats(-1, 1)
point = st.lists(coordinate, min_size=3, max_size=3)
size = st.floats(0.02, 0.6)


@st.composite
def pipe_part(draw):
    points = draw(st.lists(point, min_size=2, max_size=4))
    path = draw(st.sampled_from(["list", "spline"]))
    part = {"kind": "pipe", "radius": draw(st.floats(0.01, 0.1)),
            "sides": draw(st.integers(3, 12)), "caps": draw(st.sampled_from(["flat", "round"])),
            "path": points if path == "list" else {"points": points, "spline": True,
                                                   "step": 0.05}}
    return part


@st.composite
def primitive_part(draw):
    kind = draw(st.sampled_from(["box", "sphere", "cylinder"]))
    sizes = {"box": {"size": draw(st.lists(size, min_size=3, max_size=3))},
             "sphere": {"radius": draw(size), "segments": draw(st.integers(3, 12))},
             "cylinder": {"radius": draw(size), "height": draw(size),
                          "sides": draw(st.integers(3, 12))}}[kind]
    return {"kind": kind, **sizes}


@st.composite
def spec(draw):
    """Mostly valid specs; one in three has one fault injected somewhere."""
    parts = draw(st.lists(st.one_of(pipe_part(), primitive_part()), min_size=1, max_size=3))
    for i, p in enumerate(parts):
        p["name"] = f"p{i}"
        if draw(st.booleans()):
            p["transform"] = {"translate": draw(point)}
        if draw(st.integers(0, 3)) == 0:
            p["op"] = draw(st.sampled_from(["subtract", "intersect"]))
    top = {"parts": parts, "units": draw(st.sampled_from(["m", "mm"]))}
    if draw(st.integers(0, 2)) == 0:
        part = draw(st.sampled_from(parts))
        key = draw(st.sampled_from(sorted(part) + ["unknown", "color"]))
        part[key] = draw(anything)
    return top


def assert_builds_or_refuses(build):
    try:
        mesh = build()
    except CadpipeError:
        return
    assert mesh.is_watertight and mesh.volume > 0


@settings(FAST, max_examples=700)
@given(spec())
def test_random_specs_build_or_fail_cleanly(data):
    with tempfile.TemporaryDirectory() as folder:
        file = FilePath(folder) / "fuzz.json"
        file.write_text(json.dumps(data))
        assert_builds_or_refuses(lambda: cadpipe.load(file).union())


@settings(FAST, max_examples=1000)
@given(st.lists(st.lists(st.one_of(st.floats(-1, 1), st.just(float("nan")),
                                   st.just(float("inf"))), min_size=3, max_size=3),
                min_size=0, max_size=8),
       st.one_of(st.floats(-0.1, 0.3), st.just(float("nan")), st.just(0.05)),
       st.integers(1, 20),
       st.sampled_from(["flat", "round"]), st.booleans(), st.booleans())
def test_random_paths_build_or_fail_cleanly(points, radius, sides, caps, closed, spline):
    def build():
        path = (cadpipe.Path.spline(points, step=0.05, closed=closed) if spline
                else cadpipe.Path(points, closed=closed))
        return cadpipe.Pipe(path, radius, sides=sides, caps=caps).mesh()

    assert_builds_or_refuses(build)


@settings(FAST, max_examples=400)
@given(st.lists(st.tuples(st.integers(3, 9), st.floats(0.02, 0.2), st.floats(-0.3, 0.3)),
                min_size=1, max_size=4), st.sampled_from(["lcm", "merge"]), st.booleans())
def test_random_chains_splice_or_fail_cleanly(pipes, transition, closed):
    def build():
        made = [cadpipe.Pipe([[i, dy, 0.0], [i + 0.6, dy, 0.1]], r, sides=n)
                for i, (n, r, dy) in enumerate(pipes)]
        return cadpipe.splice(*made, transition=transition, closed=closed)

    assert_builds_or_refuses(build)
