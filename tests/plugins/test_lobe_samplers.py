"""Lobe samplers from plugins (kernels/lobe_samplers.py, examples/plugins/defensive_phong.py): a
strategy composed with one renders like a built-in, compiled out where the scene lacks its kind; its
scorecard (`drtlab check`) passes for the defensive mixture and fails, with its p-values, for a pdf
10% off (the negative control); bad registrations are one line. The scorecard's level: 0.01,
Sidak-corrected over its tests; fixed seeds."""
import numpy as np
import pytest

import drtlab
from drtlab.cli import main
from drtlab.errors import InputError
from drtlab.estimators import plugins

from plugin_sources import COSINE_OFF_BY_10
from repo_paths import PLUGIN_EXAMPLES

DEFENSIVE = PLUGIN_EXAMPLES / "defensive_phong.py"


def test_the_defensive_sampler_passes_its_scorecard_from_the_command_line(tmp_path, capsys):
    rc = main(["--plugin", str(DEFENSIVE), "check", "defensive-phong", "--out", str(tmp_path / "c.json")])
    out = capsys.readouterr().out
    assert rc == 0, out
    for line in ("directions", "directional albedo", "hard cases", "sampling cost"):
        assert line in out


def test_a_pdf_off_by_ten_percent_fails_with_its_p_values(tmp_path, clean_registry):
    from drtlab.experiments.checks import lobe_sampler
    (tmp_path / "off.py").write_text(COSINE_OFF_BY_10)
    plugins.load_plugin(tmp_path / "off.py")
    card = lobe_sampler.check("cosine-off", seed=0)
    verdict = {x.name: x for x in card.lines}
    assert not card.passed
    # The weights are f|cos|/pdf: 10% low at every angle, far beyond the noise of 200k samples.
    assert verdict["directional albedo"].passed is False and verdict["directional albedo"].p < 1e-6
    assert verdict["directions"].passed is False
    assert verdict["renderer unbiasedness"].passed is False


def test_the_composed_strategy_renders_and_compiles_out_where_its_kind_is_absent(clean_registry):
    plugins.load_plugin(DEFENSIVE)
    # aa-edges has no glossy material: the composed strategy is the built-in one, bit for bit.
    scene = drtlab.load_scene("aa-edges", {"scene.resolution": [16, 12]})
    assert np.array_equal(drtlab.render(scene, spp=4, sampler="stratified+importance-defensive", seed=2),
                          drtlab.render(scene, spp=4, sampler="stratified+importance", seed=2))
    glossy = drtlab.load_scene("glossy", {"scene.resolution": [16, 12]})
    a = drtlab.render(glossy, spp=4, sampler="stratified+importance-defensive", seed=2)
    b = drtlab.render(glossy, spp=4, sampler="stratified+importance", seed=2)
    assert np.all(np.isfinite(a)) and np.all(a >= 0) and not np.array_equal(a, b)


def test_an_edited_sampler_changes_the_strategy_fingerprint(tmp_path, clean_registry):
    from drtlab.estimators.strategies import STRATEGIES
    src = DEFENSIVE.read_text()
    (tmp_path / "d.py").write_text(src)
    plugins.load_plugin(tmp_path / "d.py")
    before = STRATEGIES["importance-defensive"].fingerprint
    (tmp_path / "d.py").write_text(src.replace("0.5 * cos_i * INV_PI", "(0.5 * cos_i) * INV_PI"))
    plugins.load_plugin(tmp_path / "d.py")
    assert STRATEGIES["importance-defensive"].fingerprint != before


@pytest.mark.parametrize("change, words", [
    (lambda t: t.replace('"diffuse",\n', '"mirror",\n'), "kind must be one of"),
    (lambda t: t.replace("wi: wp.vec3) -> float", "wi: float) -> float"), "pdf must take"),
    (lambda t: t.replace("u: wp.vec2) -> Scatter", "u: wp.vec2) -> wp.vec3"), "sample must return"),
    (lambda t: t.replace("def cosine_pdf(mat: MaterialAt,", "def cosine_pdf(mat: wp.vec3,"), "pdf must take"),
])
def test_bad_lobe_samplers_are_one_line(clean_registry, tmp_path, change, words):
    (tmp_path / "bad.py").write_text(change(COSINE_OFF_BY_10))
    with pytest.raises(InputError) as e:
        plugins.load_plugin(tmp_path / "bad.py")
    assert words in e.value.message and "\n" not in e.value.message


@pytest.mark.parametrize("kwargs, words", [
    (dict(like="importance", lobe_samplers=["nope"]), "unknown lobe sampler 'nope'"),
    (dict(like="importance", lobe_samplers=["defensive-phong", "defensive-phong"]), "one per kind"),
    (dict(like="uniform", lobe_samplers=["defensive-phong"]), "must sample BSDF lobes"),
    (dict(like="importance", lobe_samplers="defensive-phong"), "must be a list"),
])
def test_bad_compositions_are_one_line(clean_registry, kwargs, words):
    plugins.load_plugin(DEFENSIVE)
    with pytest.raises(InputError) as e:
        drtlab.register_strategy("composed", "a test", **kwargs)
    assert words in e.value.message and "\n" not in e.value.message
