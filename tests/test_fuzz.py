"""Fuzzing: inputs a user may write must build a valid solid; faulty ones must raise the
cadpipe error that names the fault.

Each family has two strategies. The *valid* one draws inputs inside the documented
limits (paths with room for their radius, specs of such parts); each example must build
a closed, outward solid that trimesh also accepts as a volume. A few may still be
refused by the pipe's own self-intersection check (a random walk can come back on
itself); the build rate is reported with ``hypothesis.event`` and asserted to be high.
The *invalid* one takes a valid input and injects one fault; the error must be the
specific type and name the argument or spec key at fault.
"""

import json
import math
import tempfile
from pathlib import Path as FilePath

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

import cadpipe
from cadpipe import GeometryError, InputError, SpecError
from rates import assert_builds_mostly

FAST = settings(deadline=None, database=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])


def check_solid(mesh):
    """A closed, outward solid by our checks and trimesh's (an independent reference)."""
    assert mesh.is_oriented and mesh.volume > 0
    reference = mesh.to_trimesh()
    assert reference.is_watertight and reference.is_winding_consistent and reference.is_volume
    assert mesh.volume == pytest.approx(reference.volume, rel=1e-9)


def record(outcomes, build):
    """Build, count and report the outcome; only a self-intersection refusal is allowed."""
    try:
        mesh = build()
    except GeometryError as exc:
        assert "intersect" in str(exc), exc          # the one documented refusal
        event("refused: self-intersection")
        outcomes["refused"] += 1
        return
    event("built")
    outcomes["built"] += 1
    check_solid(mesh)


# -- paths and pipes -------------------------------------------------------------------
def turn(direction, angle, spin):
    """``direction`` turned by ``angle`` about an axis across it chosen by ``spin``."""
    helper = np.eye(3)[int(np.argmin(np.abs(direction)))]
    u = np.cross(direction, helper)
    u /= np.linalg.norm(u)
    v = np.cross(direction, u)
    across = np.cos(spin) * u + np.sin(spin) * v
    return np.cos(angle) * direction + np.sin(angle) * across


@st.composite
def walk(draw, low=2, high=7):
    """An open polyline: steps of 0.3 to 1, each turning at most 75 degrees."""
    count = draw(st.integers(low, high))
    theta, phi = draw(st.floats(0, math.pi)), draw(st.floats(0, 2 * math.pi))
    direction = np.array([math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi),
                          math.cos(theta)])
    points = [np.array(draw(st.lists(st.floats(-1, 1), min_size=3, max_size=3)))]
    for _ in range(count - 1):
        points.append(points[-1] + draw(st.floats(0.3, 1.0)) * direction)
        direction = turn(direction, draw(st.floats(0, math.radians(75))),
                         draw(st.floats(0, 2 * math.pi)))
    return np.array(points)


@st.composite
def loop(draw):
    """A closed polygon: 3 to 8 points around a circle of radius 0.5 to 1, a little jitter."""
    count = draw(st.integers(3, 8))
    radius = draw(st.floats(0.5, 1.0))
    angle = 2 * np.pi * np.arange(count) / count
    jitter = np.array(draw(st.lists(st.floats(-0.05, 0.05), min_size=count, max_size=count)))
    return np.c_[radius * np.cos(angle), radius * np.sin(angle), jitter]


@st.composite
def valid_pipe(draw):
    """Keyword arguments of a pipe the documentation says can be built."""
    closed = draw(st.booleans())
    points = draw(loop() if closed else walk())
    return {"points": points, "closed": closed, "spline": draw(st.booleans()),
            "radius": draw(st.floats(0.01, 0.08)), "sides": draw(st.integers(3, 16)),
            "caps": draw(st.sampled_from(["flat", "round"]))}


def build_pipe(points, closed, spline, radius, sides, caps):
    path = (cadpipe.Path.spline(points, step=0.05, closed=closed) if spline
            else cadpipe.Path(points, closed=closed))
    return cadpipe.Pipe(path, radius, sides=sides, caps=caps).mesh()


@pytest.mark.slow
def test_valid_pipes_build():
    @given(valid_pipe())
    def run(outcomes, args):
        record(outcomes, lambda: build_pipe(**args))

    assert_builds_mostly(run, 400, "valid pipes", FAST)


#: one fault each: (argument, bad value or function of the valid points, error, named)
PIPE_FAULTS = [
    ("points", lambda p: np.where(np.arange(p.size).reshape(p.shape) == 4, np.nan, p),
     InputError, "points"),
    ("points", lambda p: np.where(np.arange(p.size).reshape(p.shape) == 1, np.inf, p),
     InputError, "points"),
    ("points", lambda p: p[:1], InputError, "points"),
    ("points", lambda p: p[:, :2], InputError, "points"),
    ("points", lambda p: np.repeat(p[:1], 3, axis=0), InputError, "points"),
    ("radius", 0.0, InputError, "radius"),
    ("radius", -0.05, InputError, "radius"),
    ("radius", float("nan"), InputError, "radius"),
    ("radius", float("inf"), InputError, "radius"),
    ("radius", 1e-15, InputError, "radius"),
    ("sides", 2, InputError, "sides"),
    ("sides", 5000, InputError, "sides"),
    ("caps", "square", InputError, "caps"),
]


@settings(FAST, max_examples=300)
@given(valid_pipe(), st.sampled_from(PIPE_FAULTS))
def test_invalid_pipes_raise_the_error_that_names_the_fault(args, fault):
    key, bad, error, named = fault
    args = {**args, "closed": False, "spline": False}
    if key == "points":
        args["points"] = bad(args["points"])
    else:
        args[key] = bad
    event(f"fault: {key}")
    with pytest.raises(error) as caught:
        build_pipe(**args)
    assert named in str(caught.value)


# -- specs -----------------------------------------------------------------------------
size = st.floats(0.05, 0.6)


@st.composite
def pipe_part(draw):
    points = draw(walk(2, 4)).round(6).tolist()
    spline = draw(st.booleans())
    return {"kind": "pipe", "radius": draw(st.floats(0.01, 0.08)),
            "sides": draw(st.integers(3, 12)), "caps": draw(st.sampled_from(["flat", "round"])),
            "path": {"points": points, "spline": True, "step": 0.05} if spline else points}


@st.composite
def primitive_part(draw):
    kind = draw(st.sampled_from(["box", "sphere", "cylinder"]))
    sizes = {"box": {"size": draw(st.lists(size, min_size=3, max_size=3))},
             "sphere": {"radius": draw(size), "segments": draw(st.integers(4, 12))},
             "cylinder": {"radius": draw(size), "height": draw(size),
                          "sides": draw(st.integers(3, 12))}}[kind]
    return {"kind": kind, **sizes}


@st.composite
def valid_spec(draw):
    """A spec within the documented limits: parts added, a small one maybe subtracted."""
    parts = draw(st.lists(st.one_of(pipe_part(), primitive_part()), min_size=1, max_size=3))
    for i, part in enumerate(parts):
        part["name"] = f"p{i}"
        if draw(st.booleans()):
            part["transform"] = {"translate": draw(st.lists(st.floats(-0.5, 0.5), min_size=3,
                                                            max_size=3))}
        if draw(st.booleans()):
            part["color"] = draw(st.sampled_from(["#ff8800", [0.2, 0.4, 0.6]]))
    if draw(st.booleans()):
        parts.append({"name": "hole", "kind": "sphere", "op": "subtract",
                      "radius": draw(st.floats(0.01, 0.05))})
    return {"parts": parts, "units": draw(st.sampled_from(["m", "mm"]))}


def load(spec):
    with tempfile.TemporaryDirectory() as folder:
        file = FilePath(folder) / "fuzz.json"
        file.write_text(json.dumps(spec))
        return cadpipe.load(file).union()


@pytest.mark.slow
def test_valid_specs_build():
    @given(valid_spec())
    def run(outcomes, spec):
        record(outcomes, lambda: load(spec))

    assert_builds_mostly(run, 250, "valid specs", FAST)


#: per part kind, keys and values the spec reference rejects
SPEC_FAULTS = {
    "pipe": [("radius", 0), ("radius", -1), ("radius", "thick"), ("sides", 2), ("sides", 2.5),
             ("caps", "square"), ("path", [[0, 0, 0]]), ("path", [[0, 0], [1, 0]]),
             ("path", "here")],
    "box": [("size", -1), ("size", [1, 2]), ("size", "big")],
    "sphere": [("radius", 0), ("segments", 1)],
    "cylinder": [("height", 0), ("sides", 2), ("radius", [1, 2])],
    "any": [("unknown", 1), ("color", "zz"), ("color", [2, 0, 0]), ("op", "xor"),
            ("transform", {"translate": "x"}), ("transform", {"rotate": [1, 2]}),
            ("transform", {"scale": 0})],
}


@settings(FAST, max_examples=250)
@given(valid_spec(), st.data())
def test_invalid_specs_raise_a_spec_error_at_the_key(spec, data):
    i = data.draw(st.integers(0, len(spec["parts"]) - 1))
    part = spec["parts"][i]
    key, bad = data.draw(st.sampled_from(SPEC_FAULTS[part["kind"]] + SPEC_FAULTS["any"]))
    part[key] = bad
    event(f"fault: {part['kind']}.{key}")
    with pytest.raises(SpecError) as caught:
        load(spec)
    assert f"parts[{i}].{key}" in str(caught.value)


# -- splicing --------------------------------------------------------------------------
@st.composite
def valid_chain(draw):
    """Pipes one after another along x, each with room before the next."""
    count = draw(st.integers(1, 4))
    pipes, x = [], 0.0
    for _ in range(count):
        length, gap = draw(st.floats(0.4, 0.8)), draw(st.floats(0.3, 0.6))
        dy, dz = draw(st.floats(-0.15, 0.15)), draw(st.floats(-0.15, 0.15))
        pipes.append(([[x, dy, dz], [x + length, dy, dz]], draw(st.floats(0.02, 0.12)),
                      draw(st.integers(3, 9))))
        x += length + gap
    return pipes, draw(st.sampled_from(["lcm", "merge"]))


def test_valid_chains_splice():
    @given(valid_chain())
    def run(outcomes, chain):
        pipes, transition = chain
        record(outcomes, lambda: cadpipe.splice(
            *(cadpipe.Pipe(p, r, sides=n) for p, r, n in pipes), transition=transition))

    assert_builds_mostly(run, 200, "valid chains", FAST)


@settings(FAST, max_examples=100)
@given(valid_chain(), st.sampled_from([("transition", "zigzag", "transition"),
                                       ("pipe", "a string", "argument"),
                                       ("pipe", None, "argument"),
                                       ("none", None, "at least one")]))
def test_invalid_chains_raise_an_input_error(chain, fault):
    pipes, transition = chain
    made = [cadpipe.Pipe(p, r, sides=n) for p, r, n in pipes]
    kind, bad, named = fault
    if kind == "transition":
        transition = bad
    elif kind == "pipe":
        made.insert(len(made) // 2, bad)
    else:
        made = []
    with pytest.raises(InputError) as caught:
        cadpipe.splice(*made, transition=transition)
    assert named in str(caught.value)
