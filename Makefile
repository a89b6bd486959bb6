# hertzsweep: run `make help` for the targets.
# The Python that builds .venv: PYTHON=... when given, else the first of these that runs
# and is 3.11 or newer.
PYTHON_CANDIDATES := python3.11 python3.12 python3.13 python3
PYTHON_CHECK := -c 'import sys; sys.exit(sys.version_info < (3, 11))'
ifeq ($(origin PYTHON),undefined)
PYTHON := $(shell for p in $(PYTHON_CANDIDATES); do \
	$$p $(PYTHON_CHECK) >/dev/null 2>&1 && { echo $$p; break; }; done)
endif
NO_PYTHON := no Python 3.11 or newer among $(PYTHON_CANDIDATES); give one: make PYTHON=...
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
SMOKE_SCENE     := configs/smoke.toml
SMOKE_REFERENCE := tests/data/smoke-reference.nc

.DEFAULT_GOAL := help
.PHONY: help install demo test smoke smoke-update lint docs bench fig15 paper clean

help:  ## list the targets
	@grep -E '^[a-z0-9-]+:.*## ' $(MAKEFILE_LIST) | awk -F':.*## ' '{printf "  %-13s %s\n", $$1, $$2}'

$(STAMP): pyproject.toml
	@test -n "$(PYTHON)" || { echo "make: $(NO_PYTHON)" >&2; exit 1; }
	@$(PYTHON) $(PYTHON_CHECK) || { echo "make: $(PYTHON) is not Python 3.11 or newer" >&2; exit 1; }
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[test,docs]'
	$(BIN)/python -m hertzsweep.drivers.warm
	touch $(STAMP)

install: $(STAMP)  ## create .venv and install hertzsweep with the test and docs extras

demo: $(STAMP)  ## run the default scene: results/demo.nc and a table on stdout
	@mkdir -p results
	$(BIN)/hertzsweep sweep configs/default.toml -o results/demo.nc

test: $(STAMP)  ## run the whole test suite (slow tests included)
	$(BIN)/python -m pytest -q

smoke: $(STAMP)  ## a reduced default scene compared with its reference (exit 1 if it differs)
	@mkdir -p results
	$(BIN)/hertzsweep sweep $(SMOKE_SCENE) -o results/smoke.nc --quiet
	$(BIN)/hertzsweep compare results/smoke.nc $(SMOKE_REFERENCE)

smoke-update: $(STAMP)  ## rewrite the smoke reference (only for an intended change of the numbers)
	$(BIN)/hertzsweep sweep $(SMOKE_SCENE) -o $(SMOKE_REFERENCE) --quiet

lint: $(STAMP)  ## ruff check and format check
	$(BIN)/ruff check src tests docs/hooks
	$(BIN)/ruff format --check src tests docs/hooks

# NO_MKDOCS_2_WARNING: silences mkdocs-material's banner about its own end of life (not a
# warning about the manual: any of those fails the build, --strict)
docs: $(STAMP)  ## build the manual into site/ (offline, --strict)
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict --site-dir site

bench: $(STAMP)  ## the project's speed figures
	$(BIN)/hertzsweep bench

fig15: $(STAMP)  ## the paper's Figure 15 study: results/fig15.nc and results/fig15.png
	@mkdir -p results
	$(BIN)/hertzsweep study configs/studies/fig15.toml -o results/fig15.nc
	$(BIN)/hertzsweep plot results/fig15.nc -o results/fig15.png

paper: $(STAMP)  ## the paper's figures and validation table in results/paper/
	$(BIN)/hertzsweep paper configs/paper results/paper

clean:  ## remove results, the built manual and caches (keeps .venv)
	rm -rf results site .pytest_cache build src/*.egg-info
