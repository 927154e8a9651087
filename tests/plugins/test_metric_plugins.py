"""A user's error metric (experiments/error_metrics, `drtlab.register_metric`): a plugin computing
the plain MSE gives the built-in MSE's cells, its values are stored beside every run, an edited
metric re-scores (re-renders) its runs, a finished folder reads back without the plugin, and bad
metrics are one line naming the plugin (negative controls: not an error, wrong shape, NaN)."""
import numpy as np
import pytest

import drtlab
from drtlab.errors import InputError
from drtlab.estimators import plugins
from drtlab.experiments.error_metrics import METRICS
from drtlab.experiments.study.config import load_experiment
from drtlab.experiments.study.run_store import load_records
from drtlab.experiments.study.runner import run_experiment
from fakes import fake_backend

from repo_paths import PLUGIN_EXAMPLES

METRIC = '''
import numpy as np
import drtlab


def plain(images, reference, stderr):
    d = images - reference
    return np.mean(d * d, axis=(1, 2, 3)) - np.mean(np.square(stderr)){EDIT}


drtlab.register_metric("plain-mse", plain, "the MSE again, from a plugin", label="plain RMSE")
'''
TINY = """
[experiment]
description = "a plugin metric against the built-in"
plugins = ["metric.py"]
seed = 3
spp = [1, 4, 16]
repetitions = 3
resolution = [16, 12]
gt_spp = 1024
gt_batch_spp = 128

[[study]]
name = "builtin"
scenes = ["aa-edges"]
samplers = ["uniform", "stratified"]

[[study]]
name = "plugin"
scenes = ["aa-edges"]
samplers = ["uniform", "stratified"]
metric = "plain-mse"
"""


def _run(tmp_path, edit: str = ""):
    (tmp_path / "metric.py").write_text(METRIC.replace("{EDIT}", edit))
    (tmp_path / "exp.toml").write_text(TINY)
    backend, fake = fake_backend()
    exp = load_experiment(str(tmp_path / "exp.toml"), scene_loader=fake.load_scene)
    return run_experiment(exp, out_dir=tmp_path / "out", gt_root=tmp_path / "gt", backend=backend,
                          progress=False, log=lambda m: None, analyze=True)


def test_a_plugin_mse_scores_as_the_built_in_and_reads_back_without_the_plugin(tmp_path, clean_registry):
    result = _run(tmp_path)
    records = load_records(tmp_path / "out")
    got = np.array([r["metric:plain-mse"] for r in records.values()])
    want = np.array([r["mse_corrected"] for r in records.values()])
    assert len(got) == 2 * (3 * 3) and np.allclose(got, want, rtol=1e-10, atol=1e-15)
    builtin, plugin = result.summary.studies
    assert plugin.metric_label == "plain RMSE"
    for a, b in zip(builtin.scenes[0].cells, plugin.scenes[0].cells):
        for x, y in ((a.error_mse("mse"), b.error_mse("plain-mse")), (a.error("mse"), b.error("plain-mse"))):
            assert np.allclose([x.mean, x.lo, x.hi], [y.mean, y.lo, y.hi], rtol=1e-9)
        assert np.isclose(a.efficiency_of("mse"), b.efficiency_of("plain-mse"), rtol=1e-9)
    del METRICS["plain-mse"]
    plugins._loaded.clear()
    back = drtlab.open_results(tmp_path / "out")
    cell = back.summary.studies[1].scenes[0].cells[-1]
    assert cell.error("plain-mse") == plugin.scenes[0].cells[-1].error("plain-mse")


def test_an_edited_metric_rescores_its_runs_and_an_unchanged_one_reuses_them(tmp_path, clean_registry):
    first = _run(tmp_path)
    assert first.stats["runs_new"] == 18
    again = _run(tmp_path)
    assert again.stats["runs_new"] == 0
    edited = _run(tmp_path, edit=" * 1.0")
    assert edited.stats["runs_new"] == 18


@pytest.mark.parametrize("body, words", [
    ("return np.ones(len(images))", "must measure an error"),                     # not an error
    ("return np.zeros(3)", "must return 2 finite values"),
    ("return np.full(len(images), np.nan)", "2 non-finite"),
    ("raise RuntimeError('boom')", "raised RuntimeError: boom"),
])
def test_bad_metrics_are_one_line_naming_the_plugin(tmp_path, clean_registry, body, words):
    path = tmp_path / "bad.py"
    path.write_text("import numpy as np\nimport drtlab\n\n\ndef bad(images, reference, stderr):\n"
                    f"    {body}\n\n\ndrtlab.register_metric('bad-metric', bad)\n")
    with pytest.raises(InputError) as e:
        plugins.load_plugin(path)
    assert "bad.py" in e.value.field and words in e.value.message and "\n" not in str(e.value)
    assert "bad-metric" not in METRICS


@pytest.mark.parametrize("name, fn, words", [
    ("mse", lambda i, r, s: np.zeros(len(i)), "built-in metric"),
    ("Bad Name", lambda i, r, s: np.zeros(len(i)), "lower-case"),
    ("fine", "not a function", "must be a function"),
])
def test_registration_checks_name_and_function(clean_registry, name, fn, words):
    with pytest.raises(InputError) as e:
        drtlab.register_metric(name, fn)
    assert words in e.value.message
    assert METRICS["mse"].per_run is None


def test_the_example_edge_metric_measures_the_edges(clean_registry):
    p = plugins.load_plugin(PLUGIN_EXAMPLES / "edge_mse.py")
    assert p.registered == ("metric:edge-mse",)
    ref = np.zeros((20, 20, 3))
    ref[:, 10:] = 1.0                                       # one vertical edge
    noisy_flat, noisy_edge = ref.copy(), ref.copy()
    noisy_flat[:, :5] += 0.5                                # error away from the edge: not counted
    noisy_edge[:, 9:11] += 0.5
    v = METRICS["edge-mse"].score(np.stack([ref, noisy_flat, noisy_edge]), ref, np.zeros_like(ref))
    assert v[0] == 0.0 and v[1] == 0.0 and v[2] > 0.0
    # the reference's own variance on the edges is removed
    se = np.full_like(ref, 0.1)
    assert np.isclose(METRICS["edge-mse"].score(ref[None], ref, se)[0], -0.01)
