# Quick start (fresh machine):  make map   |   make test
#
# One virtual environment (.venv); each target installs what it needs on top of it, once:
# `make map` the runtime dependencies only, `make test` adds the `test` extra, `make lint` the
# `dev` extra. Stamp files in .venv record what was installed from which pyproject.toml.
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
PIP    := $(BIN)/python -m pip install --quiet

.PHONY: map test test-fast lint format install bench clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(PIP) --upgrade pip

$(VENV)/.runtime: pyproject.toml | $(BIN)/python
	$(PIP) -e .
	@touch $@

$(VENV)/.test: pyproject.toml $(VENV)/.runtime
	$(PIP) -e ".[test]"
	@touch $@

$(VENV)/.dev: pyproject.toml $(VENV)/.runtime
	$(PIP) -e ".[dev]"
	@touch $@

## fieldmap and its runtime dependencies.
install: $(VENV)/.runtime

## The main job: global 1-degree disturbance map at 20 km from the bundled EIGEN-6S (outputs/).
map: install
	$(BIN)/fieldmap map --height-km 20 --step-deg 1 --out outputs

## The whole test suite (includes the slow high-degree and external-tool checks).
test: $(VENV)/.test
	$(BIN)/python -m pytest -q

## The test suite without the tests marked slow (about half the time).
test-fast: $(VENV)/.test
	$(BIN)/python -m pytest -q -m "not slow"

## Style and types: ruff (lint and format) and mypy, as CI runs them.
lint: $(VENV)/.dev
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/mypy

## Rewrite the files in ruff's format and apply ruff's safe fixes.
format: $(VENV)/.dev
	$(BIN)/ruff format .
	$(BIN)/ruff check --fix .

## Benchmarks: ratios against peers (pyshtools, GeographicLib, numba) measured in the same run.
bench: $(VENV)/.test
	for b in benchmarks/bench_*.py; do $(BIN)/python $$b || exit 1; done

clean:
	rm -rf $(VENV) build *.egg-info

## The documentation: HTML in docs/_build/html (fresh environment, warnings are errors).
.PHONY: docs
## The examples run again each time (sphinx-gallery would keep the figures of unchanged scripts).
docs: install $(VENV)/.docs
	rm -rf docs/gallery docs/_build/gallery_outputs
	$(BIN)/python -m sphinx -E -W --keep-going -q -b html docs docs/_build/html
	@echo "docs: docs/_build/html/index.html"

$(VENV)/.docs: pyproject.toml | install
	$(BIN)/python -m pip install --quiet -e ".[docs]"
	@touch $@
