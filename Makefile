# hertzsweep: run `make help` for the targets.
PYTHON ?= python3.11
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.DEFAULT_GOAL := help
.PHONY: help install demo test lint bench fig15 paper clean

help:  ## list the targets
	@grep -E '^[a-z0-9]+:.*## ' $(MAKEFILE_LIST) | awk -F':.*## ' '{printf "  %-8s %s\n", $$1, $$2}'

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[test]'
	touch $(STAMP)

install: $(STAMP)  ## create .venv and install hertzsweep with the test extras

demo: $(STAMP)  ## run the default scene: results/demo.nc and a table on stdout
	@mkdir -p results
	$(BIN)/hertzsweep sweep configs/default.toml -o results/demo.nc

test: $(STAMP)  ## run the whole test suite (slow tests included)
	$(BIN)/python -m pytest -q

lint: $(STAMP)  ## ruff check and format check
	$(BIN)/ruff check src tests
	$(BIN)/ruff format --check src tests

bench: $(STAMP)  ## the project's speed figures
	$(BIN)/hertzsweep bench

fig15: $(STAMP)  ## the paper's Figure 15 study: results/fig15.nc and results/fig15.png
	@mkdir -p results
	$(BIN)/hertzsweep study configs/studies/fig15.toml -o results/fig15.nc
	$(BIN)/hertzsweep plot results/fig15.nc -o results/fig15.png

paper: $(STAMP)  ## the paper's figures and validation table in results/paper/
	$(BIN)/python -m hertzsweep.output.paper configs/paper results/paper

clean:  ## remove results and caches (keeps .venv)
	rm -rf results .pytest_cache build src/*.egg-info
