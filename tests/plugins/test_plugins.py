"""Plugins (drtlab/plugins.py): a user's point set from a file, its fingerprint in every kernel and
run key, the bad plugins' one-line errors, the experiment file's `plugins` list, the entry-point
group and the copy a Dask worker loads."""
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import drtlab
from drtlab.estimators import plugins
from drtlab.errors import InputError
from drtlab.estimators.points import points
from drtlab.estimators.registry import POINTSETS, parse_sampler

from repo_paths import PLUGIN_EXAMPLES


PLUGIN = '''
import warp as wp
import drtlab
from drtlab.estimators.hashing import hash_key, unit_float


@wp.func
def mine_1d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32, spp: wp.uint32) -> float:
    return unit_float(hash_key(seed ^ wp.uint32(SALT), pixel, index, dim)){BAD}


@wp.func
def mine_2d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32, spp: wp.uint32) -> wp.vec2:
    return wp.vec2(mine_1d(seed, pixel, index, dim, spp), mine_1d(seed, pixel, index, dim + wp.uint32(1), spp))


drtlab.register_pointset(drtlab.PointSet("{NAME}", "hashed points", mine_1d, mine_2d))
'''


def _write(path: Path, name: str = "mine", salt: int = 1, bad: str = "") -> Path:
    path.write_text(PLUGIN.replace("SALT", str(salt)).replace("{NAME}", name).replace("{BAD}", bad))
    return path


def test_a_plugin_file_registers_a_set_used_like_a_built_in(tmp_path, clean_registry):
    p = plugins.load_plugin(_write(tmp_path / "mine.py"))
    assert p.registered == ("pointset:mine",) and len(p.sha256) == 64
    assert parse_sampler("mine").pointset.fingerprint
    u = points("mine", 64, 6, seed=3, pixel=9)
    assert u.shape == (64, 6) and (u >= 0).all() and (u < 1).all()
    # the same file again: the same record, nothing imported twice
    assert plugins.load_plugin(tmp_path / "mine.py") is p
    assert any(m["sha256"] == p.sha256 for m in plugins.manifest())


def test_an_edited_plugin_recompiles_and_an_unchanged_one_does_not(tmp_path, clean_registry):
    path = _write(tmp_path / "mine.py", salt=1)
    plugins.load_plugin(path)
    fp1, u1 = POINTSETS["mine"].fingerprint, points("mine", 16, 2, seed=0)
    plugins.load_plugin(path)
    assert POINTSETS["mine"].fingerprint == fp1
    _write(path, salt=2)                                  # the user edits the hash's salt
    plugins.load_plugin(path)
    fp2, u2 = POINTSETS["mine"].fingerprint, points("mine", 16, 2, seed=0)
    assert fp2 != fp1 and not np.array_equal(u1, u2)     # a stale kernel would give u1 again


@pytest.mark.parametrize("case, message", [
    ("missing", "no plugin file"),
    ("empty", "registers nothing"),
    ("crash", "ValueError while importing it at"),
    ("clash", "is a built-in point set"),
    ("codegen", "does not compile at"),
    ("range", "values must lie in [0, 1)"),
    ("signature", "each wp.uint32"),
])
def test_bad_plugins_are_one_line_naming_the_plugin(tmp_path, clean_registry, case, message):
    path = tmp_path / f"{case}.py"
    if case == "empty":
        path.write_text("x = 1\n")
    elif case == "crash":
        path.write_text("import drtlab\nraise ValueError('boom')\n")
    elif case == "clash":
        _write(path, name="sobol")
    elif case == "codegen":
        _write(path, bad=" + not_defined_anywhere")
    elif case == "range":
        _write(path, bad=" + 1.0")
    elif case == "signature":
        path.write_text(PLUGIN.replace("spp: wp.uint32) -> float", "spp: int) -> float")
                        .replace("SALT", "1").replace("{NAME}", "mine").replace("{BAD}", ""))
    with pytest.raises(InputError) as e:
        plugins.load_plugin(path)
    assert message in e.value.message and "\n" not in e.value.message
    if case in ("crash", "codegen", "clash", "range", "signature"):
        assert f"{path}:" in e.value.message          # the user's file and line, not Warp's
    assert "mine" not in POINTSETS


def test_the_command_line_loads_plugins_before_parsing(tmp_path, clean_registry):
    _write(tmp_path / "mine.py")
    env_python = sys.executable
    out = subprocess.run([env_python, "-m", "drtlab.cli", "--plugin", "mine.py", "samplers"], cwd=tmp_path,
                         capture_output=True, text=True)
    assert out.returncode == 0 and "\n  mine " in out.stdout
    bad = subprocess.run([env_python, "-m", "drtlab.cli", "samplers", "--plugin", "nope.py"], cwd=tmp_path,
                         capture_output=True, text=True)
    assert bad.returncode == 2 and bad.stderr.strip() == "drtlab: --plugin: no plugin file 'nope.py'"


def test_an_experiment_lists_plugins_relative_to_its_file(tmp_path, clean_registry):
    from drtlab.experiments.study.config import load_experiment
    _write(tmp_path / "mine.py")
    toml = tmp_path / "exp.toml"
    study = ('[[study]]\nname = "s"\ndescription = "d"\nscenes = ["aa-edges"]\n'
             'samplers = ["uniform", "mine"]\nbaseline = "uniform"\n')
    toml.write_text('[experiment]\ndescription = "x"\nplugins = ["mine.py"]\n' + study)
    exp = load_experiment(str(toml), check_scenes=False)
    assert exp.studies[0].samplers[-1] == "mine+uniform"
    assert any(k.startswith("plugin:") and k.endswith("mine.py") for k in exp.sources)
    toml.write_text('[experiment]\ndescription = "x"\nplugins = ["absent.py"]\n' + study)
    with pytest.raises(InputError) as e:
        load_experiment(str(toml), check_scenes=False)
    assert e.value.field == "experiment.plugins[0]"


def test_runs_of_a_plugin_set_carry_its_fingerprint(tmp_path, clean_registry):
    from drtlab.experiments.study.runner import _Sweep as Runner
    path = _write(tmp_path / "mine.py", salt=1)
    plugins.load_plugin(path)
    fake = type("R", (), {"backend": type("B", (), {"code_version": "abc"})(),
                          "_plugin_metrics": lambda self: []})()
    code = Runner._code
    first = code(fake, "mine")
    assert code(fake, "uniform") == "abc" and first != "abc"
    _write(path, salt=3)
    plugins.load_plugin(path)
    assert code(fake, "mine") not in (first, "abc")


def test_a_worker_loads_the_shipped_copy_of_a_plugin(tmp_path, clean_registry):
    path = _write(tmp_path / "mine.py")
    plugins.load_plugin(path)
    items = [s for s in plugins.shipped() if s[0] == str(path.resolve())]
    assert items and items[0][2] == path.read_text()
    path.unlink()                             # the worker's machine has no such file
    plugins._loaded.clear()
    del POINTSETS["mine"]
    plugins.ensure_shipped(tuple(items))
    assert "mine" in POINTSETS and POINTSETS["mine"].fingerprint
    assert any(p.sha256 == items[0][1] for p in plugins.loaded())


def test_an_installed_package_plugs_in_by_its_entry_point(tmp_path, clean_registry, monkeypatch):
    pkg = tmp_path / "site"
    pkg.mkdir()
    _write(pkg / "my_drtlab_sets.py", name="ep-set")
    dist = pkg / "my_drtlab_sets-1.0.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: my-drtlab-sets\nVersion: 1.0\n")
    (dist / "entry_points.txt").write_text("[drtlab.plugins]\nsets = my_drtlab_sets\n")
    monkeypatch.syspath_prepend(str(pkg))
    monkeypatch.setattr(plugins, "_entry_points_done", False)
    assert "ep-set" in POINTSETS                 # a miss loads the entry points, then finds it
    assert parse_sampler("ep-set").pointset.name == "ep-set"


def test_the_examples_register_their_sets(clean_registry):
    r2 = plugins.load_plugin(PLUGIN_EXAMPLES / "r2.py")
    tab = plugins.load_plugin(PLUGIN_EXAMPLES / "qmc_sobol.py")
    assert r2.registered == ("pointset:r2",) and tab.registered == ("pointset:qmc-sobol",)
    # each pixel's 64 points in x are {frac(i a1 + s)}, i < 64: seen from one of them, every other
    # lies at frac(k a1) for an integer |k| < 64, whatever the pixel's shift and permutation
    a1 = 0.7548776662466927
    lattice = np.mod(np.arange(-63, 64) * a1, 1.0)
    for seed, pixel in ((0, 5), (4, 77)):
        x = points("r2", 64, 2, seed=seed, pixel=pixel)[:, 0]
        d = np.mod(x - x[0], 1.0)
        gap = np.abs(d[:, None] - lattice[None, :])
        assert np.minimum(gap, 1 - gap).min(axis=1).max() < 1e-5
    assert drtlab.load_plugin(PLUGIN_EXAMPLES / "r2.py") is r2


def test_the_example_study_loads_with_its_plugins(clean_registry):
    from drtlab.experiments.study.config import load_experiment
    exp = load_experiment(str(PLUGIN_EXAMPLES / "compare.toml"))
    samplers = {s for st in exp.studies for s in st.samplers}
    assert {"r2+uniform", "qmc-sobol+uniform", "independent+importance-nearest",
            "independent+importance-defensive"} <= samplers
    assert sum(k.startswith("plugin:") for k in exp.sources) == 5
    assert [st.metric for st in exp.studies] == ["mse", "mse", "edge-mse", "mse"]
