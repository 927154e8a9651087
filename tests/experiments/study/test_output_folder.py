"""A study's output folder is drtlab's record: the user's files beside drtlab's are never removed or
overwritten (with and without --fresh), a folder holding anything else is refused before any work
unless allowed, and the clean-up after a kill removes only the temp files drtlab wrote."""
import json
import os
from pathlib import Path

import pytest

from drtlab.errors import InputError
from drtlab.experiments.study.output_dir import RECORD, OutputRecord, planned_files
from drtlab.experiments.study.plan import plan_runs
from drtlab.experiments.study.run_store import load_records
from fakes import fake_backend
from test_runner import TINY, run, tiny_experiment

# The user's own files, beside and inside the folders drtlab writes.
USER_FILES = {
    "images/mine.png": b"my picture",
    "images/sub/keep.txt": b"deep",
    "plots/draft.svg": b"<svg/>",
    "notes/todo.txt": b"todo",
    "README.txt": b"my notes",
    ".settings.json": b'{"mine": true}',
    ".data.csv": b"a,b\n1,2\n",
    ".x.tmp": b"not a temp of drtlab's",
    "cells/.mine.npz": b"hidden, in drtlab's folder",
    ".runs.parquet.tmp": b"no random part: not a name drtlab's temps have",
}


def put_user_files(out: Path) -> None:
    for rel, data in USER_FILES.items():
        (out / rel).parent.mkdir(parents=True, exist_ok=True)
        (out / rel).write_bytes(data)


def assert_user_files_intact(out: Path) -> None:
    for rel, data in USER_FILES.items():
        assert (out / rel).read_bytes() == data, rel


def files_under(d: Path) -> set:
    return {str(p.relative_to(d)) for p in d.rglob("*")}


@pytest.fixture
def exp(tmp_path):
    # One study of one scene: the analysis (slope fits, figures) stays short.
    return tiny_experiment(tmp_path, TINY.replace('scenes = ["aa-edges", "glossy"]', 'scenes = ["glossy"]'))


def test_every_file_an_analysed_sweep_writes_is_in_its_record(exp, tmp_path):
    out, gt = tmp_path / "out", tmp_path / "gt"
    run(exp, out, gt, analyze=True)
    record = OutputRecord.load(out, [])
    assert list(record.others()) == []                       # nothing written that is not recorded
    assert {"images", "plots", "cells"} <= record.folders
    written = {f for f in files_under(out) if (out / f).is_file()} - {RECORD}
    assert written <= record.files and "report.md" in written and "images/glossy.png" in written


def test_fresh_removes_only_what_drtlab_wrote(exp, tmp_path):
    out, gt = tmp_path / "out", tmp_path / "gt"
    run(exp, out, gt, analyze=True)
    drtlabs = {f for f in files_under(out) if (out / f).is_file()} - {RECORD, ".lock"}
    assert {"images/glossy.png", "plots/strat-efficiency.png", "report.md"} <= drtlabs
    put_user_files(out)
    s, _ = run(exp, out, gt, fresh=True, allow_other_files=True)      # no analysis: no report again
    assert s.stats["runs_new"] == 24                         # every run again
    assert_user_files_intact(out)
    left = files_under(out)
    assert set(USER_FILES) <= left
    # drtlab's own files went, in the folders the user shares too; its table and cells are new.
    assert not (out / "images/glossy.png").exists() and not (out / "report.md").exists()
    assert not (out / "plots/strat-efficiency.png").exists()
    assert {f for f in left if (out / f).is_file()} - set(USER_FILES) - {RECORD, ".lock"} == \
        {"runs.parquet", "runs.csv"} | {f for f in drtlabs if f.startswith("cells/")}
    # Without the user's files, --fresh removes drtlab's own folders too.
    record = OutputRecord.load(out, [])
    for rel in USER_FILES:
        (out / rel).unlink()
    for d in ("images/sub", "notes"):
        (out / d).rmdir()
    record.remove_outputs()
    assert sorted(p.name for p in out.iterdir()) == [RECORD, ".lock"]


def test_resume_removes_only_drtlabs_orphaned_temps(exp, tmp_path):
    out, gt = tmp_path / "out", tmp_path / "gt"
    out.mkdir()
    put_user_files(out)
    _, fake = run(exp, out, gt, allow_other_files=True)
    n = len(load_records(out))
    cell = sorted((out / "cells").glob("glossy*.npz"))[0].name
    orphans = [out / ".runs.parquet.k2j4h5g6.tmp", out / "cells" / f".{cell}.ab_cd9ef.tmp",
               out / ".calibration.json.0123abcd.tmp", out / f".{RECORD}.zz_99abc.tmp"]
    for p in orphans:
        p.write_bytes(b"a kill's temp")
    assert set(OutputRecord.load(out, []).others()) == set(USER_FILES)   # the temps are drtlab's
    _, fake = run(exp, out, gt, allow_other_files=True)
    assert fake.calls == 0 and len(load_records(out)) == n
    assert not any(p.exists() for p in orphans)
    assert_user_files_intact(out)


def test_a_folder_with_other_files_is_refused_before_any_work(exp, tmp_path):
    out, gt = tmp_path / "out", tmp_path / "gt"
    out.mkdir()
    (out / ".settings.json").write_text("{}")
    before = files_under(out)
    with pytest.raises(InputError) as e:
        run(exp, out, gt)
    assert e.value.field == "out_dir" and str(out) in e.value.message and ".settings.json" in e.value.message
    assert files_under(out) == before and not gt.exists()
    # An empty folder of the user's counts too; the ground-truth cache inside the folder does not.
    (out / ".settings.json").unlink()
    (out / "empty").mkdir()
    with pytest.raises(InputError, match="empty/"):
        run(exp, out, gt)
    (out / "empty").rmdir()
    run(exp, out, out / "gt")
    run(exp, out, out / "gt")


def test_a_users_file_where_drtlab_would_write_is_never_overwritten(exp, tmp_path):
    out, gt = tmp_path / "out", tmp_path / "gt"
    out.mkdir()
    (out / "report.md").write_text("my report")
    with pytest.raises(InputError, match="report.md was not written by drtlab"):
        run(exp, out, gt, allow_other_files=True)
    assert (out / "report.md").read_text() == "my report" and files_under(out) == {"report.md"}
    (out / "report.md").unlink()
    (out / "images").write_text("a file where drtlab's folder goes")
    with pytest.raises(InputError, match="images is not a folder"):
        run(exp, out, gt, allow_other_files=True)
    assert files_under(out) == {"images"}


def test_a_folder_an_earlier_drtlab_wrote_is_adopted(exp, tmp_path):
    out, gt = tmp_path / "out", tmp_path / "gt"
    run(exp, out, gt)
    (out / RECORD).unlink()                                  # as an earlier drtlab left it
    (out / "mine.txt").write_text("the user's")
    with pytest.raises(InputError, match="mine.txt"):         # adopted: only the user's file is other
        run(exp, out, gt)
    (out / "mine.txt").unlink()
    _, fake = run(exp, out, gt)
    assert fake.calls == 0
    record = json.loads((out / RECORD).read_text())
    assert {"runs.parquet", "runs.csv"} <= set(record["files"])
    assert list(OutputRecord.load(out, []).others()) == []


def test_planned_files_name_every_cell_of_the_plan(exp):
    backend, _ = fake_backend()
    plan = plan_runs(exp, backend)
    planned = planned_files(exp, plan)
    assert len(planned) == len(set(planned))
    assert {f"cells/{r.cell}.npz" for r in plan} <= set(planned)


def test_the_command_refuses_a_folder_of_the_users_in_one_line(tmp_path, capsys):
    from cli_util import assert_one_line_error
    from drtlab.cli import main
    from fakes import tiny_real_experiment
    p = tmp_path / "real.toml"
    p.write_text(tiny_real_experiment("refused", ["soft-shadows"]))
    out = tmp_path / "mine"
    out.mkdir()
    (out / "data.csv").write_text("1,2\n")
    rc = main(["experiment", str(p), "--out", str(out), "--gt-dir", str(tmp_path / "gt"), "--fresh"])
    err = capsys.readouterr().err
    assert rc == 2
    assert_one_line_error(err, "--out")
    assert str(out) in err and "--allow-other-files" in err
    assert files_under(out) == {"data.csv"} and not (tmp_path / "gt").exists()
    os.remove(out / "data.csv")


def test_two_studies_whose_files_would_collide_are_refused_before_any_work(tmp_path):
    text = TINY + '\n[[study]]\nname = "strat "\nscenes = ["glossy"]\nsamplers = ["stratified"]\n'
    twins = tiny_experiment(tmp_path, text.replace('name = "strat"', 'name = "strat!"'))
    out = tmp_path / "out"
    with pytest.raises(InputError, match="would write the same file") as e:
        run(twins, out, tmp_path / "gt")
    assert e.value.field == "study[1].name" and not out.exists()
