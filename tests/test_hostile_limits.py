"""Every limit of :mod:`cadpipe.limits` is reachable three ways (API, spec key, CLI flag),
the caller's value wins over the spec's, and the message names the ways to raise it."""

import dataclasses
import subprocess
import sys

import pytest

from cadpipe import limits
from cadpipe.errors import InputError, LimitError, SpecError
from cadpipe.spec import read

SPHERE = '[[parts]]\nkind = "sphere"\nradius = 1\nsegments = 64\n'     # 2,048 triangles


def names():
    return [f.name for f in dataclasses.fields(limits.Limits)]


def test_every_limit_has_a_cli_flag_and_every_one_but_the_spec_and_the_jobs_reads_a_spec_key():
    from cadpipe.cli import build_parser
    from cadpipe.cli import commands  # noqa: F401

    assert set(limits.CLI_FLAGS) == set(names())
    assert set(limits.SPEC_KEYS) == set(names()) - {"max_spec_bytes", "max_depth",
                                                    "max_number_chars", "max_jobs"}
    assert limits.JOBS_KEYS == ("max_jobs",)
    for name in names():
        args = build_parser().parse_args(["check", "x.stl", limits.flag(name), "7"])
        assert getattr(args, name) == 7


@pytest.mark.parametrize("name", limits.SPEC_KEYS)
def test_a_spec_key_sets_its_limit(tmp_path, name):
    spec = tmp_path / "s.toml"
    spec.write_text(f"{name} = 12345678\n" + SPHERE)
    assert read(spec).budgets[name] == 12345678


def test_the_spec_key_raises_and_lowers_the_triangle_budget_and_the_caller_wins(tmp_path):
    spec = tmp_path / "s.toml"
    spec.write_text("max_triangles = 1000\n" + SPHERE)
    with pytest.raises(LimitError) as caught:
        read(spec)
    assert "limit of 1,000" in str(caught.value) and "--max-triangles" in str(caught.value)
    assert caught.value.file == str(spec)
    assert read(spec, max_triangles=3000).budgets["max_triangles"] == 3000


def test_a_read_limit_from_the_api_applies_while_the_spec_is_parsed(tmp_path):
    spec = tmp_path / "s.json"
    spec.write_text('{"parts": [{"kind": "box", "size": [1, 1, 1]}]}')
    read(spec)
    with pytest.raises(LimitError) as caught:
        read(spec, max_depth=2)
    assert "--max-depth" in str(caught.value) and "spec key" not in str(caught.value)


def test_a_spec_cannot_set_the_limits_on_its_own_file(tmp_path):
    spec = tmp_path / "s.toml"
    spec.write_text("max_depth = 100000\n" + SPHERE)
    with pytest.raises(SpecError) as caught:
        read(spec)
    assert caught.value.key == "max_depth"


@pytest.mark.parametrize("value", [0, -1, 2.5, "7", True, float("nan")])
def test_bad_budget_values_are_input_errors_naming_the_limit(value):
    with pytest.raises(InputError) as caught:
        with limits.using(max_triangles=value):
            pass
    assert caught.value.key == "max_triangles"
    with pytest.raises(InputError) as caught:
        with limits.using(max_everything=1):
            pass
    assert caught.value.key == "max_everything"


def test_the_cli_flag_wins_over_the_spec_key(tmp_path):
    spec = tmp_path / "s.toml"
    spec.write_text("max_triangles = 1000\n" + SPHERE)
    run = [sys.executable, "-m", "cadpipe", "build", str(spec), "-q", "-o", str(tmp_path / "a.stl")]
    refused = subprocess.run(run, capture_output=True, text=True, timeout=120)
    assert refused.returncode == 1 and "limit of 1,000" in refused.stderr
    done = subprocess.run(run + ["--max-triangles", "3000"], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "a.stl").exists()
