"""Unbiasedness: every built-in scene x unbiased integrator x point set x strategy agrees with a
reference, and the same test rejects deliberately wrong estimators.

Test (tests/support/stats_util.py has the details): RUNS independent renders at SPP samples per pixel and
RES = 32 x 24, each reduced to 12 region values (8 x 8-pixel regions, mean of R + G + B); the
reference is REF_RUNS renders with the `importance` sampler (independent points, MIS) at REF_SPP and
other seeds. Per region a Welch t -> equal-p normal deviate; X = sum z^2 ~ chi-square(12) under
"no bias". Multiple-test correction: Sidak over the full matrix, m = M_TESTS = built-in scenes x
unbiased integrators x samplers (unbiased point sets x strategies), all counted from the registries
(13 x 2 x 81 = 2106 with today's built-ins), so each test runs at alpha_test = 1 - 0.99^(1/m)
(4.8e-6 at m = 2106) and the family-wise false-alarm rate of the whole matrix is <= 0.01. The fast
tier runs a subset of the matrix at the same alpha_test (its family-wise rate is then below 0.01 too).

Point sets biased by design (PointSet.biased: `presampled`, Cook's fixed table) are not in the
matrix; test_presampled_table_is_rejected checks that this test rejects it on the glossy scene while
its per-pixel randomised twin `presampled_random` (in the matrix like any other set) passes.

Coverage. Full tier (DRTLAB_TEST_TIER=full): all combinations, RUNS x SPP = 32 x 128 (the
reference 32 x 512). Fast tier, 12 x 32 (reference 12 x 128): every scene x {drt, path} x the three
presets (uniform, stratified, importance) plus the 8 samplers of the independent and stratified
point sets with the five strategies that sample no GGX lobe differently (importance-area among
them) on cornell-box and veach-mis, minus the HEAVY combinations (62 + 6 + 8 combinations), plus
independent+importance-ggxd (GGX normals from D instead of the visible normals, against the
visible-normal reference) on glossy-ggx with both integrators (FAST_GGX: the D sampler's only
scene), plus each
of the seven other point sets (lhs, cmj, halton, sobol, zsobol, pmj02, presampled_random) with the
importance strategy, plus the environment's two other samplers (env-uniform, env-cosine: they differ
from importance only where a scene has an environment) with independent points on the environment
scene (4 combinations; the FAST_ALL_SAMPLERS scenes run the original four strategies)
on two representative scene x integrator pairs (FAST_MODERN): cornell-box with path tracing (to
depth 8, through every per-bounce dimension) and drt-showcase with drt (lens, shutter time, glossy
reflection and transmission, area light): 14 combinations, 14 kernel variants (a variant costs a
few seconds to compile; the full tier runs the rest). The presets' kernel variants are shared
with the other test files (test_render compiles the same built-in x preset variants), and the new
sets' cornell-box path variants with test_analytic's white furnace.

Heavy tails. Where an estimator's samples are dominated by rare huge values, the t statistic of a
few runs is skewed (the mean usually misses the spikes and so does the variance) and the test fires
on a correct estimator. Calibration over 4-6 re-drawn seed sets per combination (SEED_SALT in
stats_util) found these, handled openly rather than by widening alpha:
  * HEAVY (full tier only, HEAVY_SPP = 1024 spp x 32 runs): glossy x path x the light strategy
    (NEE-only caustics: floor -> 10^4 lobe -> light), veach-mis x the uniform and light strategies
    (NEE-only: light samples rarely land in the 10^3/10^4 plates' lobes - the very point of Veach's
    scene), translucency x the uniform strategy (below).
  * LOWERED: the uniform strategy's directions are uniform over the (hemi)sphere, so a Phong lobe of
    exponent n is hit with probability ~ 2/n and a glossy transmission needs two such hits per pane
    (~ 3e-8 per path at n = 3000): no affordable budget tests glossy (exponents 100 ... 10^4),
    drt-showcase (200, 150) or translucency (30 ... 3000) under it. Those tests render the same
    scene - the same kernel variant, the same code paths - with the lobe exponents lowered to 10,
    which the test id says ("-exponents-lowered-to-10"); glossy-ggx's roughness is raised to 0.3
    (alpha 0.02 ... 0.2 -> 0.3, "-roughness-raised-to-0.3"). High exponents are tested with lobe
    sampling (everywhere here, and by test_hard_cases up to 10^6).

Whitted is deterministic and biased (regular grid, lens centre, point-like lights): it is labelled
biased in the registry and excluded, which test_biased_integrators_are_labelled_and_excluded checks.
"""
from __future__ import annotations

import functools

import numpy as np
import pytest
import warp as wp

from drtlab.estimators import registry
from drtlab.estimators.hashing import hash_key, mix32, unit_float
from drtlab.estimators.integrators import INTEGRATORS
from drtlab.estimators.pointsets.base import PointSet
from drtlab.estimators.pointsets.stratified import JITTER, grid_columns, place, stratum
from drtlab.estimators.registry import all_sampler_names, parse_sampler
from drtlab.estimators.strategies import STRATEGIES
from drtlab.experiments.stats.chi2 import sidak
from drtlab.kernels.scene_model.scene_file import builtin_names, load_scene
from drtlab.kernels.features import FAULTS

from stats_util import ALPHA, FULL, compare, render_estimate, tier

RES = (32, 24)
BLOCK = 8
RUNS = tier(12, 32)
SPP = tier(32, 128)
REF_RUNS = tier(12, 32)
REF_SPP = tier(128, 512)
HEAVY_SPP = 1024    # heavy-tailed combinations (full tier only), see HEAVY
REFERENCE_SAMPLER = "importance"

SCENES = builtin_names()
# Mitsuba 3's direct is tested against path tracing at max_depth 2, its estimand
# (tests/kernels/test_direct_integrator.py), not over this matrix.
UNBIASED = [name for name, integ in INTEGRATORS.items() if not integ.biased and name != "direct"]
SAMPLERS = all_sampler_names(unbiased=True)     # biased-by-design point sets excluded (module doc)
PRESETS = [name for name in registry.PRESETS]
FAST_ALL_SAMPLERS = ("cornell-box", "veach-mis")
FAST_ALL_POINTSETS = ("independent", "stratified")     # every strategy on FAST_ALL_SAMPLERS
# (scene, integrator) on which the other point sets run in the fast tier, with FAST_MODERN_STRATEGY.
FAST_MODERN = (("cornell-box", "path"), ("drt-showcase", "drt"))
FAST_MODERN_STRATEGY = "importance"
# Strategies that differ from importance only in how they sample an environment light.
ENV_STRATEGIES = ("env-uniform", "env-cosine")
# The D-cos GGX sampler on the scene with GGX lobes, against the visible-normal reference.
FAST_GGX = ("glossy-ggx", "independent+importance-ggxd")
M_TESTS = len(SCENES) * len(UNBIASED) * len(SAMPLERS)
ALPHA_TEST = sidak(ALPHA, M_TESTS)

# (scene, integrator or None for both, strategy): heavy-tailed estimators, HEAVY_SPP (module doc).
HEAVY = {
    ("glossy", "path", "light"),        # NEE-only caustics off the 10^4 lobes (floor -> sphere -> light)
    ("veach-mis", None, "uniform"),     # NEE-only light sampling on the 10^3/10^4 plates (Veach's
    ("veach-mis", None, "light"),       # point: light samples rarely land in a sharp lobe)
    ("translucency", None, "uniform"),  # two uniform-sphere hits of a transmission lobe per pane
    ("glossy-ggx", "path", "light"),    # as glossy
    ("glossy-ggx", None, "bsdf"),       # scattered rays alone must find the small sphere light
    ("glossy-ggx", None, "bsdf-ggxd"),
}
# Uniform-strategy direction sampling of lobes with exponent >= 30 is untestable in an affordable
# budget (module doc): the same scene (same kernel variant) with those exponents lowered to 10.
LOWERED = {
    ("glossy", "uniform"): {f"materials.gloss{n}.exponent": 10.0 for n in (100, 1000, 10000)},
    ("drt-showcase", "uniform"): {"materials.gold.exponent": 10.0, "materials.frost.exponent": 10.0},
    ("translucency", "uniform"): {f"materials.frost{n}.exponent": 10.0 for n in (30, 300, 3000)},
    ("glossy-ggx", "uniform"): {f"materials.{m}.roughness": 0.3 for m in ("ggx002", "ggx008", "ggx02")},
}


def strategy_of(sampler: str) -> str:
    return parse_sampler(sampler).strategy.name


def in_fast_tier(scene: str, integrator: str, sampler: str) -> bool:
    spec = parse_sampler(sampler)
    if sampler in PRESETS:
        return True
    if spec.strategy.name in ENV_STRATEGIES:
        return scene == "environment" and spec.pointset.name == "independent"
    if spec.strategy.microfacet != "vndf":
        return (scene, sampler) == FAST_GGX
    if spec.pointset.name in FAST_ALL_POINTSETS:
        return scene in FAST_ALL_SAMPLERS
    return (scene, integrator) in FAST_MODERN and spec.strategy.name == FAST_MODERN_STRATEGY


def is_heavy(scene: str, integrator: str, sampler: str) -> bool:
    s = strategy_of(sampler)
    return (scene, integrator, s) in HEAVY or (scene, None, s) in HEAVY


def overrides_for(scene: str, sampler: str) -> dict:
    return LOWERED.get((scene, strategy_of(sampler)), {})


@functools.lru_cache(maxsize=None)
def load(scene: str, overrides_key: tuple = ()):
    return load_scene(scene, overrides=dict(overrides_key) or None)


@functools.lru_cache(maxsize=None)
def reference(scene: str, integrator: str, overrides_key: tuple = ()):
    return render_estimate(load(scene, overrides_key), REFERENCE_SAMPLER, integrator, REF_SPP,
                           REF_RUNS, ("reference", scene, integrator, overrides_key), res=RES,
                           block=BLOCK)


def agreement(scene: str, integrator: str, sampler: str, faults=(), overrides: dict | None = None,
              spp: int | None = None, runs: int | None = None):
    """The one test: (comparison, estimate) of `sampler` against the reference."""
    key = tuple(sorted((overrides or {}).items()))
    ref = reference(scene, integrator, key)
    est = render_estimate(load(scene, key), sampler, integrator, spp or SPP, runs or RUNS,
                          ("test", scene, integrator, sampler, tuple(faults), key), res=RES,
                          block=BLOCK, faults=faults)
    return compare(est, ref, ALPHA_TEST), est


def matrix():
    cases = []
    for scene in SCENES:
        for integrator in UNBIASED:
            for sampler in SAMPLERS:
                fast = in_fast_tier(scene, integrator, sampler)
                lowered = (("-roughness-raised-to-0.3" if scene == "glossy-ggx"
                            else "-exponents-lowered-to-10") if overrides_for(scene, sampler) else "")
                marks = []
                if not fast:
                    marks = [pytest.mark.slow, pytest.mark.skipif(
                        not FULL, reason="full tier only (make test-full)")]
                elif is_heavy(scene, integrator, sampler):
                    marks = [pytest.mark.slow, pytest.mark.skipif(
                        not FULL, reason="heavy-tailed estimator: needs HEAVY_SPP, full tier only")]
                cases.append(pytest.param(scene, integrator, sampler, marks=marks,
                                          id=f"{scene}{lowered}-{integrator}-{sampler}"))
    return cases


def test_matrix_is_the_whole_product():
    # Counted from the registries: a new built-in point set, strategy or scene joins the matrix
    # (and its Sidak correction) with no number edited here.
    assert len(matrix()) == M_TESTS == len(SCENES) * len(UNBIASED) * len(SAMPLERS)
    assert {strategy_of(s) for s in SAMPLERS} == set(STRATEGIES)
    unbiased_sets = [name for name in registry.POINTSETS if not registry.POINTSETS[name].biased]
    assert {parse_sampler(s).pointset.name for s in SAMPLERS} == set(registry.unbiased_pointsets()) \
        == set(unbiased_sets)
    # a set biased by design needs its own rejection test here (test_presampled_table_is_rejected)
    assert registry.biased_pointsets() == ["presampled"]


def test_the_fast_tier_is_what_its_rules_say():
    """The fast tier enumerated from its rules (module doc, Coverage) over the registries, against
    the matrix's marks: every preset everywhere, the environment's samplers on its scene, FAST_GGX,
    every strategy of the FAST_ALL_POINTSETS on FAST_ALL_SAMPLERS, every other point set with
    FAST_MODERN_STRATEGY on FAST_MODERN; heavy-tailed combinations left to the full tier."""
    preset_of = {pair: name for name, pair in registry.PRESETS.items()}
    name = lambda ps, st: preset_of.get((ps, st), f"{ps}+{st}")
    others = [ps for ps in registry.unbiased_pointsets() if ps not in FAST_ALL_POINTSETS]
    modern = [(scene, integrator, name(ps, FAST_MODERN_STRATEGY)) for scene, integrator in FAST_MODERN
              for ps in others]
    rules = ([(scene, i, p) for scene in SCENES for i in UNBIASED for p in PRESETS]
             + [("environment", i, name("independent", st)) for i in UNBIASED for st in ENV_STRATEGIES]
             + [(FAST_GGX[0], i, FAST_GGX[1]) for i in UNBIASED]
             + [(scene, i, name(ps, st)) for scene in FAST_ALL_SAMPLERS for i in UNBIASED
                for ps in FAST_ALL_POINTSETS for st, s in STRATEGIES.items()
                if s.microfacet == "vndf" and st not in ENV_STRATEGIES]
             + modern)
    expected = sorted({c for c in rules if not is_heavy(*c)})
    fast = sorted(tuple(p.values) for p in matrix() if not p.marks)
    assert fast == expected
    assert len([c for c in fast if parse_sampler(c[2]).pointset.name in others]) == \
        len(others) * len(FAST_MODERN)


def test_biased_integrators_are_labelled_and_excluded():
    assert INTEGRATORS["whitted"].biased
    assert UNBIASED == ["drt", "path"]
    assert all(not INTEGRATORS[i].biased for i in UNBIASED)


@pytest.mark.parametrize("scene,integrator,sampler", matrix())
def test_unbiased(scene, integrator, sampler):
    heavy = is_heavy(scene, integrator, sampler)
    cmp_, est = agreement(scene, integrator, sampler, overrides=overrides_for(scene, sampler),
                          spp=HEAVY_SPP if heavy else SPP)
    assert est.nonfinite == 0 and est.negative == 0, (
        f"{est.nonfinite} non-finite, {est.negative} negative pixel values")
    assert not cmp_.rejected, f"{scene}/{integrator}/{sampler}{' (heavy)' if heavy else ''}: " \
                              f"{cmp_.summary()}\nz = {np.round(cmp_.z, 2).tolist()}"


# ---------------------------------------------------------------------------------------------------
# Negative controls: the same test (same RES, RUNS, SPP, reference, alpha_test) must reject them.
# ---------------------------------------------------------------------------------------------------

@wp.func
def reuse_stratum_1d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
                     spp: wp.uint32) -> float:
    # The stratified point set with one bug: the last stratum is never sampled, the first twice.
    n = wp.max(spp, wp.uint32(1))
    s = stratum(seed, pixel, index, dim, n)
    if s == n - wp.uint32(1):
        s = wp.uint32(0)
    return place(s, unit_float(hash_key(seed, pixel, index, dim ^ JITTER)), n)


@wp.func
def reuse_stratum_2d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
                     spp: wp.uint32) -> wp.vec2:
    n = wp.max(spp, wp.uint32(1))
    nx = grid_columns(n)
    ny = n / nx
    s = stratum(seed, pixel, index, dim, n)
    if s == n - wp.uint32(1):
        s = wp.uint32(0)
    h = hash_key(seed, pixel, index, dim ^ JITTER)
    jx = unit_float(h)
    jy = unit_float(mix32(h))
    return wp.vec2(place(s % nx, jx, nx), place(s / nx, jy, ny))


REUSE = PointSet("stratified_reuse", "stratified with the last stratum replaced by the first (bug)",
                 reuse_stratum_1d, reuse_stratum_2d)

# name -> (scene, integrator, sampler, faults, overrides); each on a scene where the fault matters.
CONTROLS = {
    "drop_cosine": ("cornell-box", "path", "importance", ("drop_cosine",), {}),
    "pdf_high_10pct": ("cornell-box", "path", "importance", ("pdf_high_10pct",), {}),
    "rr_no_reweight": ("cornell-box", "path", "importance", ("rr_no_reweight",),
                       {"scene.russian_roulette": True, "scene.rr_depth": 1}),
    "light_jacobian": ("cornell-box", "path", "uniform", ("light_jacobian",), {}),
    "stratum_reused": ("cornell-box", "path", "stratified_reuse+uniform", (), {}),
}


def test_every_fault_has_a_control():
    assert set(FAULTS) <= {c[3][0] for c in CONTROLS.values() if c[3]}


@pytest.mark.parametrize("name", list(CONTROLS))
def test_negative_control_is_rejected(name, monkeypatch):
    scene, integrator, sampler, faults, overrides = CONTROLS[name]
    monkeypatch.setitem(registry.POINTSETS, REUSE.name, REUSE)
    # The reference is the matrix's (no roulette: roulette with reweighting has the same mean).
    ref = reference(scene, integrator)
    sc = load_scene(scene, overrides=overrides or None)
    clean = render_estimate(sc, sampler if name != "stratum_reused" else "stratified", integrator,
                            SPP, RUNS, ("control-clean", name), res=RES, block=BLOCK)
    bad = render_estimate(sc, sampler, integrator, SPP, RUNS, ("control", name), res=RES,
                          block=BLOCK, faults=faults)
    c_clean, c_bad = compare(clean, ref, ALPHA_TEST), compare(bad, ref, ALPHA_TEST)
    print(f"\nnegative control {name}: clean {c_clean.summary()}\n"
          f"negative control {name}: fault {c_bad.summary()}")
    assert not c_clean.rejected, f"the estimator without the fault must pass: {c_clean.summary()}"
    assert c_bad.rejected, f"the fault {name} must be rejected: {c_bad.summary()}"


# ---------------------------------------------------------------------------------------------------
# Cook's pre-sampled table (estimators/pointsets/presampled.py): the fixed table is biased by design
# (the same 16 directions for every pixel and seed), its per-pixel randomised twin is not.
# ---------------------------------------------------------------------------------------------------

PRESAMPLED_CASE = ("glossy", "drt")


def test_presampled_table_is_rejected():
    scene, integrator = PRESAMPLED_CASE
    assert registry.POINTSETS["presampled"].biased
    assert not registry.POINTSETS["presampled_random"].biased
    c_fixed, est_fixed = agreement(scene, integrator, "presampled+importance")
    c_random, est_random = agreement(scene, integrator, "presampled_random+importance")
    print(f"\npresampled (fixed table): {c_fixed.summary()}\n"
          f"presampled_random (per-pixel table): {c_random.summary()}")
    for est in (est_fixed, est_random):
        assert est.nonfinite == 0 and est.negative == 0
    assert not c_random.rejected, f"the randomised table must pass: {c_random.summary()}"
    assert c_fixed.rejected, f"the fixed (biased) table must be rejected: {c_fixed.summary()}"
