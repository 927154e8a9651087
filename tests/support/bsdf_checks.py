"""Checks every BSDF sampler's samples must pass (tests/kernels/test_plastic.py, test_ggx.py)."""
import dataclasses
import math

import numpy as np
from scipy import stats

from drtlab.experiments.stats import chi2 as C


def assert_consistent(s: C.BSDFSamples, label: str, tol: float = 1e-4, delta: bool = False):
    """No delta lobe (unless `delta`: a mirror beside the density, smooth_plastic.py); each valid
    non-delta sample's pdf is pdf_bsdf's and its weight eval_bsdf / pdf."""
    v = s.valid & ~s.delta
    assert v.any() and (delta or not s.delta.any()), label
    assert C.relative_error(s.pdf[v], s.pdf_eval[v]).max() <= tol, f"{label}: pdf vs pdf_bsdf"
    err = C.relative_error(s.weight[v], s.f_eval[v] / s.pdf[v][:, None])
    assert err.max() <= tol, f"{label}: weight vs eval_bsdf / pdf"
    assert np.all(s.pdf[v] > 0) and np.all(np.isfinite(s.weight[v])) and np.all(s.weight[v] >= 0)


def assert_albedo_with_controls(cid: str, model, mean: float, se: float, controls: dict, level: float):
    """The samples' mean weight `mean` (standard error `se`) is the model's directional albedo at
    two-sided `level`; each control (a dataclasses.replace of the model: a deliberately wrong one)
    is far enough from the truth to be detectable, and is rejected."""
    ref = model.albedo_value()
    z_crit = stats.norm.isf(level / 2)
    z = (mean - ref) / se
    print(f"{cid}: albedo {ref:.6f}, mean weight {mean:.6f} +- {se:.2e}, z = {z:.2f}")
    assert abs(z) < z_crit, f"{cid}: albedo {ref:.6f} vs {mean:.6f} +- {se:.2e}: z = {z:.2f}"
    for name, change in controls.items():
        wrong = dataclasses.replace(model, **change).albedo_value()
        assert abs(wrong - ref) / se >= z_crit + stats.norm.isf(0.01), f"{cid}/{name}: design"
        assert abs(mean - wrong) / se >= z_crit, f"{cid}: negative control '{name}' not rejected"


def microfacet_chi2(ad: C.BSDFAdapter, case, name: str, n: int, tests: int, seed: int, cap_alpha=None):
    """The chi-square harness on `n` samples of `case` (kind, albedo, alpha, ior, normal, wo) from
    adapter `ad`, after the consistency checks: over the sphere, or with `cap_alpha` over the cap of
    8 alpha about the mirror direction (the rest cell holds the tail); Sidak over `tests`. Returns
    (samples, result)."""
    import math
    s = ad.sample(case, n, seed)
    assert_consistent(s, name)
    normal, wo = np.asarray(case[4], float), np.asarray(case[5], float)
    if cap_alpha is not None:
        refl = 2 * (wo @ normal) * normal - wo
        domain = C.CapDomain(refl, 1.0 - math.cos(8.0 * cap_alpha))
    else:
        domain = C.SphericalDomain(normal)
    r = C.run_chi2(domain, lambda k, sd: (s.wi, s.valid), ad.pdf(case), name=name, sample_count=n,
                   res=(101, 202), seed=seed + 1, test_count=tests)
    assert r.passed, r.summary()
    return s, r


def albedo_estimate(s: C.BSDFSamples) -> tuple[np.ndarray, np.ndarray]:
    """Per channel: (mean, standard error) of the sampled weights, an invalid sample counting 0, so
    the mean estimates the directional albedo."""
    w = np.where(s.valid[:, None], s.weight.astype(np.float64), 0.0)
    return w.mean(axis=0), w.std(axis=0, ddof=1) / math.sqrt(len(w))
