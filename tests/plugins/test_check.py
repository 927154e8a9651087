"""`drtlab check NAME` (experiments/checks/pointset.py) on a user's plugin: the example R2 set passes
every judged line, and the negative controls fail where they must: a table served unrandomized (the
same points in every pixel and seed) fails the battery and the renderer's unbiasedness, and a set
that renders differently across threads fails that line. Levels: the scorecard's 0.01 (Sidak over
its four tests), fixed seeds."""
import json
import subprocess
import sys

from scipy.stats import qmc

from drtlab.experiments.checks.pointset import check

from plugin_sources import OFF_BY_10
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
    raw = __import__("drtlab").register_pointset(
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


def test_a_light_selection_plugin_gets_its_scorecard_from_the_command_line(tmp_path):
    """experiments/checks/light_selection.py: the example nearest-light selection passes every judged
    line (level 0.01, Sidak over its 5 tests); a pmf 10% high on one light (the negative control)
    fails the pmf sum, the pick frequencies and the furnace, with exit status 1."""
    (tmp_path / "off.py").write_text(OFF_BY_10)
    cards = {}
    for name, plugin in (("nearest", PLUGIN_EXAMPLES / "nearest_light.py"), ("off-by-10", tmp_path / "off.py")):
        out = tmp_path / f"{name}.json"
        r = subprocess.run([sys.executable, "-m", "drtlab.cli", "check", name, "--plugin", str(plugin),
                            "--out", str(out)], capture_output=True, text=True, cwd=tmp_path)
        cards[name] = (r.returncode, {x["name"]: x["passed"] for x in json.loads(out.read_text())["lines"]})
    code, good = cards["nearest"]
    assert code == 0 and set(good) >= {"pmf", "pick frequencies", "directions", "MIS density", "hard cases",
                                       "renderer unbiasedness"} and all(v for v in good.values() if v is not None)
    code, bad = cards["off-by-10"]
    assert code == 1 and not bad["pmf"] and not bad["pick frequencies"] and not bad["renderer unbiasedness"]
    assert bad["hard cases"] and bad["MIS density"]
