"""The plugin tests register sets, selections and strategies: each test gets the registries back as
they were, so no other test sees them."""
import pytest


@pytest.fixture
def clean_registry():
    from drtlab.estimators import plugins
    from drtlab.estimators.registry import POINTSETS
    from drtlab.estimators.strategies import STRATEGIES
    from drtlab.kernels.light_selection import LIGHT_SELECTIONS
    names, loaded, was = list(POINTSETS._names), dict(POINTSETS._loaded), dict(plugins._loaded)
    sels, strats = dict(LIGHT_SELECTIONS), dict(STRATEGIES)
    yield
    POINTSETS._names[:], POINTSETS._loaded = names, loaded
    plugins._loaded.clear()
    plugins._loaded.update(was)
    for registry, before in ((LIGHT_SELECTIONS, sels), (STRATEGIES, strats)):
        registry.clear()
        registry.update(before)
