"""The notebook surface: `import drtlab` stays light, scenes and experiments from dicts, tidy
DataFrames from `run_experiment`, and the documented example study run end to end."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import drtlab
from drtlab.errors import InputError
from drtlab.experiments.examples import python_study as example_python_study


def test_import_drtlab_loads_no_warp():
    code = "import sys, drtlab, drtlab.kernels.scene_model.scene_file; print('warp' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_scene_from_a_dict_with_overrides_renders_like_the_file(tmp_path):
    from cli_util import GOOD_SCENE
    import tomllib
    as_dict = tomllib.loads(GOOD_SCENE)
    path = tmp_path / "good.toml"
    path.write_text(GOOD_SCENE)
    overrides = {"materials.grey.albedo": [0.8, 0.2, 0.2]}
    from_dict = drtlab.load_scene(as_dict, overrides)
    from_file = drtlab.load_scene(str(path), overrides)
    assert from_dict.materials[0].albedo.tolist() == [0.8, 0.2, 0.2]
    a = drtlab.render(from_dict, spp=4, seed=1)
    b = drtlab.render(from_file, spp=4, seed=1)
    assert np.array_equal(a, b)
    with pytest.raises(InputError) as e:
        drtlab.load_scene(as_dict, {"shapes[0].radius": -1.0})
    assert e.value.field == "shapes[0].radius"


def test_experiment_dict_needs_a_folder_name():
    with pytest.raises(InputError) as e:
        drtlab.run_experiment(example_python_study.STUDY, name="no/slashes")
    assert e.value.field == "name"


def test_example_study_runs_and_its_tables_are_tidy(tmp_path, capsys):
    out = tmp_path / "study"
    assert example_python_study.main(["--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "figure redrawn" in printed and (out / "redrawn-convergence.png").stat().st_size > 1000
    result = drtlab.run_experiment(example_python_study.STUDY, name="example-python-study",
                                   out_dir=out, gt_root=out / "ground-truth", progress=False,
                                   allow_other_files=True)   # the example's own figure is there
    assert result.stats["runs_new"] == 0                     # everything reused: a resume
    assert (out / "redrawn-convergence.png").is_file()
    runs, cells, slopes = result.runs, result.cells, result.slopes
    setup = example_python_study.STUDY["experiment"]
    scenes = example_python_study.STUDY["study"][0]["scenes"]
    n_cells = len(scenes) * 2 * len(setup["spp"])
    assert len(runs) == n_cells * setup["repetitions"]
    assert len(cells) == n_cells and len(slopes) == len(scenes) * 2
    assert set(cells["spp"]) == set(setup["spp"])
    assert (cells["error_lo"] <= cells["error"]).all() and (cells["error"] <= cells["error_hi"]).all()
    assert (cells["error_lo"] > 0).all(), "intervals of a positive error stay positive"
    # The cells table and runs.csv agree: mean per-run RMSE is the mean of the runs' rmse column.
    for (scene, sampler, spp), group in runs.groupby(["scene", "sampler", "spp"]):
        row = cells[(cells.scene == scene) & (cells.sampler == sampler) & (cells.spp == spp)]
        assert np.isclose(row["mean_run_rmse"].item(), group["rmse"].mean(), rtol=1e-12)
    figure = result.plot_convergence()
    assert len(figure.axes) >= len(scenes)


@pytest.mark.parametrize("call, field", [
    (lambda tmp: drtlab.render(None), "scene"),
    (lambda tmp: drtlab.load_scene(42), "scene"),
    (lambda tmp: drtlab.run_experiment(example_python_study.STUDY, name="api-bad-out",
                                       out_dir=tmp / "a-file"), "out_dir"),
])
def test_bad_api_arguments_name_their_field(tmp_path, call, field):
    (tmp_path / "a-file").write_text("not a folder")
    with pytest.raises(InputError) as e:
        call(tmp_path)
    assert e.value.field == field
    assert (tmp_path / "a-file").read_text() == "not a folder"
