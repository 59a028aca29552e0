# Every target bootstraps .venv from nothing (python3 -m venv + pip install -e .[dev]).
PY      := .venv/bin/python
STAMP   := .venv/.installed
JOBS    ?= 2
# test workers (pytest-xdist); worksteal evens out the long tests between them
TEST_JOBS ?= 2

.PHONY: test test-all bench docs lint format calibrate sweep-stiffness sweep-process \
        optimise-process optimise-design sensitivity uncertainty \
        optimise-tolerances optimise-tradeoff paper-findings sweep-process-150mm validate report clean-venv

$(STAMP): pyproject.toml
	python3 -m venv .venv
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

test: $(STAMP)
	$(PY) -m pytest -m "not slow" -n $(TEST_JOBS) --dist worksteal --durations=20 tests

test-all: $(STAMP)
	$(PY) -m pytest -n $(TEST_JOBS) --dist worksteal --durations=20 tests

bench: $(STAMP)
	$(PY) benchmarks/run.py

docs: $(STAMP)
	NO_MKDOCS_2_WARNING=1 $(PY) -m mkdocs build --strict --site-dir site

lint: $(STAMP)
	$(PY) -m ruff check ufmt tests benchmarks
	$(PY) -m ruff format --check ufmt tests benchmarks

format: $(STAMP)
	$(PY) -m ruff format ufmt tests benchmarks
	$(PY) -m ruff check --fix ufmt tests benchmarks

calibrate: $(STAMP)
	$(PY) -m ufmt.cli calibrate

validate: $(STAMP)
	$(PY) -m ufmt.cli validate

report: $(STAMP)
	$(PY) -m ufmt.cli report

sweep-stiffness: $(STAMP)
	$(PY) -m ufmt.cli run studies/sweep-stiffness.toml --jobs $(JOBS)

sweep-process: $(STAMP)
	$(PY) -m ufmt.cli run studies/sweep-process.toml --jobs $(JOBS)

optimise-process: $(STAMP)
	$(PY) -m ufmt.cli run studies/optimise-process.toml --jobs $(JOBS)

optimise-design: $(STAMP)
	$(PY) -m ufmt.cli run studies/optimise-design.toml --jobs $(JOBS)

sensitivity: $(STAMP)
	$(PY) -m ufmt.cli run studies/sensitivity.toml --jobs $(JOBS)

uncertainty: $(STAMP)
	$(PY) -m ufmt.cli run studies/uncertainty.toml --jobs $(JOBS)

sweep-process-150mm: $(STAMP)
	$(PY) -m ufmt.cli run studies/sweep-process-150mm.toml --jobs $(JOBS)

optimise-tradeoff: $(STAMP)
	$(PY) -m ufmt.cli run studies/optimise-tradeoff.toml --jobs $(JOBS)

paper-findings: $(STAMP)
	$(PY) -m ufmt.cli run studies/paper-findings.toml --jobs $(JOBS)

optimise-tolerances: $(STAMP)
	$(PY) -m ufmt.cli run studies/optimise-tolerances.toml --jobs $(JOBS)

clean-venv:
	rm -rf .venv
