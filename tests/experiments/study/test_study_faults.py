"""What a new user writing plugins and a study saw: a heavy-tailed slope stated and drawn as if it
were resolved, a Reproduce line that failed as printed, a study's integrator replacing a scene
file's own without a word, `drtlab check` passing a set that hardly converges, `drtlab check` of
a metric called unknown. Each test failed before its fix."""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from drtlab.experiments.study.results import FitLine, SlopeFit
from synthetic_study import synthetic_study


def _fit(erratic: bool, resolved: bool = True) -> SlopeFit:
    n = [1.0, 4.0, 16.0, 64.0]
    return SlopeFit(n_points=4, dropped=0, level=0.95, ok=True, slope=-0.23, slope_lo=-0.31,
                    slope_hi=-0.15, resolved=resolved, sigma=2.0, erratic=erratic,
                    line=FitLine(n=n, median=[0.1 * x ** -0.23 for x in n],
                                 lo=[0.05 * x ** -0.23 for x in n], hi=[0.2 * x ** -0.23 for x in n]))


def _study(erratic: bool):
    study = synthetic_study(2, n_scenes=1)
    scene = study.scenes[0]
    slopes = {s: _fit(erratic) for s in study.samplers}
    return replace(study, scenes=[replace(scene, slopes=slopes)])


@pytest.mark.parametrize("erratic", [True, False])
def test_a_heavy_tailed_slope_is_neither_worded_nor_drawn_as_resolved(erratic):
    from drtlab.experiments.study import report as R
    from drtlab.experiments.study.figures import plot_error_vs_spp
    study = _study(erratic)
    findings = "\n".join(R._findings(study))
    fit = study.scenes[0].slopes["sampler-0"]
    assert ("N^-0.23" in findings) is (not erratic), findings
    assert ("b=-0.23" in fit.slope_text()) is (not erratic)
    if erratic:
        assert "heavy" in fit.slope_text() and "do not resolve" in findings
    fig = plot_error_vs_spp(study)
    drawn = [line for ax in fig.axes for line in ax.get_lines()
             if np.allclose(np.asarray(line.get_xdata(), dtype=float), fit.line.n)
             and np.allclose(np.asarray(line.get_ydata(), dtype=float), fit.line.median)]
    assert bool(drawn) is (not erratic)


def test_an_unresolved_slope_is_not_stated_either():
    assert not _fit(False, resolved=False).stated and _fit(False).stated and not _fit(True).stated


# ---------------------------------------------------------------------------------------------------
# Reproduce
# ---------------------------------------------------------------------------------------------------

def test_the_reproduce_command_names_the_file_and_the_output_folder(tmp_path, monkeypatch):
    import shlex
    from drtlab.cli import build_parser
    from drtlab.experiments.study.config import load_experiment
    from drtlab.experiments.study.report_sections import reproduce_command
    (tmp_path / "my study.toml").write_text(
        '[experiment]\ndescription = "d"\nseed = 1\nspp = [1, 4]\nrepetitions = 2\n'
        'resolution = [16, 12]\ngt_spp = 256\ngt_batch_spp = 64\n\n[[study]]\nname = "s"\n'
        'scenes = ["aa-edges"]\nsamplers = ["uniform", "stratified"]\n')
    monkeypatch.chdir(tmp_path)
    exp = load_experiment("my study.toml")
    out = tmp_path / "results here"
    command = reproduce_command(exp, out)
    argv = shlex.split(command)
    assert argv[:2] == ["drtlab", "experiment"]
    args = build_parser().parse_args(argv[1:])             # parses as printed
    assert args.out.resolve() == out.resolve() and args.profile == exp.profile
    monkeypatch.chdir("/")                                 # and names the file from anywhere
    again = load_experiment(args.experiment)
    assert Path(again.path).resolve() == (tmp_path / "my study.toml").resolve()
    assert again.studies == exp.studies
    builtin = load_experiment("stratified")
    assert shlex.split(reproduce_command(builtin, out))[2] == "stratified"
    assert reproduce_command(load_experiment({"experiment": {"description": "d"}, "study": [
        {"name": "s", "scenes": ["aa-edges"], "samplers": ["uniform", "stratified"]}]}), out) is None


# ---------------------------------------------------------------------------------------------------
# A study's integrator over a scene file's own
# ---------------------------------------------------------------------------------------------------

def test_a_study_says_when_its_integrator_replaces_the_scenes_own():
    from drtlab.experiments.study.config import load_experiment
    from drtlab.experiments.study.plan import integrator_notes
    exp = load_experiment({"experiment": {"description": "d"}, "study": [
        {"name": "s", "scenes": ["aa-edges"], "samplers": ["uniform", "stratified"]}]})
    own = {"integrator": "path"}
    backend = SimpleNamespace(load_scene=lambda name, overrides: SimpleNamespace(**own))
    notes = integrator_notes(exp, backend)
    assert len(notes) == 1 and "with integrator drt" in notes[0] and "own path" in notes[0]
    own["integrator"] = "drt"
    assert integrator_notes(exp, backend) == []


def test_a_mitsuba_scene_in_a_study_gets_the_note(tmp_path):
    from drtlab.experiments.study.backend import default_backend
    from drtlab.experiments.study.config import load_experiment
    from drtlab.experiments.study.plan import integrator_notes
    (tmp_path / "s.xml").write_text(
        '<scene version="3.0.0"><integrator type="path"><integer name="max_depth" value="3"/>'
        '</integrator><sensor type="perspective"><film type="hdrfilm"><integer name="width" '
        'value="8"/><integer name="height" value="6"/></film></sensor><shape type="sphere">'
        '<emitter type="area"><rgb name="radiance" value="1, 1, 1"/></emitter></shape></scene>')
    exp = load_experiment({"experiment": {"description": "d"}, "study": [
        {"name": "s", "scenes": [str(tmp_path / "s.xml")], "samplers": ["uniform", "stratified"]}]})
    (note,) = integrator_notes(exp, default_backend())
    assert note.startswith("drtlab: note: study s renders") and "own path" in note


# ---------------------------------------------------------------------------------------------------
# drtlab check
# ---------------------------------------------------------------------------------------------------

# A set whose values sit on a 4 x 4 grid of cell centres: every draw is one of 4 values per
# dimension, so its error stops at the grid's bias and the RMSE stops falling (the negative control).
QUANTIZED = '''
import warp as wp
import drtlab
from drtlab.estimators.hashing import hash_key, unit_float

@wp.func
def q1(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32, spp: wp.uint32) -> float:
    return (wp.floor(unit_float(hash_key(seed, pixel, index, dim)) * 4.0) + 0.5) / 4.0

@wp.func
def q2(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32, spp: wp.uint32) -> wp.vec2:
    return wp.vec2(q1(seed, pixel, index, dim, spp), q1(seed, pixel, index, dim + wp.uint32(1), spp))

drtlab.register_pointset(drtlab.PointSet("quantized", "a 4-level grid of hashed points", q1, q2))
'''


def test_check_convergence_fails_a_set_with_a_bias_floor(tmp_path, clean_registry):
    from drtlab.estimators.plugins import load_plugin
    from drtlab.experiments.checks.pointset import TESTS, convergence
    from drtlab.experiments.checks.scorecard import per_test
    (tmp_path / "quantized.py").write_text(QUANTIZED)
    load_plugin(str(tmp_path / "quantized.py"))
    per_line = per_test(0.01, TESTS)
    bad = {x.name: x for x in convergence("quantized", 0, per_line)}
    good = {x.name: x for x in convergence("independent", 0, per_line)}
    # The disk's edge is what the grid misses: its slope flattens towards 0.
    assert bad["convergence: disk edge"].passed is False and bad["convergence: disk edge"].p < per_line
    assert all(x.passed for x in good.values()), good


def test_check_of_a_metric_says_metrics_have_no_check(capsys, clean_registry):
    import drtlab
    from drtlab.cli import main
    drtlab.register_metric("log-mse", lambda images, reference, stderr: np.log1p(
        np.mean((images - reference) ** 2, axis=(1, 2, 3))))
    for name in ("log-mse", "mse"):
        assert main(["check", name]) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"drtlab: NAME: '{name}' is an error metric") and "unknown" not in err
        assert len(err.splitlines()) == 1


# ---------------------------------------------------------------------------------------------------
# report.html: a plugin metric in the crop table, and a table that fits its panel
# ---------------------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def plugin_metric_report(tmp_path_factory):
    """A tiny study ranked by the example plugin metric (edge MSE), three samplers, on the fake
    renderer: report.html's crop table then has every column it can have."""
    from drtlab.estimators import plugins
    from drtlab.estimators.plugins import load_plugin
    from drtlab.experiments.error_metrics import METRICS
    from drtlab.experiments.study import analysis
    from repo_paths import PLUGIN_EXAMPLES
    from test_runner import TINY, run, tiny_experiment
    tmp = tmp_path_factory.mktemp("plugin-metric-report")
    metrics, loaded = dict(METRICS), dict(plugins._loaded)
    load_plugin(str(PLUGIN_EXAMPLES / "edge_mse.py"))
    text = TINY.replace('samplers = ["uniform", "stratified"]',
                        'samplers = ["uniform", "stratified", "sobol+importance"]\nmetric = "edge-mse"')
    try:
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(analysis, "STUDY_CHAIN", {"nsteps": 200, "burn": 50})
            run(tiny_experiment(tmp, text), tmp / "out", tmp / "gt", analyze=True)
        yield tmp / "out", METRICS["edge-mse"]
    finally:
        METRICS.clear()
        METRICS.update(metrics)
        plugins._loaded.clear()
        plugins._loaded.update(loaded)


def _page_data(out) -> dict:
    import json
    import re
    page = (out / "report.html").read_text()
    return json.loads(re.search(r'<script type="application/json" id="drt-data">(.*?)</script>', page,
                                re.S).group(1).replace("<\\/", "</"))


def test_the_crop_table_carries_a_plugin_metric(plugin_metric_report):
    from drtlab.experiments.study.ground_truth import load_ground_truth
    from drtlab.experiments.study.run_store import first_image
    out, metric = plugin_metric_report
    data = _page_data(out)
    for v in data["studies"][0]:
        assert v["metric"] == "edge MSE"
        gt_dir = next(d for d in (out.parent / "gt").iterdir() if v["scene"] in d.name)
        gt = load_ground_truth(gt_dir)
        rendered = [e for e in v["images"] if e["sampler"] is not None]
        assert len(rendered) == 12
        for e in rendered:           # the plugin's own number for that image, as Python computes it
            want = metric.score(first_image(out, e["key"])[None], gt.mean, gt.stderr)[0]
            assert e["metric"] == pytest.approx(want, rel=1e-12)


def _chromium():
    import shutil
    exe = shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")
    if exe is None:
        pytest.skip("no Chromium on PATH (Debian: apt-get install chromium)")
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        pytest.skip("playwright is not installed (pip install -e '.[dev]')")
    return exe, sync_playwright


@pytest.mark.parametrize("width", [1400, 1000])
def test_the_crop_table_fits_its_panel(plugin_metric_report, width):
    exe, sync_playwright = _chromium()
    out, _ = plugin_metric_report
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=exe, args=["--no-sandbox"])
        page = browser.new_page(viewport={"width": width, "height": 1000})
        page.goto((out / "report.html").as_uri())
        page.wait_for_selector(".viewer table.metrics")
        boxes = page.evaluate("""() => [...document.querySelectorAll('.viewer')].map(v => {
            const t = v.querySelector('table.metrics'), w = t.parentElement;
            return {viewer: v.getBoundingClientRect().right, table: t.getBoundingClientRect().right,
                    wrap: w.getBoundingClientRect().right, heads: t.querySelectorAll('th').length,
                    hidden: w.scrollWidth - w.clientWidth};
        })""")
        browser.close()
    assert boxes and all(b["heads"] == 7 for b in boxes)     # image, 4 of MSE/relMSE, edge MSE, s
    if width >= 1400:                # wide enough: the whole table inside the viewer's panel
        assert all(b["table"] <= b["viewer"] and b["hidden"] <= 0 for b in boxes), boxes
    else:                            # narrower: it scrolls inside the panel, never past it
        assert all(b["wrap"] <= b["viewer"] for b in boxes), boxes
