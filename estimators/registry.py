"""Registry of point sets, strategies and presets; `parse_sampler` accepts a preset, POINTS+STRATEGY
or a point set's name alone.

Adding a built-in point set: one file in `pointsets/` defining POINTSET, named after it, and its
name in `POINTSET_MODULES`. A user's point set is a plugin (`estimators/plugins.py`): registered by
`drtlab.register_pointset`, found here like a built-in.
"""
import importlib
from collections.abc import MutableMapping
from dataclasses import dataclass

from drtlab.estimators.defaults import DEFAULT_SAMPLER, POINTSET_STRATEGY  # noqa: F401 (re-exported)
from drtlab.estimators.integrators import BUILT_IN_INTEGRATORS, INTEGRATORS, Integrator  # noqa: F401
from drtlab.estimators.pointsets.base import PointSet
from drtlab.estimators.strategies import STRATEGIES, Strategy

BUILT_IN_STRATEGIES = tuple(STRATEGIES)       # before any plugin adds its own
from drtlab.errors import InputError

# The modules of pointsets/, each named after the POINTSET it defines, in the order listings show.
POINTSET_MODULES = ("independent", "stratified", "lhs", "cmj", "halton", "sobol", "zsobol", "pmj02",
                     "presampled", "presampled_random")


class _PointSets(MutableMapping):
    """Point-set name -> PointSet, each module imported when its set is first looked up: a render
    needs one set, and importing all of them (their Warp functions, halton's primes) is ~0.1 s of a
    small render's start-up. Iterating over the values imports every one."""

    def __init__(self, modules: tuple[str, ...]):
        self._names = list(modules)
        self._loaded: dict[str, PointSet] = {}

    def __getitem__(self, name: str) -> PointSet:
        ps = self._loaded.get(name)
        if ps is None:
            if name not in self:
                raise KeyError(name)
            ps = self._loaded.get(name)
        if ps is None:
            ps = importlib.import_module(f"drtlab.estimators.pointsets.{name}").POINTSET
            if ps.name != name:
                raise RuntimeError(f"estimators/pointsets/{name}.py defines the point set "
                                   f"{ps.name!r}: a point set's module is named after it")
            self._loaded[name] = ps
        return ps

    def __setitem__(self, name: str, ps: PointSet) -> None:       # tests register fakes
        if name not in self._names:
            self._names.append(name)
        self._loaded[name] = ps

    def __delitem__(self, name: str) -> None:
        self._names.remove(name)
        self._loaded.pop(name, None)

    def __contains__(self, name) -> bool:
        if name not in self._names:
            _entry_points()                 # an installed package's plugin may define it
        return name in self._names

    def __iter__(self):
        _entry_points()
        return iter(list(self._names))

    def __len__(self) -> int:
        return len(self._names)


def _entry_points() -> None:
    from drtlab.estimators.plugins import load_entry_points
    load_entry_points()


POINTSETS: MutableMapping[str, PointSet] = _PointSets(POINTSET_MODULES)


def __getattr__(name: str):
    # Sets that differ from another only in the bounce directions (PointSet.same_as_outside_directions:
    # Cook's tables): studies of the pixel dimensions alone (the integrand testbed) skip them.
    # Computed when asked for: it reads every point set.
    if name == "DIRECTION_ONLY_POINTSETS":
        return tuple(n for n, ps in POINTSETS.items() if ps.same_as_outside_directions)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


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


# How a pixel filter other than the box is estimated (kernels/filters.py), as a suffix of the sampler
# name: "+fis" (filter importance sampling, the default, unbiased) or "+splat" (weighted splatting,
# consistent). A box-filtered scene renders the same image under both.
PIXEL_ESTIMATORS = ("fis", "splat")


@dataclass(frozen=True)
class SamplerSpec:
    pointset: PointSet
    strategy: Strategy
    splat: bool = False

    @property
    def name(self) -> str:
        """Canonical name: the preset name when one matches, else POINTS+STRATEGY; "+splat" after
        it for the splatting estimator."""
        suffix = "+splat" if self.splat else ""
        for preset, pair in PRESETS.items():
            if pair == (self.pointset.name, self.strategy.name):
                return preset + suffix
        return f"{self.pointset.name}+{self.strategy.name}{suffix}"


def _allowed() -> str:
    return (f"a preset ({', '.join(PRESETS)}), POINTS+STRATEGY with POINTS in "
            f"{{{', '.join(POINTSETS)}}} and STRATEGY in {{{', '.join(STRATEGIES)}}}, or POINTS "
            f"alone (= POINTS+{POINTSET_STRATEGY}); any of them may end in "
            f"{' or '.join('+' + e for e in PIXEL_ESTIMATORS)} (the pixel filter's estimator)")


def parse_sampler(name: str, field: str = "sampler") -> SamplerSpec:
    """A preset, POINTS+STRATEGY, or a point set's name alone (POINTS+POINTSET_STRATEGY)."""
    if not isinstance(name, str):
        raise InputError(field, f"must be a string: {_allowed()}, got {name!r}")
    full, estimator = name, "fis"
    head, _, tail = name.rpartition("+")
    if head and tail in PIXEL_ESTIMATORS:
        name, estimator = head, tail
    spec = _parse_base(name, full, field)
    return SamplerSpec(spec.pointset, spec.strategy, splat=estimator == "splat")


def _parse_base(name: str, full: str, field: str) -> SamplerSpec:
    if name in PRESETS:
        points, strategy = PRESETS[name]
    elif name in POINTSETS:
        points, strategy = name, POINTSET_STRATEGY
    elif name.count("+") == 1:
        points, strategy = name.split("+")
    else:
        raise InputError(field, f"unknown sampler '{full}'; expected {_allowed()}")
    if points not in POINTSETS or strategy not in STRATEGIES:
        raise InputError(field, f"unknown sampler '{full}'; expected {_allowed()}")
    return SamplerSpec(POINTSETS[points], STRATEGIES[strategy])


def parse_integrator(name: str, field: str = "integrator", unbiased: bool = False) -> Integrator:
    """The integrator called `name` (a built-in, or a plugin's: an installed package's entry point
    is loaded when the name is not yet registered); with `unbiased`, one that can make a ground
    truth."""
    if name not in INTEGRATORS:
        _entry_points()
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
