"""Chi-square goodness-of-fit tests of sampling routines, in the style of Mitsuba 3's `mitsuba.chi2`.

A `ChiSquareTest` draws `sample_count` (default 10^6) samples from a sampler, histograms them on a 2D
parameter grid of a `Domain`, integrates the density the code *claims* for those samples over every
grid cell to get the expected counts, and runs Pearson's test. The facts carried over from Mitsuba:

* the grid lives in a parameterisation whose measure is the sampler's measure, so no Jacobian
  appears: (cos theta, phi) for directions (d omega = d cos d phi), (x, y) for points (one domain
  here, `ConeDomain`, carries a Jacobian, see below);
* the expected count of a cell is N times the integral of the pdf over the cell, computed by a
  quadrature on an ires x ires sub-grid of the cell (Mitsuba: trapezoid with ires = 4; here the
  midpoint rule with ires = 4, and 32 x 32 in cells at an edge of the pdf's support; with an even
  ires and an odd cell count the horizon cos theta = 0 lies between sub-samples, where the midpoint
  rule integrates a step exactly);
* cells are sorted by expected count and those expecting fewer than 5 samples are pooled together,
  until each pool expects at least 5 (Mitsuba drops a final pool below 5; here it is merged into the
  last pool, so every sample is counted and the multinomial degrees of freedom are cells - 1);
* samples in a cell whose expected count is 0 reject the hypothesis outright (here: unless the cell
  borders the support, where a sliver of support may hide from the quadrature; those samples still
  weigh in the pooled statistic);
* a family of m tests is run at the Sidak-corrected level 1 - (1 - alpha)^(1/m) (alpha = 0.01), so
  that the whole family falsely rejects with probability alpha.

Additions for this project:

* **Defective distributions.** A sampler may fail (a direction under the horizon, a light point
  facing away): it then returns `valid = False`, and the claimed pdf integrates to the valid mass
  P < 1. Invalid samples, and valid ones outside the grid (the tail beyond a zoomed cap), fall into
  one extra "rest" cell expecting N (1 - integral of the pdf over the grid). So a pdf that is right in
  shape but wrong in its normalisation, or a sampler that fails more often than its pdf admits, is
  rejected as well. `result.integral` is the integral of the pdf over the grid (1, or the valid mass).
* **Sharp lobes.** `CapDomain(axis, t_max)` histograms the cap 1 - cos theta <= t_max around a lobe's
  own axis in (t = 1 - cos theta, phi). t of a sample is computed from the components perpendicular
  to the axis, t = s^2 / (1 + sqrt(1 - s^2)), so it keeps full relative precision in float32 even for
  Phong exponents of 10^6 (lobe width ~1e-6 in t); with t_max ~ 20 / (n + 1) the 10^6 samples fill
  the grid's cells as they would for a broad lobe. What limits such tests is the precision of the
  claimed pdf itself: `phong_lobe_pdf(cos, n)` takes cos in float32, whose spacing near 1 is
  2^-24, so its value carries a relative error up to ~n * 3e-8 (3% at n = 10^6); in practice the
  n = 10^6 test still passes and the integral is off by 2e-4.
* **Singular edges.** An area-sampled sphere light has a solid-angle density ~1/cos at the light,
  infinite at its silhouette; `ConeDomain` histograms the cone it subtends in (s, phi) with
  1 - cos theta = omc (1 - s^2), where that density is bounded (Jacobian 2 omc s).
* **Quadrature at support edges.** Cells where the pdf is zero at some sub-samples and not at others,
  and zero cells next to non-zero ones, are integrated again on a refine x finer sub-grid.
* **Warp adapters.** `WarpsAdapter`, `BSDFAdapter` and `LightAdapter` wrap the project's Warp
  functions (estimators/domain_maps.py, kernels/materials/bsdf.py `make_bsdf`, kernels/lights.py `make_lights`)
  in CPU kernels built by factories (`module="unique"`, no backward pass). Each kernel samples over N
  threads with the random numbers `uniform(seed, thread, dim)` = unit_float(hash_key(seed, thread,
  dim, 0)), so results are a pure function of the seed; one runtime-switched kernel per factory
  variant keeps compiles few (1 for the warps, 2 for the BSDFs, 4 for the lights). They also
  report the consistency checks a chi-square test cannot see: the pdf a sample carries against the
  pdf evaluated separately for the same direction, and the weight against f|cos|/pdf.

Modules: `domains` (the parameter grids), `harness` (the test: pooling, ChiSquareTest, run_chi2),
`adapters` (the Warp adapters and upload_scene), `mesh_adapter` (`MeshLightAdapter`: light sampling
of scenes with triangle-mesh emitters), `environment_adapter` (`EnvironmentAdapter`: the environment
light's samplers, histogrammed over `LatLongDomain`, whose cells can be whole texels). Every public name is re-exported here, with `sidak` of
experiments/stats/hypothesis_tests.py, so `from drtlab.experiments.stats import chi2 as C;
C.ChiSquareTest(...)` is the way to use the harness.
"""
from drtlab.experiments.stats.chi2.domains import (CapDomain, ConeDomain, Domain, LatLongDomain,
                                             PlanarDomain, RectangleDomain, SphericalDomain,
                                             orthonormal_frame)
from drtlab.experiments.stats.chi2.harness import (ALPHA, POOL_THRESHOLD, ChiSquareResult, ChiSquareTest,
                                             PdfFunc, SampleFunc, pooled_chi2, relative_error,
                                             run_chi2)
from drtlab.experiments.stats.hypothesis_tests import sidak
from drtlab.experiments.stats.chi2.adapters import (ALL_KINDS, CONE, COSINE_HEMISPHERE, DISK, KIND_INDEX,
                                              PHONG, SQUARE, UNIFORM_HEMISPHERE, UNIFORM_SPHERE,
                                              BSDFAdapter, BSDFSamples, WarpsAdapter, uniform)
from drtlab.experiments.stats.chi2.light_adapter import LightAdapter, LightSamples, upload_scene
from drtlab.experiments.stats.chi2.mesh_adapter import MeshLightAdapter, MeshLightSamples
from drtlab.experiments.stats.chi2.environment_adapter import EnvironmentAdapter, EnvSamples

__all__ = [
    # domains
    "Domain", "SphericalDomain", "CapDomain", "ConeDomain", "PlanarDomain", "LatLongDomain", "RectangleDomain",
    "orthonormal_frame",
    # harness
    "ALPHA", "POOL_THRESHOLD", "sidak", "pooled_chi2", "ChiSquareResult", "ChiSquareTest",
    "SampleFunc", "PdfFunc", "run_chi2", "relative_error",
    # adapters
    "uniform", "UNIFORM_HEMISPHERE", "UNIFORM_SPHERE", "COSINE_HEMISPHERE", "PHONG", "CONE", "DISK",
    "SQUARE", "WarpsAdapter", "KIND_INDEX", "ALL_KINDS", "BSDFSamples", "BSDFAdapter",
    "LightSamples", "LightAdapter", "upload_scene", "MeshLightAdapter", "MeshLightSamples",
    "EnvironmentAdapter", "EnvSamples",
]
