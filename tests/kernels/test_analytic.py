"""Analytic and energy tests: scenes whose every pixel has a closed-form expected value.

Every registered sampler (all point sets x strategies) renders each closed-form scene to its exact
value within its standard error, as pbrt-v4 checks its samplers, except that the tolerance is the
error estimate rather than a fixed number: RUNS independent renders (fixed seeds) -> 12 regions of
4 x 4 pixels -> Welch t per region against the exact value -> chi-square over regions (see
tests/support/stats_util.py). Multiple-test correction: Sidak over every comparison this module makes in the
full tier (M_TESTS), alpha_test = 1 - 0.99^(1/M_TESTS).

Scenes (closed forms derived in tests/support/scene_util.py):
  white furnace      closed diffuse box, albedo rho, emission Le, camera inside:
                     path Le (1 - rho^d) / (1 - rho) for max_depth d, Le / (1 - rho) unbounded with
                     Russian roulette; drt Le (d = 1), Le (1 + rho) (d >= 2).
  light over plane   Lambertian plane under a sphere light (E = pi Le (r/dist)^2 cos theta) or a
                     tilted one-sided quad light (Lambert's polygon formula) and a uniform
                     background: L = rho (Le s + Bg (1 - s)), integrated over each pixel.
  thin lens          the sphere-lit plane seen through a thin lens (quadrature over pixel and lens).
  BSDF furnaces      one sphere per BSDF in a uniform background of radiance 1 (energy conservation):
                     diffuse, mirror and dielectric with albedo 1 are lossless (every pixel = 1);
                     glossy (normalized modified Phong) loses exactly what its directional albedo
                     (quadrature) says; glossy_dielectric has no closed form: it must not gain energy
                     (<= 1) and its two unbiased estimators must agree.

Tiers: the fast tier runs on the furnace (the variants cornell-box compiles) every sampler of the
independent and stratified point sets with both integrators and the other point sets with the
importance strategy and path tracing (the cornell-box variants test_unbiased's fast tier compiles
too), and the three presets on the other scenes; the full tier runs every sampler everywhere with
2x the runs and 4x the spp.
"""
from __future__ import annotations

import functools

import numpy as np
import pytest

from drtlab.estimators import registry
from drtlab.estimators.registry import all_sampler_names
from drtlab.experiments.stats.chi2 import sidak

import scene_util as su
from stats_util import ALPHA, FULL, compare, render_estimate, tier

BLOCK = 4
RES = (16, 12)
RUNS = tier(8, 16)
SPP = tier(64, 256)
SAMPLERS = all_sampler_names(unbiased=True)     # point sets biased by design (presampled) excluded
PRESETS = list(registry.PRESETS)
INTEGRATORS = ("drt", "path")
FURNACE_DEPTHS = {"path": (1, 2, 5), "drt": (1, 3)}
# NEE-only strategies (emitters area-sampled, no MIS) have infinite variance in a closed emitting
# box beyond direct light (scene_util.furnace_box): path depth 5 is tested with the other strategies.
NEE_ONLY = {name for name, st in registry.STRATEGIES.items() if st.combine == "nee"}
BSDF_KINDS = ("diffuse", "glossy", "mirror", "dielectric", "glossy_dielectric")


def furnace_depths(sampler: str, integrator: str):
    nee_only = registry.parse_sampler(sampler).strategy.name in NEE_ONLY
    return [d for d in FURNACE_DEPTHS[integrator] if not (nee_only and integrator == "path" and d > 2)]


# Every comparison of the full tier: furnace depths, 2 light-over-plane kinds, the lens scene, the
# roulette furnace, the BSDF furnaces and the glossy-dielectric strategy agreement.
M_TESTS = (sum(len(furnace_depths(s, i)) for s in SAMPLERS for i in INTEGRATORS)
           + len(SAMPLERS) * len(INTEGRATORS) * 3 + 1 + len(BSDF_KINDS) + 1)
ALPHA_TEST = sidak(ALPHA, M_TESTS)


FAST_ALL_POINTSETS = ("independent", "stratified")
# Strategies that differ from importance only under an environment light, which none of these scenes
# has: full tier only (tests/kernels/test_environment.py tests them where they differ).
ENV_STRATEGIES = ("env-uniform", "env-cosine")
FAST_MODERN = ("importance", "path")      # the other point sets' (strategy, integrator) in fast


def in_fast_furnace(sampler: str, integrator: str) -> bool:
    spec = registry.parse_sampler(sampler)
    if spec.strategy.name in ENV_STRATEGIES:
        return False
    if spec.strategy.microfacet != "vndf":
        return False        # differs from its twin on GGX lobes only, which no furnace here has
    return (spec.pointset.name in FAST_ALL_POINTSETS
            or (spec.strategy.name, integrator) == FAST_MODERN)


def slow_marks():
    return [pytest.mark.slow, pytest.mark.skipif(not FULL, reason="full tier only")]


def samplers_for(fast_all: bool):
    """All samplers in the full tier; in the fast tier all (fast_all) or the presets."""
    out = []
    for s in SAMPLERS:
        keep = (fast_all and registry.parse_sampler(s).strategy.name not in ENV_STRATEGIES
                or s in PRESETS)
        out.append(pytest.param(s, marks=[] if keep else slow_marks()))
    return out


def furnace_cases():
    """(sampler, integrator) of the white furnace: fast as in_fast_furnace says, else full tier."""
    return [pytest.param(s, i, id=f"{s}-{i}", marks=[] if in_fast_furnace(s, i) else slow_marks())
            for s in SAMPLERS for i in INTEGRATORS]


def check(cf: su.ClosedForm, sampler: str, integrator: str, spp: int = SPP, runs: int = RUNS):
    est = render_estimate(cf.load(), sampler, integrator, spp, runs,
                          ("analytic", cf.name, cf.scene["scene"]["max_depth"], sampler, integrator),
                          block=BLOCK)
    truth = cf.region_truth(BLOCK)
    c = compare(est, truth, ALPHA_TEST)
    msg = (f"{cf.name} {sampler}/{integrator}: {c.summary()}; exact {np.round(truth.mean[:4], 5)}..., "
           f"estimate {np.round(est.mean[:4], 5)}...")
    assert est.nonfinite == 0 and est.negative == 0, f"{msg}: {est.nonfinite} non-finite, " \
                                                     f"{est.negative} negative"
    assert not c.rejected, msg
    return c, est


def test_family_size():
    n = len(registry.unbiased_pointsets()) * len(registry.STRATEGIES)
    nee_only = len(registry.unbiased_pointsets()) * len(NEE_ONLY)
    assert M_TESTS == n * 5 - nee_only + n * 2 * 3 + 1 + 5 + 1
    assert len(SAMPLERS) == n
    assert registry.biased_pointsets() == ["presampled"]


def test_closed_form_scenes_share_builtin_kernel_variants():
    # Compile budget: the closed-form scenes compile to the built-ins' kernel variants (scene_util
    # adds invisible feature shapes where needed), so testing them with every sampler costs renders,
    # not compiles.
    from drtlab.kernels.features import features_of
    from drtlab.kernels.scene_model.scene_file import load_scene
    pairs = [(su.furnace_box(), "cornell-box"),
             (su.light_over_plane("sphere"), "aa-edges"),
             (su.light_over_plane("quad", size=0.8, quad_normal=(0.3, -1.0, 0.2)), "aa-edges"),
             (thin_lens_scene(), "dof"),
             (su.light_over_plane("sphere", zero_velocity_motion=True, checker=True, bg=0.0),
              "motion-blur"),
             (su.sphere_interior(), "soft-shadows")]
    for cf, builtin in pairs:
        for integrator in INTEGRATORS:
            assert features_of(cf.load(), integrator) == features_of(load_scene(builtin), integrator), \
                (cf.name, builtin)


def test_furnace_closed_form_values():
    assert su.furnace_value(0.6, 1.0, 4, "path") == pytest.approx(2.176)
    assert su.furnace_value(0.5, 2.0, -1, "path") == pytest.approx(4.0)
    assert su.furnace_value(0.6, 1.0, 1, "drt") == 1.0
    assert su.furnace_value(0.6, 1.0, 7, "drt") == pytest.approx(1.6)


# ---------------------------------------------------------------------------------------------------
# White furnace: every sampler, both integrators, several depths
# ---------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("sampler,integrator", furnace_cases())
def test_white_furnace(sampler, integrator):
    # The camera sees only the middle of one wall (EDGE_FREE_VIEW) so that direct light sampled
    # from the walls' area has finite variance (scene_util.furnace_box).
    for depth in furnace_depths(sampler, integrator):
        cf = su.furnace_box(rho=0.6, le=1.0, depth=depth, integrator=integrator, **su.EDGE_FREE_VIEW)
        check(cf, sampler, integrator)


def test_white_furnace_unbounded_with_roulette():
    # max_depth -1 with roulette from depth 1: Le / (1 - rho), the full Neumann series.
    cf = su.furnace_box(rho=0.5, le=1.0, depth=-1, roulette=True, rr_depth=1)
    check(cf, "importance", "path")


# ---------------------------------------------------------------------------------------------------
# Lambertian plane lit by a sphere light or a quad light (pinhole), and through a thin lens
# ---------------------------------------------------------------------------------------------------

PLANES = {
    "sphere-light": dict(kind="sphere"),
    "quad-light": dict(kind="quad", size=0.8, quad_normal=(0.3, -1.0, 0.2)),
}


@pytest.mark.parametrize("integrator", INTEGRATORS)
@pytest.mark.parametrize("sampler", samplers_for(fast_all=False))
@pytest.mark.parametrize("light", list(PLANES))
def test_light_over_plane(light, sampler, integrator):
    cf = su.light_over_plane(**PLANES[light], integrator=integrator, name=light)
    check(cf, sampler, integrator)


@pytest.mark.parametrize("integrator", INTEGRATORS)
@pytest.mark.parametrize("sampler", samplers_for(fast_all=False))
def test_thin_lens_plane(sampler, integrator):
    # Aperture 0.3, focused at 2 (the plane is about 3.7 away along the axis), a small bright light
    # low over the plane just outside the view: a strongly blurred hot spot whose expected value is
    # the quadrature over pixel and lens of the plane's closed-form radiance.
    check(thin_lens_scene(integrator), sampler, integrator)


LENS_KW = dict(light_pos=(-0.7, 0.15, 0.0), size=0.05, le=400.0, bg=0.05, fov=12.0, checker=True)


@functools.lru_cache(maxsize=None)
def thin_lens_scene(integrator="path", aperture=0.3, focus=2.0):
    return su.light_over_plane("sphere", lens=(aperture, focus), integrator=integrator,
                               name="thin-lens", **LENS_KW)


def test_thin_lens_blurs_the_closed_form():
    # The lens truth differs from the pinhole truth by up to ~50% per region, so a lens that
    # sampled the wrong rays would fail test_thin_lens_plane (it is not a pinhole test in disguise).
    pin = su.light_over_plane("sphere", **LENS_KW).region_truth(BLOCK).mean
    lens = thin_lens_scene().region_truth(BLOCK).mean
    assert np.max(np.abs(lens - pin) / pin) > 0.2


# ---------------------------------------------------------------------------------------------------
# Energy conservation: one sphere per BSDF in a white furnace (background radiance 1)
# ---------------------------------------------------------------------------------------------------

FURNACES = {
    "diffuse": dict(),
    "glossy": dict(exponent=20.0),
    "mirror": dict(),
    "dielectric": dict(ior=1.5, roulette=True, depth=-1),
    "glossy_dielectric": dict(ior=1.5, exponent=100.0, depth=16),
}


@pytest.mark.parametrize("kind", BSDF_KINDS)
def test_bsdf_furnace_conserves_energy(kind):
    cf = su.sphere_furnace(kind, **FURNACES[kind])
    if cf.truth is not None:
        # Lossless kinds: exactly 1; glossy: its directional albedo (< 1 away from normal incidence).
        c, est = check(cf, "importance", "path")
        assert np.all(cf.truth <= 3.0 + 1e-9)
        return
    # glossy_dielectric: no closed form. It must not create energy: every region <= 1 (one-sided
    # z against 1 at the same alpha_test), and it must lose little at exponent 100 (>= 0.9 in the
    # centre, where the lobes are far from the horizon).
    est = render_estimate(cf.load(), "importance", "path", SPP, RUNS, ("analytic-gd", kind),
                          block=BLOCK)
    assert est.nonfinite == 0 and est.negative == 0
    ones = su.Estimate.exact(np.full_like(est.mean, 3.0))
    c = compare(est, ones, ALPHA_TEST)
    from scipy import stats
    z_crit = stats.norm.isf(ALPHA_TEST)
    assert np.all(c.z < z_crit), f"glossy_dielectric furnace gains energy: {c.summary()}"
    centre = est.mean.reshape(3, 4)[1, 1:3] / 3.0
    assert np.all(centre >= 0.9), f"centre regions {centre}"


def test_glossy_dielectric_lobe_sampling_agrees_with_uniform():
    # Exponent 1 lobes cross the surface widely: uniform sphere sampling (pdf 1/4pi, trivially
    # right) and lobe sampling must agree. Before d61f7ee the lobe pdf counted only the lobe on wi's
    # side while the sampler draws the two-lobe mixture on both sides; this test then failed with
    # 15-30% too much energy per region (chi2 ~ 1e2-1e3, p ~ 1e-49).
    cf = su.sphere_furnace("glossy_dielectric", exponent=1.0, ior=1.5, depth=12)
    runs, spp = RUNS, SPP * 4
    lobe = render_estimate(cf.load(), "importance", "path", spp, runs, ("gd-lobe",), block=BLOCK)
    unif = render_estimate(cf.load(), "uniform", "path", spp, runs, ("gd-unif",), block=BLOCK)
    c = compare(unif, lobe, ALPHA_TEST)
    assert not c.rejected, c.summary()
