"""Bad flags of the benchmark entry points (`python -m drtlab.experiments.bench`, `.bench.mitsuba`,
`.bench.profile_kernels`) are one line naming the flag and exit 2, before any render or compile."""
import pytest
from cli_util import assert_one_line_error

from drtlab.experiments.bench import profile_kernels, scenes
from drtlab.experiments.bench.mitsuba import compare


@pytest.mark.parametrize("main, argv, flag", [
    (scenes.main, ["--spp", "-3"], "--spp"),
    (scenes.main, ["--repeats", "0"], "--repeats"),
    (scenes.main, ["--scaling-repeats", "two"], "--scaling-repeats"),
    (scenes.main, ["--startup-repeats", "0"], "--startup-repeats"),
    (scenes.main, ["--bogus"], "--bogus"),
    (compare.main, ["--spp", "-3"], "--spp"),
    (compare.main, ["--seeds", "1"], "--seeds"),
    (profile_kernels.main, ["rays", "--threads", "-3"], "--threads"),
    (profile_kernels.main, ["nonsense"], "mode"),
    (profile_kernels.main, ["rays", "--quad-test", "wide"], "--quad-test"),
    (profile_kernels.main, ["components", "--repeats", "0"], "--repeats"),
])
def test_bad_flag_is_one_line(capsys, main, argv, flag):
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert_one_line_error(captured.err, flag)


def test_bench_out_must_be_a_file(capsys, tmp_path):
    assert scenes.main(["--out", str(tmp_path)]) == 2
    assert_one_line_error(capsys.readouterr().err, "--out")
    assert list(tmp_path.iterdir()) == []
