"""A light selection from a plugin (kernels/light_selection.py, examples/plugins/nearest_light.py)
through the chi-square harness the built-ins go through: its pick frequencies and its directions
match the density it claims (with the pmf MIS reads), it renders exactly like the power pick where
there is one light, and a pmf off by 10% (the negative control) is rejected. Significance: 0.01,
Sidak-corrected over the file's 3 chi-square tests; fixed seeds."""
import math

import numpy as np
import pytest
from scipy import stats

import drtlab
from drtlab.errors import InputError
from drtlab.estimators import plugins
from drtlab.experiments.stats import chi2 as C

from plugin_sources import OFF_BY_10
from repo_paths import PLUGIN_EXAMPLES


ALPHA = 0.01
LEVEL = C.sidak(ALPHA, 3)
N = 400_000
X = np.zeros(3)
SPHERE_C, SPHERE_R = np.array([1.5, 0.5, 3.0]), 1.0
QUAD = dict(origin=[-3.0, -1.0, 2.0], edge_u=[0.0, 2.0, 0.0], edge_v=[2.0, 0.0, 0.0])
EMISSION = {"warm": [4.0, 3.0, 2.0], "cool": [1.0, 1.0, 2.0]}
SCENE = {
    "scene": {"description": "two lights", "resolution": [4, 4], "integrator": "path"},
    "camera": {"position": [0, 0, -5], "look_at": [0, 0, 0]},
    "materials": {"warm": {"kind": "emitter", "emission": EMISSION["warm"]},
                  "cool": {"kind": "emitter", "emission": EMISSION["cool"]}},
    "shapes": [{"kind": "sphere", "material": "warm", "center": SPHERE_C.tolist(), "radius": SPHERE_R},
               {"kind": "quad", "material": "cool", **QUAD}]}

def _expected_pmf() -> np.ndarray:
    lum = lambda c: 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
    area_q = np.linalg.norm(np.cross(QUAD["edge_u"], QUAD["edge_v"]))
    power = np.array([lum(EMISSION["warm"]) * 4 * math.pi * SPHERE_R ** 2, lum(EMISSION["cool"]) * area_q])
    centres = [SPHERE_C, np.asarray(QUAD["origin"]) + 0.5 * (np.add(QUAD["edge_u"], QUAD["edge_v"]))]
    w = power / power.sum() / np.array([np.sum((c - X) ** 2) for c in centres])
    return w / w.sum()


def test_the_plugin_selection_samples_what_it_claims(clean_registry):
    p = plugins.load_plugin(PLUGIN_EXAMPLES / "nearest_light.py")
    assert p.registered == ("light_selection:nearest", "strategy:importance-nearest")
    sd = C.upload_scene(SCENE)[0]
    ad = C.LightAdapter(True, "nearest")
    s = ad.sample(sd, X, N, 11)
    pmf = _expected_pmf()
    np.testing.assert_allclose(s.pmf, pmf[s.light], rtol=1e-5)
    counts = np.bincount(s.light, minlength=2)
    assert stats.chisquare(counts, N * pmf).pvalue >= LEVEL, counts
    v = s.valid
    assert np.all(C.relative_error(s.pdf[v], s.pdf_eval[v]) <= 1e-4)       # what MIS evaluates
    r = C.run_chi2(C.SphericalDomain((0.0, 0.0, 1.0)), lambda n, seed: (s.wi, s.valid), ad.pdf(sd, X),
                   name="nearest", sample_count=N, res=(101, 202), seed=12, test_count=3)
    assert r.p_value >= LEVEL, r


def test_a_pmf_off_by_ten_percent_is_rejected(clean_registry, tmp_path):
    (tmp_path / "off.py").write_text(OFF_BY_10)
    plugins.load_plugin(tmp_path / "off.py")
    sd = C.upload_scene(SCENE)[0]
    ad = C.LightAdapter(True, "off-by-10")
    s = ad.sample(sd, X, N, 13)
    r = C.run_chi2(C.SphericalDomain((0.0, 0.0, 1.0)), lambda n, seed: (s.wi, s.valid), ad.pdf(sd, X),
                   name="off-by-10", sample_count=N, res=(101, 202), seed=14, test_count=3)
    assert r.p_value < LEVEL, r


def test_with_one_light_it_renders_as_the_power_pick(clean_registry):
    plugins.load_plugin(PLUGIN_EXAMPLES / "nearest_light.py")
    scene = drtlab.load_scene("soft-shadows", {"scene.resolution": [24, 18]})
    a = drtlab.render(scene, spp=4, sampler="stratified+importance-nearest", seed=2)
    b = drtlab.render(scene, spp=4, sampler="stratified+importance", seed=2)
    assert np.array_equal(a, b)


@pytest.mark.parametrize("change, words", [
    (lambda t: t.replace('"off-by-10"', '"power"'), "built-in light selection"),
    (lambda t: t.replace("li: int) -> float", "li: float) -> float"), "pmf must take"),
])
def test_bad_light_selections_are_one_line(clean_registry, tmp_path, change, words):
    (tmp_path / "bad.py").write_text(change(OFF_BY_10))
    with pytest.raises(InputError) as e:
        plugins.load_plugin(tmp_path / "bad.py")
    assert words in e.value.message and "\n" not in e.value.message
