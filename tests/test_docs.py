"""The docs stay true: every code block of the quickstart and the README runs as written,
docs/cli.md is what docs/make_docs.py generates from the command's own parsers and its
examples run, every relative link resolves, and the figures regenerate, small and drawn."""

import importlib.util
import re
import shlex
import shutil
from pathlib import Path as FilePath
from xml.etree import ElementTree

import numpy as np
import pytest
from PIL import Image

from cadpipe.cli import main

ROOT = FilePath(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
FENCE = re.compile(r"^```(\w*)\n(.*?)^```", re.M | re.S)
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")
NAMED_FILE = re.compile(r"# (\S+\.(?:toml|json))\n")


def make_docs():
    spec = importlib.util.spec_from_file_location("make_docs", DOCS / "make_docs.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def blocks(markdown):
    """``(language, code, first line number)`` of each fenced block."""
    text = markdown.read_text(encoding="utf-8")
    for m in FENCE.finditer(text):
        yield m.group(1), m.group(2), text.count("\n", 0, m.start(2)) + 1


def run_blocks(markdown):
    """Run the page's blocks in order, in the current folder, the way a reader would.

    ``python`` blocks share one namespace (tracebacks point at the page's lines);
    each ``cadpipe ...`` line of an ``sh`` block goes through the CLI and must exit 0;
    a ``toml``/``json`` block whose first line is ``# NAME`` is written to NAME.
    Returns how many blocks ran.
    """
    namespace = {"__name__": "__docs__"}
    ran = 0
    for language, code, line in blocks(markdown):
        where = f"{markdown.name}:{line}"
        if language == "python":
            exec(compile("\n" * (line - 1) + code, str(markdown), "exec"), namespace)
        elif language == "sh":
            for command in code.splitlines():
                words = shlex.split(command, comments=True)
                if words[:1] == ["cadpipe"]:
                    assert main(words[1:]) == 0, f"{where}: `{command}` did not exit 0"
                else:   # the two make targets run the rest: CI runs `make test` itself
                    assert words in ([], ["make", "demo"], ["make", "test"]), \
                        f"{where}: only cadpipe commands can run here, got `{command}`"
        elif language in ("toml", "json"):
            name = NAMED_FILE.match(code)
            assert name, f"{where}: start a {language} block with `# FILE` so it can be written"
            FilePath(name.group(1)).write_text(code, encoding="utf-8")
        else:
            continue
        ran += 1
    return ran


@pytest.fixture
def reader_folder(tmp_path, monkeypatch):
    """An empty folder with the shipped assets, as the repository root has them."""
    shutil.copytree(ROOT / "assets", tmp_path / "assets")
    monkeypatch.chdir(tmp_path)
    return tmp_path


@pytest.mark.parametrize("page", ["docs/quickstart.md", "README.md"])
def test_every_code_block_runs(page, reader_folder, capsys):
    assert run_blocks(ROOT / page) >= 2
    if page == "docs/quickstart.md":
        for written in ("pipe.stl", "pipe.usda", "duct.glb", "tee.stl", "tee.usda", "tee.png",
                        "tee.html", "duct_cable.svg", "preview/preview.png",
                        "tee_from_spec.3mf", "certificates"):
            assert (reader_folder / written).exists(), written
        assert "COLLISION duct <-> fixture" in capsys.readouterr().out


def test_cli_reference_is_generated_from_the_parsers():
    committed = (DOCS / "cli.md").read_text(encoding="utf-8")
    assert committed == make_docs().cli_reference(), \
        "docs/cli.md is stale: run `.venv/bin/python docs/make_docs.py` and commit it"


def test_cli_reference_names_every_option():
    from cadpipe.cli import commands  # noqa: F401  (registers the subcommands)
    from cadpipe.cli import build_parser

    text = (DOCS / "cli.md").read_text(encoding="utf-8")
    docs = make_docs()
    for name, parser in docs._subparsers(build_parser()).items():
        section = text.split(f"## cadpipe {name}\n", 1)[1].split("\n## ", 1)[0]
        for action in parser._actions:
            for flag in action.option_strings:
                assert f"`{flag}`" in section, (name, flag)
        assert "```sh\ncadpipe " + name in section


def test_cli_reference_examples_run(reader_folder, capsys):
    assert run_blocks(DOCS / "cli.md") >= 5


def test_relative_links_resolve():
    pages = [ROOT / "README.md", *sorted(DOCS.glob("*.md"))]
    for page in pages:
        text = page.read_text(encoding="utf-8")
        for target in LINK.findall(text):
            if re.match(r"[a-z]+:", target):
                continue
            file, _, anchor = target.partition("#")
            linked = (page.parent / file).resolve() if file else page
            assert linked.exists(), f"{page.name}: broken link {target}"
            if anchor and linked.suffix == ".md":
                headings = re.findall(r"^#+ (.+)$", linked.read_text(encoding="utf-8"), re.M)
                slugs = {re.sub(r"[^\w\- ]", "", h.lower()).replace(" ", "-") for h in headings}
                assert anchor in slugs, f"{page.name}: no heading for {target}"


def test_readme_links_every_guide():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert readme.splitlines()[3:5] == [
        "make demo    # set up .venv, install, run the built-in example end to end "
        "(files in out/demo)",
        "make test    # set up .venv, install, run the whole test suite"]
    for guide in ("quickstart", "algorithms", "spec", "export", "collision", "cli",
                  "performance"):
        assert f"(docs/{guide}.md)" in readme, guide


def test_figures_regenerate_small_drawn_and_referenced(tmp_path):
    written = make_docs().figures(tmp_path)
    committed = sorted((DOCS / "figures").iterdir())
    assert sorted(p.name for p in written) == [p.name for p in committed]
    algorithms = (DOCS / "algorithms.md").read_text(encoding="utf-8")
    for path in [*written, *committed]:
        assert path.stat().st_size < 200_000, path
        if path.suffix == ".png":
            pixels = np.asarray(Image.open(path).convert("L"), dtype=float)
            assert pixels.std() > 10, f"{path} looks blank"
        else:
            shapes = [e for e in ElementTree.parse(path).iter()
                      if e.tag.endswith(("polygon", "path"))]
            assert len(shapes) >= 2, f"{path} draws nothing"
    for path in committed:
        assert f"(figures/{path.name})" in algorithms, f"algorithms.md does not show {path.name}"
