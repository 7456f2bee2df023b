# study: make-driven parameter studies of stick-slip locomotion.
#   make          compute the paper's regime map and draw it (figures/regime_map.png)
#   make test     set up .venv on a fresh machine, lint, run the test suite
#   make bench    benchmarks (timings; never pass/fail)

PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: all map test test-slow lint bench clean

all: map

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test]'
	touch $(STAMP)

map: $(STAMP)
	$(PY) -m study.figures.regime_map --output figures/regime_map.png

lint: $(STAMP)
	$(PY) -m ruff check study tests benchmarks

test: $(STAMP) lint
	$(PY) -m pytest -m "not slow"

test-slow: $(STAMP)
	$(PY) -m pytest -m slow

bench: $(STAMP)
	$(PY) benchmarks/bench_velocity_map.py

clean:
	rm -rf $(VENV) results figures .pytest_cache .ruff_cache .hypothesis
