# Two commands a user needs: `make demo` and `make test`. Both set up .venv on first use,
# each installing only what it needs: the package for the demo, its test extra (the
# consumers and references the tests check against) for the tests, and the benchmark
# peers only for `make bench`.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
BASE   := $(VENV)/.base-stamp
TESTS  := $(VENV)/.test-stamp
BENCH  := $(VENV)/.bench-stamp
OUT    ?= out/demo

.PHONY: demo test bench clean chromium consumers

$(BASE): pyproject.toml setup.py
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip 'setuptools>=77' wheel
	$(PY) -m pip install --quiet -e .
	touch $@

$(TESTS): $(BASE)
	$(PY) -m pip install --quiet -e '.[test]'
	touch $@

$(BENCH): $(TESTS)
	$(PY) -m pip install --quiet -e '.[test,bench]'
	touch $@

# the compiled kernels, built again whenever a C source changes (cadpipe.core.kernels
# refuses to run kernels built from other sources)
KERNELS := $(VENV)/.kernels-stamp
$(KERNELS): $(BASE) $(wildcard cadpipe/core/csrc/*)
	$(PY) -m pip install --quiet --no-deps --no-build-isolation -e .
	touch $@

demo: $(BASE) $(KERNELS)
	$(VENV)/bin/cadpipe demo -o $(OUT)

# ruff's rule set is in pyproject.toml; slow cases run too, spread over the cores
test: $(TESTS) $(KERNELS) chromium consumers
	$(VENV)/bin/ruff check cadpipe tests benchmarks examples
	$(PY) -m pytest -n auto

bench: $(BENCH) $(KERNELS)
	for f in benchmarks/bench_*.py; do $(PY) $$f || exit 1; done

# headless browser that tests/test_preview.py drives (Debian's package; needs root to install)
chromium:
	command -v chromium >/dev/null || (apt-get update && apt-get install -y chromium)

# the programs tests/test_consumers.py opens cadpipe's files with: PrusaSlicer (Debian,
# needs root to install), the Khronos glTF validator (npm, into .tools/) and Blender as a
# Python module (bpy from PyPI, into a venv of its own: its wheels are for CPython 3.11 and
# numpy < 2, which .venv's packages have outgrown); lib3mf and usd-core come with the test
# extra
GLTF_VALIDATOR := .tools/node_modules/gltf-validator/package.json
BLENDER := .tools/blender/.installed-stamp
consumers: $(GLTF_VALIDATOR) $(BLENDER)
	command -v prusa-slicer >/dev/null || (apt-get update && \
		apt-get install -y --no-install-recommends prusa-slicer)

$(BLENDER):
	$(PYTHON) -m venv .tools/blender
	.tools/blender/bin/python -m pip install --quiet 'bpy>=5.0.1'
	touch $@

$(GLTF_VALIDATOR):
	command -v node >/dev/null || (apt-get update && apt-get install -y nodejs npm)
	npm install --silent --prefix .tools gltf-validator@2.0.0-dev.3.10

clean:
	rm -rf $(VENV) out .tools .pytest_cache .hypothesis
