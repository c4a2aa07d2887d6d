# `make demo` and `make test` each build .venv from nothing, install, and run.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed-stamp
OUT ?= demo-out

.PHONY: demo test lint types kernels unit bench docs clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/torquemap demo --out $(OUT)

test: lint
	$(MAKE) --no-print-directory -j2 types kernels
	$(MAKE) --no-print-directory unit

lint: $(STAMP)
	$(BIN)/ruff check src tests benchmarks
	$(BIN)/ruff format --check src tests benchmarks

types: $(STAMP)
	$(BIN)/mypy

# numba compiles each kernel on first use and caches it on disk (src/torquemap/_jit.py): the
# kernels' own tests compile most of them once here, on the core mypy leaves idle, and the two
# test workers then load them instead of each compiling its own (a fresh clone: ~1 min each)
kernels: $(STAMP)
	$(BIN)/pytest -q tests/test_kernels.py tests/test_fit_kernels.py tests/test_multirate.py \
		tests/test_estimate_kernels.py

unit: $(STAMP)
	$(BIN)/pytest -n 2 --dist loadgroup -q

# API reference from the docstrings (pdoc); fails on a public name without a docstring or a
# cross-reference that does not resolve (tests/test_apidoc.py runs the same check)
docs: $(STAMP)
	$(BIN)/python -m torquemap._apidoc --build build/api

bench: $(STAMP)
	$(BIN)/python benchmarks/force_accuracy.py
	$(BIN)/python benchmarks/linearize.py

clean:
	rm -rf $(VENV) $(OUT) build src/*.egg-info
