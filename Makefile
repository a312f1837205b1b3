# dualpose: every target creates .venv with python3 -m venv when missing and installs the package first.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed-test
BSTAMP := $(VENV)/.installed-bench
DSTAMP := $(VENV)/.installed-docs
RUFF_PATHS := src tests benchmarks docs/conf.py docs/_ext docs/examples

.PHONY: demo test bench docs lint accuracy-table clean

$(PY):
	$(PYTHON) -m venv $(VENV)

NATIVE := CMakeLists.txt $(shell find src/native src/launcher -type f 2>/dev/null)

# the native kernels compile here, at install (scikit-build-core + the machine's cmake/ninja/g++); the build
# directory is kept, so an edit of src/native recompiles only what changed
$(STAMP): $(PY) pyproject.toml $(NATIVE)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q "scikit-build-core>=0.10" "numpy>=2.0"
	$(PY) -m pip install -q --no-build-isolation -e '.[test]'
	touch $(STAMP)

$(BSTAMP): $(STAMP)
	$(PY) -m pip install -q --no-build-isolation -e '.[test,bench]'
	touch $(BSTAMP)

$(DSTAMP): $(STAMP)
	$(PY) -m pip install -q --no-build-isolation -e '.[test,docs]'
	touch $(DSTAMP)

demo: $(STAMP)
	$(VENV)/bin/dualpose demo
	$(VENV)/bin/dualpose fuse --out demo-output --force  # the main job on the built-in simulated run

test: $(STAMP)
	$(VENV)/bin/ruff check $(RUFF_PATHS)
	$(VENV)/bin/mypy
	$(PY) -m pytest -q -n 2 -p no:cacheprovider

bench: $(BSTAMP)
	$(PY) benchmarks/bench_algebra.py

# the documentation site into docs/_build/html: warnings are errors, every cross-reference must resolve (-n),
# no network needed (docs/_ext/dualpose_api.py writes the intersphinx inventories)
docs: $(DSTAMP)
	$(PY) -m sphinx -b html -W --keep-going -n -q docs docs/_build/html
	@echo "docs/_build/html/index.html"

accuracy-table: $(STAMP)
	$(PY) tests/accuracy/make_table.py docs/accuracy.md

lint: $(STAMP)
	$(VENV)/bin/ruff check $(RUFF_PATHS)

clean:
	rm -rf $(VENV) .mypy_cache build src/*.egg-info docs/_build docs/api docs/auto_examples docs/sg_execution_times.rst
