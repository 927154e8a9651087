"""Commands that could overwrite or misplace the user's files: outputs of one command that would share
a name, empty paths (which Python reads as the current folder), and long commands that state their
cost first and refuse past a limit unless told."""
import numpy as np
import pytest

from cli_util import assert_one_line_error
from drtlab.cli import main


def test_compare_of_two_images_of_one_name_writes_both_pairs(tmp_path, capsys):
    from drtlab.kernels.imageio import read_exr, write_exr
    for d, v in (("same1", 0.5), ("same2", 0.375)):
        (tmp_path / d).mkdir()
        write_exr(tmp_path / d / "img.exr", np.full((4, 6, 3), v), {"sampler": "none"})
    write_exr(tmp_path / "c.exr", np.full((4, 6, 3), 0.25))
    out = tmp_path / "cmp"
    a, b = tmp_path / "same1" / "img.exr", tmp_path / "same2" / "img.exr"
    assert main(["compare", str(a), str(b), "--ref", str(tmp_path / "c.exr"), "--out-dir", str(out)]) == 0
    wrote = capsys.readouterr().out.splitlines()[-1]
    names = wrote.removeprefix("wrote ").split(", ")
    assert len(names) == len(set(names)) == 4
    assert np.all(read_exr(out / "same1_img-vs-c.diff.exr")[0] == np.float32(0.25))
    assert np.all(read_exr(out / "same2_img-vs-c.diff.exr")[0] == np.float32(0.125))
    assert sorted(p.name for p in out.iterdir()) == sorted(
        f"same{i}_img-vs-c.{k}" for i in (1, 2) for k in ("diff.exr", "error.png"))


def test_compare_of_one_image_twice_against_a_reference_is_refused(tmp_path, capsys):
    from drtlab.kernels.imageio import write_exr
    write_exr(tmp_path / "img.exr", np.full((4, 6, 3), 0.5), {"sampler": "none"})
    write_exr(tmp_path / "c.exr", np.full((4, 6, 3), 0.25))
    out = tmp_path / "cmp"
    img = str(tmp_path / "img.exr")
    assert main(["compare", img, img, "--ref", str(tmp_path / "c.exr"), "--out-dir", str(out)]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and not out.exists()
    assert_one_line_error(captured.err, "B")


@pytest.mark.parametrize("flag", ["--spp", "--batch-spp"])
def test_a_reference_for_days_is_estimated_and_refused_before_it_renders(flag, tmp_path, capsys):
    gt = tmp_path / "gt"
    # 2^31 - 1 spp of 64x48 pixels: months at any speed this code reaches (16x12 was 22 h on a fast
    # run, under the 24 h limit)
    rc = main(["ground-truth", "aa-edges", flag, "2147483647", "--res", "64", "--gt-dir", str(gt)])
    err = capsys.readouterr().err.splitlines()
    assert rc == 2
    assert err[-1].startswith("drtlab: --yes: this reference would render for about ") and "h" in err[-1]
    assert any(line.startswith("estimate: about ") for line in err[:-1])       # said first
    assert not (gt.exists() and any(gt.iterdir()))


def test_a_short_reference_says_its_cost_and_renders(tmp_path, capsys):
    gt = tmp_path / "gt"
    assert main(["ground-truth", "aa-edges", "--spp", "16", "--res", "16", "--gt-dir", str(gt)]) == 0
    captured = capsys.readouterr()
    assert captured.err.startswith("estimate: ") and "16 spp" in captured.out
    assert main(["ground-truth", "aa-edges", "--spp", "16", "--res", "16", "--gt-dir", str(gt)]) == 0
    assert "estimate" not in capsys.readouterr().err                        # reused: nothing to render


# ---------------------------------------------------------------------------------------------------
# Empty paths: Python reads '' as the current folder, so each would write where it was not asked to
# ---------------------------------------------------------------------------------------------------

@pytest.fixture
def elsewhere(tmp_path, monkeypatch):
    """A current folder to watch, and the default results root outside it."""
    cwd = tmp_path / "cwd"
    cwd.mkdir()
    monkeypatch.chdir(cwd)
    monkeypatch.setenv("DRTLAB_RESULTS", str(tmp_path / "results"))
    monkeypatch.delenv("DRTLAB_GT_DIR", raising=False)
    return tmp_path


def study_file(tmp_path):
    from fakes import tiny_real_experiment
    p = tmp_path / "study.toml"
    p.write_text(tiny_real_experiment("empty paths", ["soft-shadows"]))
    return str(p)


def refused(argv, field, tmp_path, capsys):
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert_one_line_error(captured.err, field)
    assert list((tmp_path / "cwd").iterdir()) == [] and not (tmp_path / "results").exists()


@pytest.mark.parametrize("argv, field", [
    (["render", "aa-edges", "--res", "8", "--spp", "1", "--out", ""], "--out"),
    (["experiment", "STUDY", "--out", ""], "--out"),
    (["experiment", "STUDY", "--gt-dir", " "], "--gt-dir"),
    (["ground-truth", "aa-edges", "--gt-dir", ""], "--gt-dir"),
    (["compare", "A", "A", "--out-dir", ""], "--out-dir"),
    (["compare", "A", "A", "--ref", ""], "--ref"),
    (["compare", "A", "A", "--stderr", "", "--per-pixel-z"], "--stderr"),
    (["sources", "aa-edges", "--out", ""], "--out"),
    (["pointset", "sobol", "--n", "64", "--out", ""], "--out"),
    (["validate", "sobol", "--out", ""], "--out"),
    (["lobe", "glossy", "--out", ""], "--out"),
    (["audit-intervals", "--studies", "2", "--out", ""], "--out"),
])
def test_an_empty_path_flag_is_refused(argv, field, elsewhere, capsys):
    from drtlab.kernels.imageio import write_exr
    write_exr(elsewhere / "a.exr", np.full((4, 6, 3), 0.5), {"sampler": "none"})
    argv = [{"STUDY": study_file(elsewhere), "A": str(elsewhere / "a.exr")}.get(a, a) for a in argv]
    refused(argv, field, elsewhere, capsys)


@pytest.mark.parametrize("variable, argv", [
    ("DRTLAB_RESULTS", ["render", "aa-edges", "--res", "8", "--spp", "1"]),
    ("DRTLAB_RESULTS", ["experiment", "STUDY"]),
    ("DRTLAB_RESULTS", ["ground-truth", "aa-edges", "--spp", "4"]),
    ("DRTLAB_RESULTS", ["compare", "A", "A"]),
    ("DRTLAB_GT_DIR", ["ground-truth", "aa-edges", "--spp", "4"]),
])
def test_an_empty_results_variable_is_refused(variable, argv, elsewhere, monkeypatch, capsys):
    from drtlab.kernels.imageio import write_exr
    write_exr(elsewhere / "a.exr", np.full((4, 6, 3), 0.5), {"sampler": "none"})
    argv = [{"STUDY": study_file(elsewhere), "A": str(elsewhere / "a.exr")}.get(a, a) for a in argv]
    monkeypatch.setenv(variable, "")
    refused(argv, variable, elsewhere, capsys)
    assert main(["scenes"]) == 0                    # a command that writes nothing is not stopped


def test_the_api_refuses_an_empty_output_folder(elsewhere):
    import drtlab
    from drtlab.errors import InputError
    from fakes import tiny_real_experiment
    with pytest.raises(InputError) as e:
        drtlab.run_experiment(study_file(elsewhere), out_dir="", progress=False)
    assert e.value.field == "out_dir"
    assert list((elsewhere / "cwd").iterdir()) == []


def test_a_decomposition_for_days_is_estimated_and_refused_before_it_renders(tmp_path, capsys):
    out = tmp_path / "sources"
    rc = main(["sources", "aa-edges", "--spp", "65536", "--res", "2048", "--out", str(out)])
    err = capsys.readouterr().err.splitlines()
    assert rc == 2
    assert err[-1].startswith("drtlab: --yes: this decomposition would render for about "), err
    assert err[-2].startswith("estimate: about ") and not out.exists()


@pytest.mark.parametrize("argv, wrote", [
    (["render", "aa-edges", "--res", "8", "--spp", "1", "--out", "~/r.exr"], "r.exr"),
    (["pointset", "sobol", "--n", "16", "--realisations", "1", "--out", "~/p"], "p"),
])
def test_a_path_from_home_is_written_where_it_was_checked(argv, wrote, elsewhere, monkeypatch, capsys):
    home = elsewhere / "home"
    home.mkdir()
    monkeypatch.setenv("HOME", str(home))
    assert main(argv) == 0
    assert (home / wrote).exists() and list((elsewhere / "cwd").iterdir()) == []


def test_two_scene_files_of_one_name_get_their_own_default_sources_folder(elsewhere, capsys):
    from cli_util import GOOD_SCENE
    for d, emission in (("one", "5.0"), ("two", "2.0")):
        (elsewhere / d).mkdir()
        (elsewhere / d / "s.toml").write_text(GOOD_SCENE.replace("emission = [5.0, 5.0, 5.0]",
                                                                 f"emission = [{emission}, 1.0, 1.0]"))
        assert main(["sources", str(elsewhere / d / "s.toml"), "--spp", "2", "--res", "8"]) == 0
    folders = sorted(p.name for p in (elsewhere / "results" / "sources").iterdir())
    assert len(folders) == 2 and all(f.startswith("s-") for f in folders), folders
    assert main(["sources", "aa-edges", "--spp", "2", "--res", "8"]) == 0
    assert (elsewhere / "results" / "sources" / "aa-edges" / "sources.json").is_file()


@pytest.mark.parametrize("argv, name", [
    (["pointset", "sobol", "--n", "16", "--realisations", "1"], "analysis.json"),
    (["lobe", "diffuse", "--samples", "10000"], "lobe.json"),
    (["sources", "aa-edges", "--spp", "2", "--res", "8"], "sources.json"),
])
def test_a_users_file_at_a_name_the_command_writes_is_never_overwritten(argv, name, tmp_path, capsys):
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / name).write_text("the user's own")
    (mine / "notes.txt").write_text("beside it")
    assert main(argv + ["--out", str(mine)]) == 2
    assert_one_line_error(capsys.readouterr().err, "--out")
    assert (mine / name).read_text() == "the user's own"
    assert sorted(p.name for p in mine.iterdir()) == sorted([name, "notes.txt"])
    # Its own folder: written, then written again (the files are drtlab's now); a user's other
    # files beside them are left alone.
    ours = tmp_path / "ours"
    ours.mkdir()
    (ours / "notes.txt").write_text("beside it")
    assert main(argv + ["--out", str(ours)]) in (0, 1)
    assert main(argv + ["--out", str(ours)]) in (0, 1)
    assert (ours / name).read_text() != "the user's own" and (ours / "notes.txt").read_text() == "beside it"
