# study: make-driven parameter studies of stick-slip locomotion.
#   make            run every workflow whose spec or package changed: results/<name>.nc
#   make test       set up .venv on a fresh machine, lint, run the test suite
#   make bench      benchmarks (timings; never pass/fail)
#   make cf-check   CF-1.11 compliance of every result file (IOOS compliance-checker, offline)

PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STUDY  := $(VENV)/bin/study
STAMP  := $(VENV)/.installed

WORKFLOWS := $(wildcard workflows/*.toml)
RESULTS   := $(patsubst workflows/%.toml,results/%.nc,$(WORKFLOWS))
PACKAGE   := $(shell find study -name '*.py') $(wildcard results_schema/*.json)

.PHONY: all results map test test-slow lint bench cf-check list clean

all: results

results: $(RESULTS)

# make asks whenever the spec or the package is newer; `study run` recomputes only
# when the spec's canonical hash or the computing code really changed.
results/%.nc: workflows/%.toml $(PACKAGE) | $(STAMP)
	$(STUDY) run $< -o $@

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test]'
	touch $(STAMP)

map: $(STAMP)
	$(PY) -m study.figures.regime_map --output figures/regime_map.png

list: $(STAMP)
	$(STUDY) list

lint: $(STAMP)
	$(PY) -m ruff check study tests benchmarks

test: $(STAMP) lint
	$(PY) -m pytest -m "not slow"

test-slow: $(STAMP)
	$(PY) -m pytest -m slow

bench: $(STAMP)
	$(PY) benchmarks/bench_velocity_map.py
	$(PY) benchmarks/bench_study_overhead.py

cf-check: $(RESULTS)
	$(VENV)/bin/compliance-checker --test cf:1.11 --criteria strict $(RESULTS)

clean:
	rm -rf $(VENV) results figures .pytest_cache .ruff_cache .hypothesis
