"""The runnable example's flags go through drtlab's parser: a bad one is one line and exit 2 (the
example itself runs end to end in tests/drtlab/test_python_api.py)."""
import pytest
from cli_util import assert_one_line_error

from drtlab.experiments.examples import python_study


@pytest.mark.parametrize("argv, flag", [(["--bogus"], "--bogus"), (["--out"], "--out")])
def test_bad_flag_is_one_line(capsys, argv, flag):
    assert python_study.main(argv) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert_one_line_error(captured.err, flag)
