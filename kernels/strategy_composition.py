"""A strategy composed of registered routines (drtlab.register_strategy's and the checks'): a
registered strategy `like` with another light selection, MIS heuristic and/or lobe samplers, checked
against what is registered. In kernels/ because the routines it names are Warp code registered here
(light_selection.py, lobe_samplers.py); estimators/plugin_checks.add_strategy then registers it."""
from dataclasses import replace

from drtlab.errors import InputError
from drtlab.estimators import strategies
from drtlab.estimators.strategies import Strategy
from drtlab.kernels.light_selection import LIGHT_SELECTIONS
from drtlab.kernels.lobe_samplers import composed


def compose_strategy(name: str, description: str, like: str = "importance", *,
                     light_selection: str | None = None, heuristic: str | None = None,
                     lobe_samplers=None) -> Strategy:
    """The Strategy `like` with the routines given replaced, named `name` (not yet registered)."""
    # Read at call time: what is registered then (a test may add a heuristic).
    STRATEGIES, MIS_HEURISTICS = strategies.STRATEGIES, strategies.MIS_HEURISTICS
    if like not in STRATEGIES:
        raise InputError("like", f"must be a registered strategy ({', '.join(STRATEGIES)}), got {like!r}")
    base = STRATEGIES[like]
    if (light_selection is not None or heuristic is not None) and base.light is None:
        raise InputError("like", f"must be a strategy that samples lights to change its light selection or "
                                 f"heuristic ({', '.join(k for k, v in STRATEGIES.items() if v.light)}), "
                                 f"got {like!r}")
    light, fingerprint, lobes = base.light, base.fingerprint, base.lobes
    if light_selection is not None:
        if light_selection not in LIGHT_SELECTIONS:
            raise InputError("light_selection", f"unknown light selection {light_selection!r}; "
                                                f"registered: {', '.join(LIGHT_SELECTIONS)}")
        light = replace(light, pick=light_selection)
        fingerprint = LIGHT_SELECTIONS[light_selection].fingerprint
    if heuristic is not None:
        if heuristic not in MIS_HEURISTICS or not light.mis:
            raise InputError("heuristic", f"must be one of {', '.join(MIS_HEURISTICS)} for a strategy that "
                                          f"combines by MIS, got {heuristic!r} (like={like!r})")
        light = replace(light, heuristic=heuristic)
    if lobe_samplers is not None:
        if not base.lobe:
            raise InputError("like", f"must sample BSDF lobes to compose lobe samplers "
                                     f"({', '.join(k for k, v in STRATEGIES.items() if v.lobe)}), got {like!r}")
        lobes, lobe_fp = composed(lobe_samplers)
        fingerprint = f"{fingerprint}:{lobe_fp}"
    return replace(base, name=name, description=description, light=light, lobes=lobes,
                   fingerprint=fingerprint)


