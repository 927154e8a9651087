"""Chi-square tests of the environment light's samplers (kernels/environment.py) with the harness in
experiments/stats/chi2/ (EnvironmentAdapter, LatLongDomain).

Each test draws N = 10^6 directions with the Warp sampler and compares them by Pearson's test with
the density claimed *independently of the Warp code*: for the image sampler the exact float64
density of kernels/scene_model/environment_map.py (texel func / mean func / (2 pi^2 sin theta)), for the uniform
and cosine samplers 1/(4 pi) and max(0, cos)/pi. The grid is the lat-long square with cells that
are whole texels (4 x 4 cells per texel), where the midpoint rule integrates a piecewise-constant
map's density exactly. alpha = 0.01, Sidak-corrected over the N_TESTS tests of this file (the
negative control is judged at the same level).

Besides the chi-square test: the pdf a sample carries equals the exact density at the sample, and
env_pdf (what MIS evaluates at an escape) equals it at directions drawn uniformly.

Negative control: the image sampler's tables built without the sin(theta) weight (func = luminance
alone), against the exact density of the right tables: it must be rejected.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from drtlab.experiments.stats import chi2 as C
from drtlab.experiments.stats.chi2.environment_adapter import EnvironmentAdapter, device_tables
from drtlab.kernels.scene_model.environment_map import (EnvironmentMap, direction_pdf, procedural,
                                            sampling_tables)

N = 1_000_000
PER_TEXEL = 4
N_TESTS = 5     # the two image maps, uniform, cosine, and the negative control's level


def sky_with_sun() -> EnvironmentMap:
    """A 16 x 8 gradient sky with one texel 50x brighter than the zenith: a peaked density."""
    img = procedural("gradient", 8, 16, zenith=np.array([0.2, 0.4, 1.0]),
                     horizon=np.array([1.0, 1.0, 1.0]), nadir=np.array([0.1, 0.1, 0.1]))
    img[2, 11] += 50.0
    return EnvironmentMap("gradient", img, "test")


def rough_map() -> EnvironmentMap:
    """A 12 x 6 map of log-normal texels with a black row and a black texel (zero-mass bins the
    binary searches must never land in)."""
    rng = np.random.default_rng(7)
    img = np.exp(rng.normal(0.0, 1.0, (6, 12, 3)))
    img[4] = 0.0
    img[1, 3] = 0.0
    return EnvironmentMap("image", img, "test")


MAPS = {"sky-with-sun": sky_with_sun, "rough": rough_map}


def latlong_test(env: EnvironmentMap, sampler, pdf, name, sample_count=N):
    return C.ChiSquareTest(C.LatLongDomain(), sampler, pdf, sample_count=sample_count,
                           res=(env.height * PER_TEXEL, env.width * PER_TEXEL), seed=len(name),
                           name=name)


@pytest.mark.parametrize("name", list(MAPS))
def test_image_sampler_matches_exact_pdf(name):
    env = MAPS[name]()
    a = EnvironmentAdapter("image")
    sd = device_tables(env)
    n_axis = (0.0, 1.0, 0.0)
    res = latlong_test(env, a.sampler(sd, n_axis), lambda p: direction_pdf(env.image, p),
                       f"image-{name}").run(C.ALPHA, N_TESTS)
    print(res.summary())
    assert res.passed, res.summary()
    assert abs(res.integral - 1.0) < 1e-9
    # The pdf each sample carries (and env_pdf, MIS's density) against the exact one.
    s = a.sample(sd, n_axis, 100_000, seed=3)
    assert s.valid.all()
    exact = direction_pdf(env.image, s.wi)
    assert np.all(exact > 0.0), "a sample landed in a texel of zero density"
    rel = C.relative_error(s.pdf, exact)
    # float32 angles put a sample across a texel edge about once in 10^5 (then its carried pdf
    # is the neighbour's, as MIS evaluates it at an escape).
    assert np.mean(rel > 1e-4) < 1e-3 and np.median(rel) < 1e-5
    rng = np.random.default_rng(1)
    d = rng.normal(size=(20_000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    assert np.mean(C.relative_error(a.pdf(sd, n_axis)(d), direction_pdf(env.image, d)) > 1e-4) < 1e-3


@pytest.mark.parametrize("sampler", ["uniform", "cosine"])
def test_uniform_and_cosine_samplers(sampler):
    env = sky_with_sun()
    a = EnvironmentAdapter(sampler)
    sd = device_tables(env)
    n_axis = np.array([0.3, 0.5, -0.8]) / np.linalg.norm([0.3, 0.5, -0.8])

    def exact(p):
        if sampler == "uniform":
            return np.full(len(p), 1.0 / (4.0 * math.pi))
        p = p / np.linalg.norm(p, axis=1, keepdims=True)
        return np.maximum(0.0, p @ n_axis) / math.pi

    res = latlong_test(env, a.sampler(sd, n_axis), exact, f"env-{sampler}").run(C.ALPHA, N_TESTS)
    print(res.summary())
    assert res.passed, res.summary()
    s = a.sample(sd, n_axis, 20_000, seed=5)
    assert np.max(C.relative_error(s.pdf[s.valid], exact(s.wi[s.valid]))) < 1e-4


def test_missing_sin_jacobian_is_rejected():
    env = sky_with_sun()
    a = EnvironmentAdapter("image")
    wrong = device_tables(env, sampling_tables(env.image, sin_weight=False))
    res = latlong_test(env, a.sampler(wrong, (0.0, 1.0, 0.0)), lambda p: direction_pdf(env.image, p),
                       "image-without-sin").run(C.ALPHA, N_TESTS)
    print(res.summary())
    assert res.rejected, res.summary()
