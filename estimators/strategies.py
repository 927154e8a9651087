"""Sampling strategies: how directions and light points are drawn and how the two are combined.

Every strategy is an unbiased estimator of the same image (for a given integrator); they differ only
in variance. Fields are compile-time switches read by the kernel factory.
    direction   "uniform": uniform hemisphere (sphere for transmissive lobes); "lobe": cosine for
                diffuse, the Phong lobe for glossy reflection/transmission, Fresnel for the lobe choice
    light       how lights are sampled (LightSampling), or None: no light sampling
    light.environment  how next-event estimation samples an environment light (scenes without one
                compile it out): "uniform" over the sphere, "cosine" about the shading normal,
                "image": by the radiance image (piecewise-constant 2D, kernels/scene_model/environment_map.py)
    microfacet  how "lobe" samples a GGX microfacet normal: "vndf", the distribution of normals
                visible from wo (Dupuy & Benyoub 2023's spherical caps, the same density as Heitz
                2018), or "d", the full distribution D weighted by cos(theta_m) (Walter et al. 2007);
                all else equal, so a study isolates the choice (no effect on other kinds)
    lobes       registered lobe samplers (kernels/lobe_samplers.py) replacing "lobe"'s built-in
                sampling for the kinds they sample, by name: a new lobe sampler is a composition
A strategy's `combine` follows from `light`: "nee" (light samples without MIS): emitters count only
through light samples after a non-delta bounce; "bsdf" (no light sampling): only through scattered
rays; "mis" (light samples with MIS): both, weighted by `light.heuristic` ("power", Veach 1995's
recommendation, in every built-in strategy, or "balance"; kernels/mis.py).
"""
from __future__ import annotations

from dataclasses import dataclass


ENVIRONMENT_SAMPLERS = ("uniform", "cosine", "image")
MIS_HEURISTICS = ("power", "balance")          # kernels/mis.py defines each


@dataclass(frozen=True)
class LightSampling:
    """Next-event estimation: which light, which point on it, and whether MIS weights it."""
    point: str          # "area": uniform area on the chosen light; "solid_angle": uniform in the
                        # solid angle the light subtends (a sphere's cone, a rectangle's spherical
                        # rectangle, a mesh face's spherical triangle; kernels/lights.py has the
                        # thresholds below which flat lights fall back to area)
    pick: str           # the light selection (kernels/light_selection.py): "uniform" over lights,
                        # "power" (proportional to emitted power) or a plugin's
    mis: bool = False   # combine with scattered-ray hits by MIS
    environment: str = "image"  # the environment's sampler: "uniform" | "cosine" | "image"
    heuristic: str = "power"    # the MIS weight: "power" | "balance"

    def __post_init__(self):
        if self.environment not in ENVIRONMENT_SAMPLERS:
            raise ValueError(f"environment sampler {self.environment!r}: one of {ENVIRONMENT_SAMPLERS}")
        if self.heuristic not in MIS_HEURISTICS:
            raise ValueError(f"MIS heuristic {self.heuristic!r}: one of {MIS_HEURISTICS}")


@dataclass(frozen=True)
class Strategy:
    name: str
    description: str
    direction: str
    light: LightSampling | None = None
    microfacet: str = "vndf"
    lobes: tuple[str, ...] = ()
    fingerprint: str = ""          # a plugin strategy's (and its routines') source hash

    @property
    def combine(self) -> str:
        if self.light is None:
            return "bsdf"
        return "mis" if self.light.mis else "nee"

    @property
    def lobe(self) -> bool:
        return self.direction == "lobe"

    @property
    def solid_angle(self) -> bool:
        return self.light is not None and self.light.point == "solid_angle"

    @property
    def environment_sampler(self) -> str:
        return self.light.environment if self.light is not None else "image"

    @property
    def mis(self) -> bool:
        return self.combine == "mis"

    @property
    def counts_hits(self) -> bool:
        """Emitters found by scattered rays after a non-delta bounce count (MIS-weighted or not)."""
        return self.combine in ("bsdf", "mis")


STRATEGIES = {s.name: s for s in (
    Strategy("uniform", "uniform directions and uniform light area (an environment: uniform sphere), "
             "next-event estimation",
             "uniform", LightSampling("area", "uniform", environment="uniform")),
    Strategy("importance", "BSDF-lobe and solid-angle light sampling (an environment: by its image) "
             "combined by MIS (power heuristic)",
             "lobe", LightSampling("solid_angle", "power", mis=True)),
    Strategy("importance-area", "as importance, but lights sampled by area (to compare with solid angle)",
             "lobe", LightSampling("area", "power", mis=True)),
    Strategy("light", "light sampling only (solid angle), BSDF-lobe continuation",
             "lobe", LightSampling("solid_angle", "power")),
    Strategy("bsdf", "BSDF-lobe sampling only, emitters found by scattered rays",
             "lobe", None),
    # The environment's three samplers with all else as `importance` (which samples the image).
    Strategy("env-uniform", "as importance, but the environment sampled uniformly over the sphere",
             "lobe", LightSampling("solid_angle", "power", mis=True, environment="uniform")),
    Strategy("env-cosine", "as importance, but the environment sampled by cosine about the normal",
             "lobe", LightSampling("solid_angle", "power", mis=True, environment="cosine")),
    Strategy("importance-ggxd", "as importance, but GGX normals drawn from D cos (not the visible "
             "normals)", "lobe", LightSampling("solid_angle", "power", mis=True), microfacet="d"),
    Strategy("bsdf-ggxd", "as bsdf, but GGX normals drawn from D cos (not the visible normals)",
             "lobe", None, microfacet="d"),
)}
MICROFACET_SAMPLING = ("vndf", "d")


def environment_only(name: str) -> bool:
    """Whether strategy `name` is another registered strategy with only its environment sampler
    changed from the default ("image"): env-uniform and env-cosine against importance. In a scene
    without an environment it renders exactly as that strategy does."""
    from dataclasses import replace
    st = STRATEGIES.get(name)
    default = LightSampling.__dataclass_fields__["environment"].default
    if st is None or st.light is None or st.light.environment == default:
        return False
    return any(other.name != name and other.light is not None and other.light.environment == default
               and replace(other, name=name, description=st.description, fingerprint=st.fingerprint,
                           light=replace(other.light, environment=st.light.environment)) == st
               for other in STRATEGIES.values())
