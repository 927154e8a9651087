"""A user's point sets and strategies checked and added to the registries (drtlab/registration.py
calls these): a free, well-formed name (not a built-in's), a point set's Warp signature and its
values in [0, 1) drawn through a real kernel; and the fingerprint a run's key mixes in. Apart from
estimators/plugins.py (the loader), so that the registry may load entry points without importing
what imports it."""
from __future__ import annotations

import hashlib
from dataclasses import replace

from drtlab.errors import InputError
from drtlab.estimators.plugins import (NAME, check_warp_function, fingerprint, last_words, note,
                                       user_frame, who_registers)

CHECK_POINTS, CHECK_DIMS = 64, 12              # values drawn per (seed, pixel) at registration


def reserved(name: str) -> str | None:
    from drtlab.estimators import registry
    if name in registry.POINTSET_MODULES:
        return "a built-in point set"
    if name in registry.PRESETS:
        return "a built-in preset"
    if name in registry.BUILT_IN_STRATEGIES:
        return "a built-in strategy"
    if name in registry.BUILT_IN_INTEGRATORS:
        return "a built-in integrator"
    return None



def check_signature(ps, who: str) -> None:
    import warp as wp
    for attr, ret in (("get1d", float), ("get2d", wp.vec2)):
        check_warp_function(getattr(ps, attr), attr, (wp.uint32,) * 5, ret, who,
                            "(seed, pixel, index, dim, spp), each wp.uint32")



def check_values(ps, who: str) -> None:
    """Draw CHECK_POINTS x CHECK_DIMS values at two seeds and pixels through a real kernel: the set
    must compile and give finite values in [0, 1)."""
    import numpy as np

    from drtlab.estimators.points import points
    files = {getattr(getattr(ps, a), "func").__code__.co_filename for a in ("get1d", "get2d")}
    for seed, pixel in ((0, 0), (7, 12345)):
        try:
            u = points(ps, CHECK_POINTS, CHECK_DIMS, seed=seed, pixel=pixel)
        except InputError:
            raise
        except Exception as e:                                    # noqa: BLE001 (user code)
            where = user_frame(e, files)
            raise InputError(who, f"point set '{ps.name}' does not compile"
                                  f"{' at ' + where if where else ''}: {last_words(e)}") from None
        bad = ~(np.isfinite(u) & (u >= 0.0) & (u < 1.0))
        if bad.any():
            i, d = (int(v) for v in np.argwhere(bad)[0])
            raise InputError(who, f"point set '{ps.name}' gives {float(u[i, d])!r} at sample {i}, dimension "
                                  f"{d} (seed {seed}, pixel {pixel}); values must lie in [0, 1)")



def checked_name(obj, cls, kind: str, words: str) -> str:
    """`obj` is a `cls` with a free, well-formed name; returns what its errors name."""
    who = who_registers(kind)
    if not isinstance(obj, cls):
        raise InputError(who, f"register_{kind} takes a drtlab {cls.__name__}, got {type(obj).__name__}")
    if not isinstance(obj.name, str) or not NAME.match(obj.name):
        raise InputError(who, f"a {words}'s name is lower-case letters, digits, - and _ (at most 40, "
                              f"starting with a letter), got {obj.name!r}")
    clash = reserved(obj.name)
    if clash:
        raise InputError(who, f"'{obj.name}' is {clash}; give your {words} another name")
    return who



def add_strategy(strategy):
    """Add a Strategy under its name (drtlab.register_strategy composes it), its fingerprint
    mixed with the importing plugin's source."""
    from drtlab.estimators.strategies import STRATEGIES, Strategy
    checked_name(strategy, Strategy, "strategy", "strategy")
    strategy = replace(strategy, fingerprint=fingerprint(strategy.fingerprint))
    STRATEGIES[strategy.name] = strategy
    note("strategy", strategy.name)
    return strategy


def add_pointset(ps, check: bool = True):
    """Add a PointSet under its name (drtlab.register_pointset): checked (signature; with `check`,
    compiled and drawn once), fingerprinted."""
    from drtlab.estimators.pointsets.base import PointSet
    from drtlab.estimators.registry import POINTSETS
    who = checked_name(ps, PointSet, "pointset", "point set")
    check_signature(ps, who)
    ps = replace(ps, fingerprint=fingerprint(ps.fingerprint, ps.get1d, ps.get2d, ps.pixel_key,
                                             ps.count_word))
    if check:
        check_values(ps, who)
    POINTSETS[ps.name] = ps
    note("pointset", ps.name)
    return ps



def sampler_fingerprint(sampler: str, integrator: str | None = None) -> str:
    """The fingerprint of a sampler's point set and strategy, and of `integrator` when given (""
    for the built-ins): what a run's key mixes in, so an edited plugin re-renders its cells."""
    from drtlab.estimators.integrators import integrator_fingerprint
    from drtlab.estimators.registry import parse_sampler
    spec = parse_sampler(sampler)
    both = [f for f in (spec.pointset.fingerprint, spec.strategy.fingerprint,
                        integrator_fingerprint(integrator)) if f]
    return "" if not both else both[0] if len(both) == 1 else hashlib.sha256(":".join(both).encode()).hexdigest()[:16]
