"""Experiment files: the shipped ones parse, bad ones fail with one line naming the field, exit 2, and
nothing written."""
import os
import subprocess
import sys

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pathlib import Path

from drtlab.experiments.study.config import builtin_experiments, load_experiment
from fakes import FakeRenderer
from drtlab.experiments.seeds import GT_BIT, gt_seed, run_seed
from drtlab.errors import InputError

FAKE = FakeRenderer()

GOOD = """
[experiment]
description = "tiny"
seed = 3
spp = [1, 4, 16]
repetitions = 2
resolution = [16, 12]
gt_spp = 1024
gt_batch_spp = 128

[[study]]
name = "s"
scenes = ["aa-edges", "glossy"]
samplers = ["uniform", "stratified"]

[profile.full]
spp = [1, 4, 16, 64]
"""


def write(tmp_path, text, name="exp.toml"):
    p = tmp_path / name
    p.write_text(text)
    return p


@pytest.mark.parametrize("name", ["stratified", "importance", "uniform", "environment", "all"])
@pytest.mark.parametrize("profile", ["quick", "full"])
def test_shipped_experiments_parse_with_the_real_scenes(name, profile):
    exp = load_experiment(name, profile)
    assert exp.studies
    for st in exp.studies:
        assert st.baseline in st.samplers
        assert len(st.settings.spp) >= 2 and st.settings.repetitions >= 2
        assert st.settings.gt_spp % st.settings.gt_batch_spp == 0


def test_shipped_set_and_stratified_contents():
    assert {"stratified", "importance", "uniform", "all"} <= set(builtin_experiments())
    exp = load_experiment("stratified", check_scenes=False)
    st = exp.studies[0]
    assert st.samplers == ("uniform", "stratified")
    assert {s.label for s in st.scenes} >= {"aa-edges", "soft-shadows", "glossy", "dof", "motion-blur"}
    # Powers of 4 by default: stratified runs on square counts.
    for n in st.settings.spp:
        assert int(round(n ** 0.5)) ** 2 == n
    mis = [s for s in load_experiment("importance", check_scenes=False).studies if s.name == "mis"][0]
    assert set(mis.samplers) == {"importance", "independent+bsdf", "independent+light"}
    names = [s.name for s in load_experiment("all", check_scenes=False).studies]
    assert "stratification" in names and "mis" in names and "uniform" in names


def test_samples_per_cell_sets_runs_along_the_ladder(tmp_path):
    """Equal samples per cell: ceil(samples_per_cell / N) runs, never fewer than `repetitions`; the
    shipped convergence studies use it (320 per cell in the quick profile)."""
    p = write(tmp_path, GOOD.replace("repetitions = 2", "repetitions = 2\nsamples_per_cell = 10"))
    st = load_experiment(str(p), "quick", scene_loader=FAKE.load_scene).studies[0].settings
    assert st.spp == (1, 4, 16) and st.runs_per_spp == [10, 3, 2]
    assert load_experiment(str(write(tmp_path, GOOD)), scene_loader=FAKE.load_scene
                           ).studies[0].settings.runs_per_spp == [2, 2, 2]
    for name in ("stratified", "uniform", "importance"):
        for st in load_experiment(name, check_scenes=False).studies:
            assert st.settings.runs_per_spp == [320, 80, 20, 5], (name, st.name)


def test_profiles_override_experiment_settings(tmp_path):
    p = write(tmp_path, GOOD)
    quick = load_experiment(str(p), "quick", scene_loader=FAKE.load_scene)
    full = load_experiment(str(p), "full", scene_loader=FAKE.load_scene)
    assert quick.studies[0].settings.spp == (1, 4, 16)
    assert full.studies[0].settings.spp == (1, 4, 16, 64)
    assert quick.studies[0].settings.strip_spp == (1, 4, 16)


@pytest.mark.parametrize("edit, field", [
    (("repetitions = 2", "repetitions = 1"), "experiment.repetitions"),
    (("repetitions = 2", "repetitions = 2\nsamples_per_cell = 1"), "experiment.samples_per_cell"),
    (("repetitions = 2", "repetitions = 2\nsamples_per_cell = 4.5"), "experiment.samples_per_cell"),
    (("repetitions = 2", "repetitions = 2\nsamples_per_cell = 5000"), "experiment.samples_per_cell"),
    (("spp = [1, 4, 16]", "spp = [4, 1]"), "experiment.spp[1]"),
    (("spp = [1, 4, 16]", "spp = [1]"), "experiment.spp"),
    (("spp = [1, 4, 16, 64]", "spp = [1, 'x']"), "profile.full.spp[1]"),
    (("gt_spp = 1024", "gt_spp = 1000"), "experiment.gt_spp"),
    (("gt_spp = 1024", "gt_spp = 256"), "experiment.gt_spp"),
    (("seed = 3", "seed = 3\ncolour = 1"), "experiment.colour"),
    (('samplers = ["uniform", "stratified"]', 'samplers = ["uniform", "sobol+nope"]'), "study[0].samplers[1]"),
    (('samplers = ["uniform", "stratified"]', 'samplers = ["uniform", "independent+uniform"]'),
     "study[0].samplers[1]"),
    (('scenes = ["aa-edges", "glossy"]', 'scenes = ["aa-edges", "nope"]'), "study[0].scenes[1]"),
    (('name = "s"', 'name = "s"\nbaseline = "importance"'), "study[0].baseline"),
    (('name = "s"', 'name = "s"\nintegrator = "whitted"'), "study[0].integrator"),
    (('name = "s"', 'name = "s"\nmetric = "psnr"'), "study[0].metric"),
    (('resolution = [16, 12]', 'resolution = [16]'), "experiment.resolution"),
    (('description = "tiny"', ''), "experiment.description"),
    (('[[study]]', '[study]'), "study"),
    (("repetitions = 2", "repetitions = -3"), "experiment.repetitions"),
    (("repetitions = 2", 'repetitions = "two"'), "experiment.repetitions"),
    (("repetitions = 2", "repetitions = true"), "experiment.repetitions"),
    (("repetitions = 2", "repetitions = 2.5"), "experiment.repetitions"),
    (("seed = 3", "seed = -1"), "experiment.seed"),
    (("seed = 3", 'seed = "x"'), "experiment.seed"),
    (("spp = [1, 4, 16]", "spp = [0, 4]"), "experiment.spp[0]"),
    (("spp = [1, 4, 16]", 'spp = "many"'), "experiment.spp"),
    (("gt_spp = 1024", "gt_spp = nan"), "experiment.gt_spp"),
    (("gt_batch_spp = 128", "gt_batch_spp = 0"), "experiment.gt_batch_spp"),
    (("resolution = [16, 12]", "resolution = [0, 12]"), "experiment.resolution[0]"),
    (("resolution = [16, 12]", 'resolution = ["a", 12]'), "experiment.resolution[0]"),
    (('scenes = ["aa-edges", "glossy"]', "scenes = []"), "study[0].scenes"),
    (('samplers = ["uniform", "stratified"]', "samplers = []"), "study[0].samplers"),
    (('samplers = ["uniform", "stratified"]', "samplers = [3]"), "study[0].samplers[0]"),
    (('name = "s"', "name = 5"), "study[0].name"),
])
def test_bad_fields_are_named(tmp_path, edit, field):
    p = write(tmp_path, GOOD.replace(*edit))
    with pytest.raises(InputError) as e:
        load_experiment(str(p), scene_loader=FAKE.load_scene)
    assert e.value.field == field, str(e.value)
    assert "\n" not in str(e.value)


def test_unknown_profile_and_file(tmp_path):
    p = write(tmp_path, GOOD)
    with pytest.raises(InputError) as e:
        load_experiment(str(p), "publication", scene_loader=FAKE.load_scene)
    assert e.value.field == "profile" and "full" in e.value.message
    with pytest.raises(InputError) as e:
        load_experiment("no-such-experiment")
    assert "stratified" in e.value.message


def test_include_and_cycles(tmp_path):
    write(tmp_path, GOOD, "a.toml")
    write(tmp_path, '[experiment]\ndescription = "b"\ninclude = ["a"]\n', "b.toml")
    exp = load_experiment(str(tmp_path / "b.toml"), scene_loader=FAKE.load_scene)
    assert [s.name for s in exp.studies] == ["s"] and exp.studies[0].experiment == "a"
    write(tmp_path, '[experiment]\ndescription = "c"\ninclude = ["c"]\n', "c.toml")
    with pytest.raises(InputError) as e:
        load_experiment(str(tmp_path / "c.toml"), scene_loader=FAKE.load_scene)
    assert "include" in e.value.field
    write(tmp_path, GOOD.replace("repetitions = 2", "repetitions = 0"), "d.toml")
    write(tmp_path, '[experiment]\ndescription = "e"\ninclude = ["d"]\n', "e.toml")
    with pytest.raises(InputError) as e:
        load_experiment(str(tmp_path / "e.toml"), scene_loader=FAKE.load_scene)
    assert e.value.field == "d.toml:experiment.repetitions"


def test_scene_tables_with_overrides(tmp_path):
    text = GOOD.replace('scenes = ["aa-edges", "glossy"]',
                        'scenes = ["aa-edges", {name = "glossy", overrides = {"scene.max_depth" = 3}, '
                        'label = "glossy-d3"}]')
    exp = load_experiment(str(write(tmp_path, text)), scene_loader=FAKE.load_scene)
    sc = exp.studies[0].scenes[1]
    assert sc.label == "glossy-d3" and sc.overrides_dict == {"scene.max_depth": 3}
    assert sc.key.startswith("glossy-d3~")


def test_seeds_are_reproducible_and_disjoint_from_ground_truth():
    a = run_seed(1, "aa-edges", "stratified", "drt", (48, 36), 16, 0)
    assert a == run_seed(1, "aa-edges", "stratified", "drt", (48, 36), 16, 0)
    seeds = {run_seed(1, "aa-edges", s, "drt", (48, 36), n, r)
             for s in ("uniform", "stratified") for n in (1, 4, 16, 64) for r in range(8)}
    assert len(seeds) == 64 and all(x < GT_BIT for x in seeds)
    gts = {gt_seed("aa-edges", "drt", (48, 36), b) for b in range(64)}
    assert len(gts) == 64 and all(x >= GT_BIT for x in gts)
    assert not seeds & gts


def test_bad_experiment_file_via_cli_exits_2_writes_nothing(tmp_path):
    bad = write(tmp_path, GOOD.replace('"stratified"]', '"stratifed"]'))
    work = tmp_path / "work"
    work.mkdir()
    env = dict(os.environ, DRTLAB_RESULTS=str(work / "results"))
    r = subprocess.run([sys.executable, "-m", "drtlab.cli", "experiment", str(bad)],
                       cwd=work, env=env, capture_output=True, text=True, timeout=120)
    assert r.returncode == 2, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "study[0].samplers[1]" in lines[0], r.stderr
    assert list(work.iterdir()) == []


def test_scene_paths_are_relative_to_the_experiment_file(tmp_path, monkeypatch):
    from drtlab.kernels.scene_model.scene_file import BUILTIN_DIR
    src = BUILTIN_DIR / "aa-edges.toml"
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "mine.toml").write_text(src.read_text())
    write(tmp_path / "sub", GOOD.replace('"aa-edges"', '"mine.toml"'))
    monkeypatch.chdir(tmp_path)
    exp = load_experiment(str(tmp_path / "sub" / "exp.toml"))
    sc = exp.studies[0].scenes[0]
    assert sc.label == "mine" and Path(sc.name).is_absolute()


_LITERALS = ['"x"', "-1", "0", "1", "2.5", "nan", "inf", "-inf", "true", "[]", "[1, \"a\"]",
             "[[1]]", "{a = 1}", "1e400", '""', "[-4, 0]"]
_VALUE_LINES = [i for i, line in enumerate(GOOD.splitlines()) if " = " in line]


@settings(max_examples=200, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(line=st.sampled_from(_VALUE_LINES), literal=st.sampled_from(_LITERALS),
       second=st.sampled_from([None] + _VALUE_LINES), literal2=st.sampled_from(_LITERALS))
def test_fuzzed_experiment_files_fail_cleanly(tmp_path, line, literal, second, literal2):
    # Replace one or two values of a valid file by arbitrary TOML literals: the loader either
    # accepts the result or raises one single-line InputError naming a field; nothing else escapes.
    lines = GOOD.splitlines()
    for i, lit in ((line, literal), (second, literal2)):
        if i is not None:
            lines[i] = lines[i].split(" = ")[0] + " = " + lit
    p = write(tmp_path, "\n".join(lines), name="fuzz.toml")
    try:
        load_experiment(str(p), scene_loader=FAKE.load_scene)
    except InputError as e:
        assert e.field and "\n" not in str(e)
