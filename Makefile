# hydrodiag — every target creates the virtual environment and installs the project first.
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed-stamp
export HYDRODIAG_CACHE_DIR ?= $(CURDIR)/.hydrodiag-cache

.PHONY: run test lint bench accuracy pump-study load-bench discrepancy-study clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

run: $(STAMP)
	$(PY) -m app.cli serve

test: $(STAMP)
	$(PY) -m pytest -q -n 2

lint: $(STAMP)
	$(VENV)/bin/ruff check sim diagnostics app tests benchmarks
	$(VENV)/bin/mypy sim diagnostics app

bench: $(STAMP)
	$(PY) -m benchmarks.bench_sim

clean:
	rm -rf $(VENV) .hydrodiag-cache .pytest_cache .mypy_cache .ruff_cache

accuracy: $(STAMP)
	$(PY) -m benchmarks.accuracy

pump-study: $(STAMP)
	$(PY) -m benchmarks.pump_study

load-bench: $(STAMP)
	$(PY) -m benchmarks.load_bench

discrepancy-study: $(STAMP)
	$(PY) -m benchmarks.discrepancy_study
