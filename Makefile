# Two commands for a fresh machine with Python 3.11 and make:
#   make run   — set up .venv and run the default workflow
#   make test  — set up .venv and run the tests, the linter, dry runs and the small profile
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
CORES ?= 2

.PHONY: setup run own-data paper test test-slow bench validate clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $(STAMP)

setup: $(STAMP)

run: setup
	$(BIN)/snakemake --cores $(CORES) --rerun-incomplete --configfile config/config.yaml

# Your recording only (ingest → … → identification → diagnosis): make own-data OWN=config/my_line.yaml
OWN ?= config/own_data.yaml
own-data: setup
	$(BIN)/snakemake --cores $(CORES) --rerun-incomplete --configfile $(OWN) -- measurements

# The paper-reproduction simulations only (dropper table, Figs 2–4 and 6, dynamics)
paper: setup
	$(BIN)/snakemake --cores $(CORES) --rerun-incomplete --configfile config/config.yaml -- paper

# The small profile runs before pytest: the `pipeline` tests check its results against its truth.
# pytest runs last so that its summary is the closing line.
test: setup
	$(BIN)/snakemake --lint
	$(BIN)/snakemake --dry-run --quiet --configfile config/config.yaml
	$(BIN)/snakemake --dry-run --quiet --configfile config/test.yaml
	$(BIN)/snakemake --cores $(CORES) --configfile config/test.yaml
	$(BIN)/python -m pytest -m 'not slow and not validation'

# Calibration of the standard errors and convergence of the dynamic model (CI runs it after make test).
test-slow: setup
	$(BIN)/python -m pytest -m slow

bench: setup
	$(BIN)/python benchmarks/run.py

# Campaigns of known truth through the whole pipeline (config/validation/): the identification's
# validation table, the model-form differences and every hidden-effect campaign's diagnosis
# (results/validation/diagnosis.csv); ≈ 2 h on 2 cores. See benchmarks/validate.py.
validate: setup
	$(BIN)/python benchmarks/validate.py --cores $(CORES)
	$(BIN)/python -m pytest -m validation

clean:
	rm -rf results .snakemake
