# drtlab: every target bootstraps .venv itself (Python 3.11+, no venv needed beforehand).
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
DRT    := $(VENV)/bin/drtlab
# Kernel cache inside the checkout's ignored results folder keeps compiles warm across runs.
export WARP_CACHE_PATH ?= $(CURDIR)/.warp-cache

.PHONY: venv test test-full bench experiment-stratified experiment-importance experiment-uniform \
        experiment-all ground-truth clean

venv: $(STAMP)

$(STAMP): pyproject.toml
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q -e '.[dev]'
	@touch $(STAMP)

test: venv
	$(PY) -m pytest -q

test-full: venv
	DRTLAB_TEST_TIER=full $(PY) -m pytest -q

bench: venv
	$(PY) -m drtlab.experiments.bench

experiment-stratified: venv
	$(DRT) experiment stratified

experiment-importance: venv
	$(DRT) experiment importance

experiment-uniform: venv
	$(DRT) experiment uniform

experiment-all: venv
	$(DRT) experiment all

ground-truth: venv
	$(DRT) ground-truth --experiment stratified

clean:
	rm -rf $(VENV) .warp-cache
