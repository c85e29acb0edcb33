# Quick start (fresh machine):  make map   |   make test
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin

.PHONY: map test install bench clean

$(BIN)/fieldmap: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[test]"
	@touch $@

install: $(BIN)/fieldmap

## The main job: global 1-degree disturbance map at 20 km from the bundled EIGEN-6S (outputs/).
map: install
	$(BIN)/fieldmap map --height-km 20 --step-deg 1 --out outputs

## The whole test suite (includes the slow high-degree and external-tool checks).
test: install
	$(BIN)/python -m pytest -q

bench: install
	for b in benchmarks/bench_*.py; do $(BIN)/python $$b || exit 1; done

clean:
	rm -rf $(VENV) build *.egg-info

## The documentation: HTML in docs/_build/html (fresh environment, warnings are errors).
.PHONY: docs
docs: install $(VENV)/.docs
	$(BIN)/python -m sphinx -E -W --keep-going -q -b html docs docs/_build/html
	@echo "docs: docs/_build/html/index.html"

$(VENV)/.docs: pyproject.toml | install
	$(BIN)/python -m pip install --quiet -e ".[docs]"
	@touch $@
