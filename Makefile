# drtlab: every target bootstraps .venv itself (Python 3.11+, no venv needed beforehand).
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
RUNTIME := $(VENV)/.installed-runtime
DRT    := $(VENV)/bin/drtlab
# Kernel cache inside the checkout's ignored results folder keeps compiles warm across runs.
export WARP_CACHE_PATH ?= $(CURDIR)/.warp-cache

.PHONY: venv test test-full bench experiment-stratified experiment-importance experiment-uniform \
        experiment-all experiment-integrands experiment-pointsets experiment-presampled experiment-environment experiment-filters experiment-microfacet experiment-lights ground-truth clean bench-compare crosscheck crosscheck-suite

venv: $(STAMP)

# Experiments need the package alone; the test tools (pytest, nbclient, a Jupyter kernel) come with
# `make test`: a fresh clone's `make experiment-stratified` then installs half as much.
# uv (from PyPI) installs the same packages as pip in a fifth of the time (16 s against 75 s on a
# 2-core box): a fresh clone's first command spends its time on the study, not on pip. Where uv
# cannot be installed, pip does the same install.
# Bytecode is compiled at install (site-packages by uv, drtlab's own folders by compileall): where
# Python may not write it (PYTHONDONTWRITEBYTECODE, read-only installs) every `drtlab` command would
# otherwise compile ~190 modules from source, 0.3 s of a 0.5 s start.
INSTALL = $(PY) -m pip install -q uv >/dev/null 2>&1 && $(PY) -m uv pip install -q --compile-bytecode --python $(PY)
# Targets refresh drtlab's bytecode first (0.1 s when nothing changed): an edited module is not
# compiled again on every start.
BYTECODE = $(PY) -m compileall -q -j 0 drtlab kernels estimators experiments >/dev/null

$(RUNTIME): pyproject.toml
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(INSTALL) -e . || $(PY) -m pip install -q -e .
	@$(BYTECODE)
	@touch $(RUNTIME)

$(STAMP): $(RUNTIME)
	$(INSTALL) -e '.[dev]' || $(PY) -m pip install -q -e '.[dev]'
	@touch $(STAMP)

# Tests run on every core (pytest-xdist): most of a cold run is kernel compiles, one core each.
TEST_WORKERS ?= auto

test: venv
	@$(BYTECODE)
	$(PY) -m pytest -q -n $(TEST_WORKERS) --dist worksteal

test-full: venv
	@$(BYTECODE)
	DRTLAB_TEST_TIER=full $(PY) -m pytest -q -n $(TEST_WORKERS)

bench: venv
	@$(BYTECODE)
	$(PY) -m drtlab.experiments.bench

# The built-in studies (experiments/studies/NAME.toml), one target each.
STUDIES := stratified importance uniform presampled environment filters microfacet lights all
$(addprefix experiment-,$(STUDIES)): experiment-%: $(RUNTIME)
	@$(BYTECODE)
	$(DRT) experiment $*

experiment-integrands: $(RUNTIME)
	$(PY) -m drtlab.experiments.integrands

experiment-pointsets: $(RUNTIME)
	$(DRT) experiment pointsets

ground-truth: $(RUNTIME)
	$(DRT) ground-truth --experiment stratified

clean:
	rm -rf $(VENV) .warp-cache

# The [compare] extra (mitsuba==3.9.1) for the targets that run Mitsuba 3 beside drtlab; a failed
# install is said once and the run then skips (exit 0).
COMPARE_EXTRA = $(INSTALL) -e '.[compare]' || $(PY) -m pip install -q -e '.[compare]' || echo "$@: pip could not install the [compare] extra (mitsuba==3.9.1); the comparison will skip"
# Mitsuba's llvm_ad_rgb needs LLVM 19 (LLVM 14 crashes it): the script prints its libLLVM-19.so,
# apt-get installing Debian's libllvm19 when missing and we are root, or says why not.
LLVM19 = DRJIT_LIBLLVM_PATH="$$(sh experiments/bench/mitsuba/llvm19.sh $@)"

# drtlab vs Mitsuba 3 on mi.cornell_box() -> results/bench/compare.json and a Markdown table. Without
# Mitsuba or LLVM 19 the run says why and skips (exit 0).
# Flags: make bench-compare BENCH_COMPARE_ARGS='--res 64 --spp 64'.
bench-compare: venv
	@$(COMPARE_EXTRA)
	@$(LLVM19) $(PY) -m drtlab.experiments.bench.mitsuba $(BENCH_COMPARE_ARGS)

# drtlab vs Mitsuba 3 on every scene both read: the exportable built-ins (exported to XML) and
# tests/data/mitsuba/*.xml, several seeds each -> results/crosscheck/ (JSON, Markdown table). Skips
# (exit 0) without Mitsuba or LLVM 19. Flags: make crosscheck CROSSCHECK_ARGS='--seeds 4'.
crosscheck: venv
	@$(COMPARE_EXTRA)
	@$(LLVM19) $(PY) -m drtlab.experiments.bench.mitsuba.crosscheck $(CROSSCHECK_ARGS)

# drtlab against Mitsuba 3's own render-test scenes (../shared/mitsuba-tests, or $DRTLAB_MITSUBA_TESTS):
# which load, and whether each agrees with Mitsuba's reference image -> results/mitsuba-suite/ (JSON,
# Markdown table). No Mitsuba needed. Skips (exit 0) without the suite. Flags:
# make crosscheck-suite SUITE_ARGS='--spp 64 --docs docs/mitsuba-suite.md'.
crosscheck-suite: $(RUNTIME)
	@$(BYTECODE)
	$(PY) -m drtlab.experiments.bench.mitsuba.suite $(SUITE_ARGS)
