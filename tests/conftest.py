"""Shared test setup: keep Warp's compiled kernels in the checkout's cache (as `make test` does)."""
import os
import sys
from pathlib import Path

import pytest

# The shared test utilities (scene pieces, statistics procedure, fakes, data) live in tests/support/;
# test modules in every subfolder import them by name.
sys.path.insert(0, str(Path(__file__).resolve().parent / "support"))

# Set before anything imports Warp, so a plain `pytest` run reuses (and fills) the same kernel cache.
os.environ.setdefault("WARP_CACHE_PATH", str(Path(__file__).resolve().parent.parent / ".warp-cache"))


def pytest_sessionfinish(session, exitstatus):
    """For .ci/run: pytest's exit status and the number of tests run, which `make` would hide.
    Written by the controlling process only: pytest-xdist's workers (`workerinput`) finish first,
    each with a share of the tests."""
    path = os.environ.get("DRTLAB_PYTEST_STATUS")
    if path and not hasattr(session.config, "workerinput"):
        with open(path, "w") as f:
            f.write(f"{int(exitstatus)} {session.testscollected}\n")


def pytest_addoption(parser):
    parser.addoption("--drtlab-plugin", action="append", default=[], metavar="FILE_OR_MODULE",
                     help="load a drtlab plugin before collection: every test parametrized over the "
                          "registered point sets then runs on its sets too")


def pytest_configure(config):
    specs = config.getoption("--drtlab-plugin", default=[])
    if specs:
        from drtlab.estimators.plugins import load_plugins
        load_plugins(specs, "--drtlab-plugin", Path.cwd())


@pytest.fixture
def clean_registry():
    """The point sets, light selections, lobe samplers, strategies, integrators, metrics and loaded plugins as they were before the test:
    a test that registers a plugin leaves no trace for the tests after it (in its worker)."""
    from drtlab.estimators import plugins
    from drtlab.estimators.integrators import INTEGRATORS
    from drtlab.estimators.registry import POINTSETS
    from drtlab.estimators.strategies import STRATEGIES
    from drtlab.experiments.error_metrics import METRICS
    from drtlab.kernels.light_selection import LIGHT_SELECTIONS
    from drtlab.kernels.lobe_samplers import LOBE_SAMPLERS
    names, loaded, was = list(POINTSETS._names), dict(POINTSETS._loaded), dict(plugins._loaded)
    sels, strats, metrics, lobes = dict(LIGHT_SELECTIONS), dict(STRATEGIES), dict(METRICS), dict(LOBE_SAMPLERS)
    integrators = dict(INTEGRATORS)
    yield
    POINTSETS._names[:], POINTSETS._loaded = names, loaded
    plugins._loaded.clear()
    plugins._loaded.update(was)
    for registry, before in ((LIGHT_SELECTIONS, sels), (STRATEGIES, strats), (METRICS, metrics),
                             (LOBE_SAMPLERS, lobes), (INTEGRATORS, integrators)):
        registry.clear()
        registry.update(before)
