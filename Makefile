# Two commands for a fresh machine with Python 3.11 and make:
#   make run   — set up .venv and run the default workflow
#   make test  — set up .venv and run the linter, dry runs and the tests (the shipped example end to end)
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
CORES ?= 2
SMK := $(BIN)/snakemake --workflow-profile workflow/profiles/default

.PHONY: setup cluster-setup run own-data paper unlock default-data test test-pipeline test-slow test-cluster docs \
	bench bench-line bench-line-cores validate clean

# Packages go in through uv, pinned, where it installs: it fetches and links wheels in parallel
# (the venv's packages in 2.4 s, against pip's 36 s: measured 2026-11-26/27). They are then
# byte-compiled as pip does, or where PYTHONDONTWRITEBYTECODE is set every job compiles every module
# it imports (make run 609 s by uv without compiling, against 551 s with it): by compileall on every
# core, leaving out the packages' own test suites, which no job imports (7.4 s, against 10.9 s for
# uv's --compile-bytecode, which compiles them too; a file it cannot compile only costs the job that
# imports it the time to compile it). Where uv cannot install (no uv wheel for the
# platform, no registry for it), pip, which compiles as it installs.
UV_VERSION := 0.13.9
COMMA := ,
SITE_PACKAGES = "$$($(BIN)/python -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')"
define install
	( $(BIN)/python -m pip install --quiet --disable-pip-version-check uv==$(UV_VERSION) 2>/dev/null \
	  && $(BIN)/uv pip install --quiet --python $(BIN)/python $(1) \
	  && ( $(BIN)/python -m compileall -q -j 0 -x '/tests?/' $(SITE_PACKAGES) > /dev/null || true ) ) \
	|| ( echo "uv could not install; pip instead" && $(BIN)/python -m pip install --quiet --upgrade pip \
	  && $(BIN)/python -m pip install --quiet $(1) )
endef

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(call install,-e '.[test]')
	touch $(STAMP)

setup: $(STAMP)

# Ends with the HTML report (every figure and table, with captions): results/report.html.
run: setup
	$(SMK) --cores $(CORES) --configfile config/config.yaml --report results/report.html --report-after-run

# Rewrite data/default_campaign, the default campaign that make run copies instead of simulating
# while it was written from these very config/campaign.yaml, catenary.yaml and pantographs.yaml
# (catenary.measurement.shipped): after changing one of them or the code that moves the campaign.
default-data: setup
	$(SMK) --cores $(CORES) --configfile config/config.yaml --config campaign_copy= results=results/default_data \
	  -- results/default_data/campaign/recording.parquet
	$(BIN)/python -m catenary.measurement.shipped results/default_data/campaign data/default_campaign \
	  config/campaign.yaml config/catenary.yaml config/pantographs.yaml

# Your recording only (ingest → … → identification → diagnosis): make own-data OWN=config/my_line.yaml
OWN ?= config/own_data.yaml
own-data: setup
	$(SMK) --cores $(CORES) --configfile $(OWN) --report-after-run --report \
	  "$$($(BIN)/python -c 'import sys, yaml; print(yaml.safe_load(open(sys.argv[1])).get("results", "results"))' $(OWN))/report.html" \
	  -- measurements

# The paper-reproduction simulations only (dropper table, Figs 2–4 and 6, dynamics)
paper: setup
	$(SMK) --cores $(CORES) --configfile config/config.yaml -- paper

# After a run killed hard (closed terminal, power loss): lift Snakemake's lock on the folder.
unlock: setup
	$(SMK) --unlock --configfile config/config.yaml

# The linter, dry runs of both configs, then pytest on $(CORES) processes (pytest-xdist; "worksteal":
# an idle process takes tests queued for a busy one), among them the shipped example through the
# rules from ingest to diagnosis and its report (tests/test_own_data.py). pytest runs last so that
# its summary is the closing line.
test: setup
	$(SMK) --lint
	$(SMK) --dry-run --quiet --configfile config/config.yaml
	$(SMK) --dry-run --quiet --configfile config/test.yaml
	$(BIN)/python -m pytest -n $(CORES) --dist worksteal -m 'not slow and not validation and not pipeline' --durations=10

# The whole workflow on the small profile (config/test.yaml: campaign → … → contact force,
# maintenance and the report, into results/ci), then the `pipeline` tests that check it against
# its own truth and open its report in a headless browser. CI runs it after make test.
test-pipeline: setup
	$(SMK) --cores $(CORES) --configfile config/test.yaml --report results/ci/report.html --report-after-run
	bash tests/install_browser.sh
	$(BIN)/python -m pytest -n $(CORES) --dist worksteal -m pipeline --durations=5

# Calibration of the standard errors and convergence of the dynamic model (CI runs it after make test).
test-slow: setup
	$(BIN)/python -m pytest -m slow

# The small profile's measurement pipeline through a one-node SLURM cluster on this machine (root:
# installs Debian's Slurm, starts its daemons, stops them on exit); compared with the local run.
test-cluster: cluster-setup
	bash tests/cluster/run.sh

# The SLURM executor plugins in .venv (once: CI installs them before test-cluster and test-slow
# run side by side, so that no install rewrites the venv under a running test).
CLUSTER_STAMP := $(VENV)/.cluster-installed
$(CLUSTER_STAMP): $(STAMP)
	$(call install,-e '.[test$(COMMA)cluster]')
	touch $(CLUSTER_STAMP)

cluster-setup: $(CLUSTER_STAMP)

# The documentation site from docs/ (API reference from the docstrings) into site/, strict: a broken
# link, a page missing from the navigation or a docstring the reference cannot read fails it.
docs: setup
	$(call install,-e '.[docs]')
	$(BIN)/mkdocs build --strict

bench: setup
	$(BIN)/python benchmarks/run.py

# A line of $(SPANS) spans (N2 and N3 sections of 20, config/line/'s laws) from the recording to the
# report on $(CORES) cores, in results/line_$(SPANS)/, the campaign's simulation timed apart: wall
# time per stage and peak memory per job into results/benchmarks.json (benchmarks/line.py).
SPANS ?= 1000
bench-line: setup
	$(BIN)/python benchmarks/line.py --spans $(SPANS) --cores $(CORES)

# After bench-line: the per-type jobs of that line (identify, diagnose, maintenance) again on
# 1 core and on 2, their wall times, speed-ups and whether the answers are the same
# (benchmarks/line_cores.py, into results/benchmarks.json).
TYPE ?= N2
REPEAT ?= 1
bench-line-cores: setup
	$(BIN)/python benchmarks/line_cores.py --spans $(SPANS) --span-type $(TYPE) --repeat $(REPEAT)

# Campaigns of known truth through the whole pipeline (config/validation/): the identification's
# validation table, the model-form differences and every hidden-effect campaign's diagnosis
# (results/validation/diagnosis.csv), then the replicate tests (pytest -m validation); its wall time
# goes to results/benchmarks.json (validate_wall_time_s). See benchmarks/validate.py.
validate: setup
	$(BIN)/python benchmarks/validate.py --cores $(CORES)

clean:
	rm -rf results .snakemake site
