# study: make-driven parameter studies of stick-slip locomotion.
#   make            run every workflow whose spec or package changed: results/<name>.nc
#                   (parameter studies and the steering scenes alike), two at a time
#                   (RESULT_JOBS=1: one after another); ends with the table of the
#                   slowest runs (wall time, points computed and reused)
#   make figures    redraw every figure from its result file: figures/<name>.png, .pdf
#                   (only those whose data, options or code changed), two at a time
#                   from one process (FIGURE_JOBS=1: one after another)
#   make docs       the documentation site, build/html/index.html (Sphinx, warnings are
#                   errors; runs the example gallery); needs the figures, so `make` first
#   make test       set up .venv on a fresh machine, lint, run the default test tier (every
#                   module and capability with its headline checks; not the slow and fuzz marks)
#   make test-unit  the default tier's tests/unit only (no process, install, cluster or docs run)
#   make test-integration  the default tier's processes, installs, clusters and the docs
#   make test-slow  the tests marked slow (long reference integrations, big grids; CI runs them)
#   make test-all   everything: the default tier, the slow tier and the fuzz tiers
#   make fuzz       seeded fuzz tiers: corrupted result files must be refused, never crash;
#                   counts of what they tried -> results/reliability.md
#   make bench      benchmarks (timings; never pass/fail); work-precision -> results/bench.nc,
#                   two-way work-precision -> results/bench-two-way.nc and .md,
#                   each benchmark's table for the documentation -> docs/speed/*.md,
#                   one-thread map against a single-purpose floor -> results/bench-floor.md,
#                   one-thread map, one-way against two-way -> results/bench-two-way-map.md,
#                   exact two-way solver vs integrator -> results/bench-two-way-agreement.md,
#                   flight: M -> 1 map with and without it, work-precision -> results/bench-flight.md,
#                   orbit sweeps, one thread: two-way continued and cold against one-way on the
#                   paper, M = 1 and flight maps and one point, by status with passes, the
#                   goals of issue 22 -> results/bench-orbit-sweeps.md,
#                   the cost of a call on a few points -> results/bench-small-calls.md,
#                   a flight map with frontier run again onto another output and forced,
#                   against the first run -> results/bench-frontier-reuse.md,
#                   slow sweeps and verified starts against the one-way map
#                   -> results/bench-protocol.md,
#                   basins (24 starts) against a single-start map -> results/bench-basins.md,
#                   a fold from a sweep's bracket and fold curves against basins lines
#                   -> results/bench-branches.md,
#                   reading a million-row measurement file -> docs/speed/measurements.md
#   make bench-quick  every benchmark with --quick (fewer rounds, smaller sizes; a
#                   change's before and after): tables to results/bench-quick/, never
#                   docs/speed/
#   make cf-check   CF-1.11 compliance of every result file (IOOS compliance-checker, offline)
#   make schemas    refresh results_schema/, the repo's copy of the package's JSON schemas,
#                   and the generated tables of docs/user-guide/specs.md
#   make designs    run every design spec in designs/: results/design-<name>.nc

PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STUDY  := $(VENV)/bin/study
STAMP  := $(VENV)/.installed

WORKFLOWS := $(wildcard workflows/*.toml)
# `make` runs RESULT_JOBS studies at a time (default 2, the cores of the machine it was
# timed on; RESULT_JOBS=1: one after another). On a fresh clone most of a study's time
# is numba compiling its kernels, on one core: two at a time, one study compiles while
# the other computes. They start in this order (the others follow in file order): a
# two-way study first (it compiles the two-way kernels), then the one-way studies and
# the steering scenes, whose kernels are others, so that the second job never waits
# for or repeats that compile; then the studies that compile kernels of their own
# (slow sweeps, attractors, basins, sections).
RESULT_JOBS ?= 2
RESULTS_FIRST := irregular-bouncing \
    regime-map frontier mass-ratio mass-ratio-limit thresholds threshold-collapse \
    velocity-curves steering steering-calibration steering-calibration-two-way \
    steering-plan \
    hysteresis-flight regime-map-flight basins-flight bifurcation-along-a
STEMS     := $(patsubst workflows/%.toml,%,$(WORKFLOWS))
RESULTS   := $(patsubst %,results/%.nc,$(foreach name,$(RESULTS_FIRST),$(filter $(name),$(STEMS))) \
                 $(filter-out $(RESULTS_FIRST),$(STEMS)))
PACKAGE   := $(shell find study -name '*.py') $(wildcard study/schemas/*.json)

.PHONY: all results result-files figures figure-files docs docs-html test test-unit test-integration \
        test-slow test-all fuzz lint bench bench-quick compare cf-check list clean \
        schemas designs FORCE

all: results

# Every `study run` appends its wall time and point counts to RUN_LOG; `make` ends with
# the table of the slowest runs it started (those begun after RUN_SINCE, the time make
# read this file).
RUN_LOG   := results/run-times.jsonl
RUN_SINCE := $(shell date +%s)

results: | $(STAMP)
	@$(MAKE) --no-print-directory -j$(RESULT_JOBS) result-files
	@$(PY) -m study.engine.run_log $(RUN_LOG) --since $(RUN_SINCE)

result-files: $(RESULTS)

# make asks whenever the spec or the package is newer; `study run` recomputes only
# when the spec's canonical hash or the computing code really changed.
results/%.nc: workflows/%.toml $(PACKAGE) | $(STAMP)
	$(STUDY) run $< -o $@ --log-times $(RUN_LOG)

# Designs (study design): the structure parameters that achieve target behaviours.
DESIGNS := $(patsubst designs/%.toml,results/design-%.nc,$(wildcard designs/*.toml))

designs: $(DESIGNS)

results/design-%.nc: designs/%.toml $(PACKAGE) | $(STAMP)
	$(STUDY) design $< -o $@

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	@# Before 0.1.0 the distribution was called `study` (another project's name on the
	@# package index); a venv made then still holds it. Removed before the install: its
	@# record owns the `study` command, which the install writes again.
	$(PY) -m pip uninstall --quiet --yes study 2>/dev/null || true
	$(PY) -m pip install --quiet --upgrade pip
	@# The metadata of an earlier install in the source tree would name its old version
	@# to anything that imports study from here (pytest, sphinx): made anew below.
	rm -rf stickslip_study.egg-info
	$(PY) -m pip install --quiet -e '.[test,docs]'
	touch $(STAMP)

# The package reads study/schemas/ (package data, shipped in the wheel); results_schema/
# keeps an identical copy at the top of the repo (a test checks they agree).
# The spec schema's observables are exported from study/studies/observables.py, the
# parameters of the study, fit and design spec schemas from study/model/parameters.py, the
# starts (spec and result schemas) from study/model/starts.py; results_schema/
# is the repository's copy of the package's schemas (a test checks both). The tables
# of docs/user-guide/specs.md (parameters, observables, contact laws, starts) are written into
# the page from the same declarations (docs/generate_tables.py; a test checks them).
schemas: | $(STAMP)
	$(PY) -c "from study.studies.schema import export_spec_schema as e; text = e(); \
	open('study/schemas/study-spec-v1.schema.json', 'w').write(text)"
	$(PY) -c "from study.analyses.measurements import export_measurement_schema as e; text = e(); \
	open('study/schemas/study-measurements-v1.schema.json', 'w').write(text)"
	$(PY) -c "from study.analyses.fit_spec import export_fit_spec_schema as e; text = e(); \
	open('study/schemas/study-fit-spec-v1.schema.json', 'w').write(text)"
	$(PY) -c "from study.analyses.design_spec import export_design_spec_schema as e; text = e(); \
	open('study/schemas/study-design-spec-v1.schema.json', 'w').write(text)"
	$(PY) -c "from study.engine.validation.header import export_result_schema as e; text = e(); \
	open('study/schemas/study-result-v1.schema.json', 'w').write(text)"
	$(MAKE) $(patsubst study/schemas/%,results_schema/%,$(wildcard study/schemas/*.json))
	$(PY) docs/generate_tables.py

results_schema/%.json: study/schemas/%.json
	cp $< $@

# Figures, each redrawn from its result file alone: figures/NAME.png and .pdf.
FIGURES := thresholds velocity-curves regime-map force-traces mass-ratio \
           threshold-collapse mass-ratio-limit coupling \
           steering steering-calibration steering-plan
# The same figures drawn from the two-way studies: figures/NAME-two-way.png is figure
# NAME of a *-two-way result (each figure's title says which coupling its file holds).
TWO_WAY_FIGURES := regime-map velocity-curves force-traces mass-ratio-limit
FIGURES += $(addsuffix -two-way,$(TWO_WAY_FIGURES))
# The same figures drawn from the studies with flight (two-way coupling, the base flies
# past lift-off): figures/NAME-flight.png is figure NAME of a *-flight result; bouncing
# shows the bouncing region of mass-ratio-limit-flight.
FLIGHT_FIGURES := regime-map velocity-curves mass-ratio-limit coupling
FIGURES += $(addsuffix -flight,$(FLIGHT_FIGURES)) bouncing lyapunov
# The bifurcation diagram along each drive axis: figures/bifurcation-along-X.png is
# figure bifurcation of results/bifurcation-along-X.nc.
FIGURES += bifurcation-along-a bifurcation-along-f
# Slow sweeps up and down: figures/hysteresis-X.png is figure hysteresis of
# results/hysteresis-X.nc.
FIGURES += hysteresis-flight hysteresis-paper
# Basins: figures/basins-X.png is figure basins of results/basins-X.nc (workflows
# basins-flight and basins-paper: every attractor of 24 starts and its basin fraction).
FIGURES += basins-flight basins-paper
# The folds of the forward and backward hops against M (workflow mass-ratio-folds).
FIGURES += fold-curves
# The branches the slow sweeps of hysteresis-flight ride (its branches observable).
FIGURES += branch-diagram
# `make figures` draws them from one process, FIGURE_JOBS at a time (default 2; 1: one
# after another): the figure rules below only write their `study figure` commands to
# FIGURE_LIST (and make the result files they need), then python -m study.figure_batch
# runs each in a child forked from one process that paid the imports (numba, xarray,
# matplotlib) and the figure code's fingerprints once. A `study figure` process of its
# own spends about 2.5 s on those, most of the 3 s an up-to-date figure takes. The 29
# figures of a fresh clone's results, on a 2-core machine shared with other work (load
# 0.2-3; 3 December 2026): one `study figure` process each, one after another, 162 and
# 145 s drawn, 86 s up to date (what `make docs` spent before its build); this way 61
# and 70 s drawn, 10 s up to date; the same PNGs, byte for byte. `make figures/NAME.png`
# draws one figure with its own `study figure` process.
FIGURE_JOBS ?= 2
FIGURE_COMMANDS := build/figure-commands
FIGURE_FILES := $(addprefix figures/,$(addsuffix .png,$(FIGURES)))
figures: | $(STAMP)
	@mkdir -p build && rm -f $(FIGURE_COMMANDS)
	@$(MAKE) --no-print-directory figure-files FIGURE_LIST=$(FIGURE_COMMANDS)
	$(PY) -m study.figure_batch --jobs $(FIGURE_JOBS) $(FIGURE_COMMANDS)

figure-files: $(FIGURE_FILES)

# How a figure rule draws: `study figure ...`; under `make figures`, the command
# appended to FIGURE_LIST.
STUDY_FIGURE = $(if $(FIGURE_LIST),@echo >>$(FIGURE_LIST),$(STUDY))

figures/thresholds.png: results/thresholds.nc
figures/velocity-curves.png: results/velocity-curves.nc
figures/regime-map.png: results/regime-map.nc
figures/force-traces.png: results/regime-map.nc
figures/mass-ratio.png: results/mass-ratio.nc
figures/threshold-collapse.png: results/threshold-collapse.nc
figures/mass-ratio-limit.png: results/mass-ratio-limit.nc
figures/coupling.png: results/coupling.nc
figures/steering.png: results/steering.nc
figures/steering-calibration.png: results/steering-calibration.nc
figures/steering-plan.png: results/steering-plan.nc
figures/regime-map-two-way.png: results/regime-map-two-way.nc
figures/force-traces-two-way.png: results/regime-map-two-way.nc
figures/velocity-curves-two-way.png: results/velocity-curves-two-way.nc
figures/mass-ratio-limit-two-way.png: results/mass-ratio-limit-two-way.nc
figures/regime-map-flight.png: results/regime-map-flight.nc
figures/velocity-curves-flight.png: results/velocity-curves-flight.nc
figures/mass-ratio-limit-flight.png: results/mass-ratio-limit-flight.nc
figures/coupling-flight.png: results/coupling-flight.nc
figures/bouncing.png: results/mass-ratio-limit-flight.nc
figures/lyapunov.png: results/irregular-bouncing.nc
figures/fold-curves.png: results/mass-ratio-folds.nc
figures/branch-diagram.png: results/hysteresis-flight.nc
figures/bifurcation-along-%.png: results/bifurcation-along-%.nc $(PACKAGE) FORCE | $(STAMP)
	$(STUDY_FIGURE) figure bifurcation $< -o figures/bifurcation-along-$* --if-changed
figures/hysteresis-%.png: results/hysteresis-%.nc $(PACKAGE) FORCE | $(STAMP)
	$(STUDY_FIGURE) figure hysteresis $< -o figures/hysteresis-$* --if-changed
# Basins: figures/basins-X.png is figure basins of results/basins-X.nc (each motion
# followed over the map, study.analyses.basins.follow_attractors).
figures/basins-%.png: results/basins-%.nc $(PACKAGE) FORCE | $(STAMP)
	$(STUDY_FIGURE) figure basins $< -o figures/basins-$* --if-changed
# A figure's date says nothing of what it was drawn from (a figure of another file drawn
# to the same name is newer than its result): `study figure --if-changed` is asked every
# time and redraws unless the PNG records this result's checksum, these options and
# this figure code.
figures/%.png: $(PACKAGE) FORCE | $(STAMP)
	$(STUDY_FIGURE) figure $* $(filter results/%.nc,$^) -o figures/$* --if-changed
# The shorter stem wins: NAME-two-way.png is figure NAME.
figures/%-two-way.png: $(PACKAGE) FORCE | $(STAMP)
	$(STUDY_FIGURE) figure $* $(filter results/%.nc,$^) -o figures/$*-two-way --if-changed
figures/%-flight.png: $(PACKAGE) FORCE | $(STAMP)
	$(STUDY_FIGURE) figure $* $(filter results/%.nc,$^) -o figures/$*-flight --if-changed

FORCE:

# The documentation site (`make docs`, after `make`: 152 s before the figure batch, 91 s
# with it, load 2-2.7; of those, Sphinx: 4 s of start, the gallery 30-40 s, then reading
# and writing 10 s each). Its pictures (docs/images/) are the figures of a full run,
# copied in by `make docs`; `make docs-html` builds the pages from the pictures as they
# are (no results needed). Warnings are errors; the example gallery (docs/examples/)
# runs at every build. docs/images/ is tracked (the pages show their pictures on GitHub
# too): docs/copy_images.py copies a figure only when its pixels differ from the
# tracked picture's, so a figure that differs only in its metadata (version,
# fingerprint, date) leaves the clone clean.
# The figures the pages show: every images/NAME.png a page names that `make figures` draws
# (the benchmark figures are copied by `make bench`).
DOC_FIGURES := $(filter $(FIGURES),$(sort $(patsubst images/%.png,%,$(shell \
    grep -rhoE 'images/[a-z0-9-]+[.]png' README.md docs --include='*.md'))))

docs: figures
	$(PY) docs/copy_images.py $(addprefix figures/,$(addsuffix .png,$(DOC_FIGURES))) docs/images
	$(MAKE) docs-html

# Not with Sphinx's -j 2: without the gallery (-D plot_gallery=0) its reading and writing
# took 27-32 s in one process and 23-39 s with -j 2 on this shared 2-core machine, no
# clear gain, and the readers would be forked from the process the examples ran in
# (a dask cluster, numba's threads). sphinx-gallery runs examples side by side only
# with joblib, which the docs extra does not install.
docs-html: | $(STAMP)
	$(PY) -m sphinx -W --keep-going -b html docs build/html

list: $(STAMP)
	$(STUDY) list

lint: $(STAMP)
	$(PY) -m ruff check study tests benchmarks docs

# The default tier (`make test`): every folder (unit, integration, paper, hard_cases,
# property, golden: the result files of every release, tests/golden/), every module and
# capability with at least its headline checks; the heavier checks are marked slow
# (`make test-slow`), the fuzz tiers fuzz (`make fuzz`); CI runs all three (.ci/run),
# `make test-all` too. Each tier's time and its slowest tests: docs/developer/testing.md.
# The tests run in one process per core (pytest-xdist), at most 4 so that a shared
# machine is not taken over. Before the workers start, the controller compiles the
# kernels most tests use into numba's on-disk cache, one process per worker
# (tests/support/warm_kernels.py; a second run loads them in seconds); at the end each
# worker says what it still compiled (0 on a warm cache). The goal: `make test` within
# 6 minutes on a fresh clone of a 2-core machine, compile included.
# PYTEST_WORKERS=0 runs them in this process, in order. The 20 slowest tests are listed
# at the end: what to move to `make test-slow` when the tier grows past 6 minutes.
PYTEST_WORKERS ?= auto
XDIST := --numprocesses=$(PYTEST_WORKERS) --maxprocesses=4

test: $(STAMP) lint
	$(PY) -m pytest $(XDIST) -m "not slow and not fuzz" --durations=20

test-unit: $(STAMP)
	$(PY) -m pytest $(XDIST) tests/unit -m "not slow and not fuzz"

test-integration: $(STAMP)
	$(PY) -m pytest $(XDIST) tests/integration -m "not slow and not fuzz"

test-slow: $(STAMP)
	$(PY) -m pytest $(XDIST) -m "slow and not fuzz" --durations=20

# Everything: the default tier (with lint), the slow tier, the fuzz tiers.
test-all: test test-slow fuzz

# Seeded fuzz tiers (corrupted result files, damaged caches, mutated specs, measurement
# files, command lines): CI runs them. Each passed tier records what it tried; the
# table of counts (cases, faults injected, results lost) goes to results/reliability.md.
# One pytest run: tests/fuzz (every test marked fuzz, and only those: test_tiers.py)
# and every case of the API-input properties, in pytest-xdist workers a module at a
# time (--dist loadfile: a module's last test reads the counts of the ones before it
# in the same process; the workers' records merge under a lock), the longest modules
# first (tests/support/schedule.py; --no-loadscope-reorder keeps that order).
RELIABILITY_COUNTS := results/reliability-counts.json
fuzz: $(STAMP)
	mkdir -p results && rm -f $(RELIABILITY_COUNTS)
	STUDY_RELIABILITY_COUNTS=$(RELIABILITY_COUNTS) $(PY) -m pytest $(XDIST) --dist loadfile \
	    --no-loadscope-reorder tests/fuzz tests/property/test_api_inputs.py
	$(PY) -m tests.support.reliability $(RELIABILITY_COUNTS) > results/reliability.md
	cat results/reliability.md
	{ echo "*Written by \`make fuzz\` on $$(date -u +%Y-%m-%d) ($$(nproc) cores); the next run overwrites this file.*"; \
	  echo; cat results/reliability.md; } > docs/speed/reliability.md

# The benchmarks, in one list for `make bench` and `make bench-quick`: $(1) is
# `--quick` or nothing; $(2) the basins benchmark's options in quick mode.
define BENCHMARKS
	$(PY) benchmarks/bench_velocity_map.py $(1)
	NUMBA_NUM_THREADS=1 $(PY) benchmarks/floor_one_way.py $(1)
	$(PY) benchmarks/bench_study_overhead.py $(1)
	$(PY) benchmarks/bench_work_precision.py $(1)
	NUMBA_NUM_THREADS=1 $(PY) benchmarks/bench_work_precision.py --coupling two-way $(1)
	NUMBA_NUM_THREADS=1 $(PY) benchmarks/bench_two_way_map.py $(1)
	$(PY) benchmarks/bench_planar.py $(1)
	$(PY) benchmarks/two_way_agreement.py $(1)
	$(PY) benchmarks/bench_measurements.py $(1)
	NUMBA_NUM_THREADS=1 $(PY) benchmarks/bench_flight.py $(1)
	NUMBA_NUM_THREADS=1 $(PY) benchmarks/bench_orbit_sweeps.py $(1)
	NUMBA_NUM_THREADS=1 $(PY) benchmarks/bench_small_calls.py $(1)
	$(PY) benchmarks/bench_frontier_reuse.py $(1)
	NUMBA_NUM_THREADS=1 $(PY) benchmarks/bench_protocol.py $(1)
	NUMBA_NUM_THREADS=1 $(PY) benchmarks/bench_branches.py $(1)
	NUMBA_NUM_THREADS=1 $(PY) benchmarks/bench_basins.py $(2)
endef

bench: $(STAMP)
	$(call BENCHMARKS,,)
	mkdir -p docs/images && cp figures/work-precision.png figures/work-precision-two-way.png \
	    docs/images/

# A change's before and after in a minute or two (asv's quick mode): every benchmark
# with --quick (fewer rounds, smaller sizes); tables and reports go to
# results/bench-quick/, never docs/speed/ (the documentation's numbers are those of a
# full `make bench`). Compare two checkouts' results/bench-quick/ (same machine, same
# load), not a quick table with a full one.
bench-quick: $(STAMP)
	$(call BENCHMARKS,--quick,--size 15 --repeats 1 --no-docs \
	    --output results/bench-quick/bench-basins.md)
	@echo "quick tables and reports: results/bench-quick/"

# A refactor keeps results bit-identical: `make compare BEFORE=other/results` checks
# every file of that folder against results/, variable by variable.
compare: $(RESULTS)
	@test -n "$(BEFORE)" || { echo "make compare BEFORE=FOLDER: the folder of the results to compare with" >&2; exit 2; }
	$(PY) -m tests.support.compare_results $(BEFORE) results

cf-check: $(RESULTS)
	$(VENV)/bin/compliance-checker --test cf:1.11 --criteria strict $(RESULTS)

clean:
	rm -rf $(VENV) results figures build .pytest_cache .ruff_cache .hypothesis
