"""Light selection: which area light next-event estimation samples from a shading point, with the
probability it picks each (the light's density and MIS read it). One interface for the built-ins and
a user's plugins alike (pbrt-v4's `LightSampler`):

    pick(sd: SceneData, x: wp.vec3, u: float) -> int     a light index, from u in [0, 1)
    pmf(sd: SceneData, x: wp.vec3, li: int) -> float     the probability `pick` gives li from x

`pmf` must be exactly what `pick` does, summing to 1 over the scene's `sd.lights.n_area` lights at
every x, and positive wherever a light can contribute (else the estimator loses that light's light;
MIS stays unbiased only with the exact pmf): `drtlab check` and the chi-square harness test both.
A light's power share is `sd.lights.pmf[li]` and its position `sd.lights.center[li]`
(`scene_upload.light_center`). `environment_share` says how an environment light's share of the
choice is set against the area lights: by "power" or "uniform" (`kernels/environment.py`).

A strategy names its selection (`LightSampling.pick`); the built-ins are `uniform` and `power`.
"""
from dataclasses import dataclass

import warp as wp

from drtlab.errors import InputError
from drtlab.estimators.plugins import check_warp_function
from drtlab.kernels.device_scene import SceneData

ENVIRONMENT_SHARES = ("power", "uniform")


@dataclass(frozen=True)
class LightSelection:
    name: str
    description: str
    pick: wp.Function
    pmf: wp.Function
    environment_share: str = "power"
    fingerprint: str = ""              # a plugin's source hash (estimators/plugins.py); "" built in


@wp.func
def uniform_pick(sd: SceneData, x: wp.vec3, u: float) -> int:
    return wp.min(int(u * float(sd.lights.n_area)), sd.lights.n_area - 1)


@wp.func
def uniform_pmf(sd: SceneData, x: wp.vec3, li: int) -> float:
    return 1.0 / float(sd.lights.n_area)


@wp.func
def power_pick(sd: SceneData, x: wp.vec3, u: float) -> int:
    li = int(0)
    # Few lights: a linear scan of the cdf is cheaper than a search.
    while li < sd.lights.n_area - 1 and u >= sd.lights.cdf[li]:
        li += 1
    return li


@wp.func
def power_pmf(sd: SceneData, x: wp.vec3, li: int) -> float:
    return sd.lights.pmf[li]


LIGHT_SELECTIONS = {s.name: s for s in (
    LightSelection("uniform", "every area light alike", uniform_pick, uniform_pmf, "uniform"),
    LightSelection("power", "in proportion to emitted power", power_pick, power_pmf, "power"),
)}
BUILT_IN = tuple(LIGHT_SELECTIONS)


def selection_of(strategy) -> LightSelection:
    """The light selection a strategy names (`power` for one without light sampling: its
    environment share is the only part read then)."""
    name = strategy.light.pick if strategy.light is not None else "power"
    if name not in LIGHT_SELECTIONS:
        raise InputError("strategy", f"strategy '{strategy.name}' picks lights by {name!r}, which is "
                                     f"not registered; registered: {', '.join(LIGHT_SELECTIONS)}")
    return LIGHT_SELECTIONS[name]


def register(sel: LightSelection, who: str, fingerprint: str) -> LightSelection:
    """Add a user's selection (checked: signatures, name, environment share); a name registered
    again is replaced (an edited plugin)."""
    from dataclasses import replace
    if not isinstance(sel, LightSelection):
        raise InputError(who, f"register_light_selection takes a drtlab LightSelection, got {type(sel).__name__}")
    if sel.name in BUILT_IN:
        raise InputError(who, f"'{sel.name}' is a built-in light selection; give yours another name")
    if sel.environment_share not in ENVIRONMENT_SHARES:
        raise InputError(who, f"environment_share must be one of {', '.join(ENVIRONMENT_SHARES)}, "
                              f"got {sel.environment_share!r}")
    check_warp_function(sel.pick, "pick", (SceneData, wp.vec3, float), int, who)
    check_warp_function(sel.pmf, "pmf", (SceneData, wp.vec3, int), float, who)
    sel = replace(sel, fingerprint=fingerprint)
    LIGHT_SELECTIONS[sel.name] = sel
    return sel
