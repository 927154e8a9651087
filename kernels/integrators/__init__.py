"""The integrators, one module per method, each written against the estimator API (`api.py`) alone:
`whitted.py`, `drt.py`, `path.py`, `direct.py` (Mitsuba 3's direct illumination). A module defines
`DIMENSIONS` (its own named sample decisions: ((name, size), ...), estimators/dimensions.own_layout)
and `make(api) -> trace`, `trace(sd, seed, pix, idx, spp, o, d, dt) -> wp.vec3` a Warp function.
A plugin's integrator (drtlab.register_integrator) is the same two things, found through
estimators/integrators.INTEGRATORS.
"""
import importlib

from drtlab.estimators.integrators import INTEGRATORS


def integrator_factory(name: str) -> tuple:
    """(make, DIMENSIONS) of the integrator called `name` (a built-in's module, or a plugin's)."""
    entry = INTEGRATORS[name]
    if entry.make is not None:
        return entry.make, entry.dimensions
    module = importlib.import_module(entry.module)
    return module.make, module.DIMENSIONS
