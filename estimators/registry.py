"""Registry of point sets, strategies and presets; `parse_sampler` accepts a preset, POINTS+STRATEGY
or a point set's name alone.

Adding a point set: one file in `pointsets/` defining POINTSET, and one entry in `_POINTSET_MODULES`.
"""
from dataclasses import dataclass

from drtlab.estimators.defaults import DEFAULT_SAMPLER, POINTSET_STRATEGY  # noqa: F401 (re-exported)
from drtlab.estimators.integrators import INTEGRATORS, Integrator
from drtlab.estimators.pointsets import (cmj, halton, independent, lhs, pmj02, presampled,
                                         presampled_random, sobol, stratified, zsobol)
from drtlab.estimators.pointsets.base import PointSet
from drtlab.estimators.strategies import STRATEGIES, Strategy
from drtlab.errors import InputError

_POINTSET_MODULES = (independent, stratified, lhs, cmj, halton, sobol, zsobol, pmj02, presampled,
                     presampled_random)
POINTSETS: dict[str, PointSet] = {m.POINTSET.name: m.POINTSET for m in _POINTSET_MODULES}


# Sets that differ from another only in the bounce directions (PointSet.same_as_outside_directions:
# Cook's tables): studies of the pixel dimensions alone (the integrand testbed) skip them.
DIRECTION_ONLY_POINTSETS = tuple(n for n, ps in POINTSETS.items() if ps.same_as_outside_directions)


def biased_pointsets() -> list[str]:
    """Names of the point sets biased by design (PointSet.biased), in registry order."""
    return [name for name, ps in POINTSETS.items() if ps.biased]


def unbiased_pointsets() -> list[str]:
    """Names of the point sets usable where unbiasedness / uniformity is required."""
    return [name for name, ps in POINTSETS.items() if not ps.biased]

# preset name -> (point set, strategy)
PRESETS: dict[str, tuple[str, str]] = {
    "uniform": ("independent", "uniform"),
    "stratified": ("stratified", "uniform"),
    "importance": ("independent", "importance"),
}


@dataclass(frozen=True)
class SamplerSpec:
    pointset: PointSet
    strategy: Strategy

    @property
    def name(self) -> str:
        """Canonical name: the preset name when one matches, else POINTS+STRATEGY."""
        for preset, pair in PRESETS.items():
            if pair == (self.pointset.name, self.strategy.name):
                return preset
        return f"{self.pointset.name}+{self.strategy.name}"


def _allowed() -> str:
    return (f"a preset ({', '.join(PRESETS)}), POINTS+STRATEGY with POINTS in "
            f"{{{', '.join(POINTSETS)}}} and STRATEGY in {{{', '.join(STRATEGIES)}}}, or POINTS "
            f"alone (= POINTS+{POINTSET_STRATEGY})")


def parse_sampler(name: str, field: str = "sampler") -> SamplerSpec:
    """A preset, POINTS+STRATEGY, or a point set's name alone (POINTS+POINTSET_STRATEGY)."""
    if not isinstance(name, str):
        raise InputError(field, f"must be a string: {_allowed()}, got {name!r}")
    if name in PRESETS:
        points, strategy = PRESETS[name]
    elif name in POINTSETS:
        points, strategy = name, POINTSET_STRATEGY
    elif name.count("+") == 1:
        points, strategy = name.split("+")
    else:
        raise InputError(field, f"unknown sampler '{name}'; expected {_allowed()}")
    if points not in POINTSETS or strategy not in STRATEGIES:
        raise InputError(field, f"unknown sampler '{name}'; expected {_allowed()}")
    return SamplerSpec(POINTSETS[points], STRATEGIES[strategy])


def parse_integrator(name: str, field: str = "integrator", unbiased: bool = False) -> Integrator:
    """The integrator called `name`; with `unbiased`, one that can make a ground truth."""
    allowed = [i.name for i in INTEGRATORS.values() if not (unbiased and i.biased)]
    if unbiased and name in INTEGRATORS and INTEGRATORS[name].biased:
        raise InputError(field, f"'{name}' is biased and cannot make a ground truth; "
                                f"use {' or '.join(allowed)}")
    if name not in INTEGRATORS:
        raise InputError(field, f"unknown integrator '{name}'; allowed: {', '.join(allowed)}")
    return INTEGRATORS[name]


def all_sampler_names(unbiased: bool = False) -> list[str]:
    """Every point set x strategy combination, canonical names (presets where they apply); with
    `unbiased`, only those whose point set is not biased by design."""
    return [SamplerSpec(p, s).name for p in POINTSETS.values() for s in STRATEGIES.values()
            if not (unbiased and p.biased)]
