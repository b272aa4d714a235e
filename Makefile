# hydrodiag — every target creates the virtual environment and installs the project first.
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed-stamp
export HYDRODIAG_CACHE_DIR ?= $(CURDIR)/.hydrodiag-cache

.PHONY: run test test-postgres lint bench accuracy pump-study trend-study load-bench console-bench screenshots real-data chaos discrepancy-study discrepancy-effects discrepancy-paper000 discrepancy-prototype diagnose-bench diagnose-ab history-bench job-stall soak serve-memory clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

run: $(STAMP)
	$(PY) -m app.cli serve

test: $(STAMP)
	$(PY) -m pytest -q -n 2

test-postgres: $(STAMP)
	$(PY) -m tests.app.postgres_run

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

real-data: $(STAMP)
	$(PY) -m benchmarks.real_data

# the trends' time-left coverage and the level-shift test's false alarms and power
trend-study: $(STAMP)
	$(PY) -m benchmarks.trend_study

load-bench: $(STAMP)
	$(PY) -m benchmarks.load_bench

# in-process diagnose(): fast (compiled) vs direct path, warm and at new conditions; batches
diagnose-bench: $(STAMP)
	$(PY) -m benchmarks.diagnose_bench

# the same diagnose() against an older tree, interleaved: make diagnose-ab BASE=/tmp/base
# (git worktree add /tmp/base REV first)
diagnose-ab: $(STAMP)
	$(PY) -m benchmarks.diagnose_ab $(BASE) $(ROUNDS)

console-bench: $(STAMP)
	$(PY) -m benchmarks.console_bench

# pages, trends and a stored diagnosis with 1,000-100,000 stored diagnoses of one rig
history-bench: $(STAMP)
	$(PY) -m benchmarks.history_bench

# how long a discrepancy run in a server thread keeps the other threads (/health) waiting
job-stall: $(STAMP)
	$(PY) -m benchmarks.job_stall

# memory of serve's processes (PSS) with 1 and 2 workers, ready and after sweeps
serve-memory: $(STAMP)
	$(PY) -m benchmarks.serve_memory

# screenshots of every console page, taken by the browser tests in a real Chromium
screenshots: $(STAMP)
	HYDRODIAG_SCREENSHOTS=$(CURDIR)/docs/img $(PY) -m pytest -q -rs tests/app/console/test_browser.py

chaos: $(STAMP)
	$(PY) -m benchmarks.chaos

discrepancy-study: $(STAMP)
	OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 $(PY) -m benchmarks.discrepancy_study

discrepancy-effects: $(STAMP)
	$(PY) -m benchmarks.discrepancy_effects

discrepancy-paper000: $(STAMP)
	$(PY) -m benchmarks.discrepancy_paper000

# the steady workflow on the design notes' prototype grid, like for like with its figures
discrepancy-prototype: $(STAMP)
	OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 $(PY) -m benchmarks.discrepancy_prototype

# the service under a mixed workload for 10 min (SOAK_DURATION_S): resources over time
soak: $(STAMP)
	$(PY) -m benchmarks.soak
