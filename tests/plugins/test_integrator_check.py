"""`drtlab check INTEGRATOR` (experiments/checks/integrator.py): the built-in unbiased integrators pass
every judged line; the negative controls fail where they must: path with the cosine dropped
(features.DROP_COSINE) fails every unbiasedness line and the furnace, path whose roulette does not
reweight its survivors (RR_NO_REWEIGHT) fails the indirect-light line (the one scene deep enough for
roulette to act); whitted, which claims no unbiasedness, has those lines reported, not judged.
Level: the scorecard's 0.01, Sidak over its p-valued lines; fixed seeds (the check's seed 0)."""
import json
import subprocess
import sys
from types import SimpleNamespace

import pytest

from drtlab.cli import main
from drtlab.estimators import integrators
from drtlab.experiments.checks import integrator as check_module
from drtlab.experiments.checks.integrator import check, claims, claims_unbiased
from drtlab.experiments.checks.integrator_scenes import EFFECTS
from drtlab.kernels.features import DROP_COSINE, RR_NO_REWEIGHT

from cli_util import assert_one_line_error


def _verdicts(card) -> dict:
    return {x.name: x.passed for x in card.lines}


def test_drt_passes_its_scorecard_from_the_command_line(tmp_path):
    out = tmp_path / "card.json"
    r = subprocess.run([sys.executable, "-m", "drtlab.cli", "check", "drt", "--out", str(out)],
                       capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == 0, r.stdout + r.stderr
    judged = {x["name"]: x["passed"] for x in json.loads(out.read_text())["lines"] if x["passed"] is not None}
    # drt claims every effect but diffuse interreflection, and each claim gets its scene's line
    assert set(claims("drt")) == set(EFFECTS) - {"indirect"}
    assert set(judged) == {f"unbiased: {e}" for e in EFFECTS if e != "indirect"} | {
        "white furnace", "threads and tiles", "hard cases", "convergence"}
    assert all(judged.values())


def test_path_passes_every_line_on_every_effect():
    card = check("path")
    v = _verdicts(card)
    assert card.passed, "\n".join(card.text())
    assert card.tests == len(EFFECTS) + 1
    assert {f"unbiased: {e}" for e in EFFECTS} <= set(v) and v["cost"] is None


@pytest.mark.parametrize("fault, failing", [
    (DROP_COSINE, {f"unbiased: {e}" for e in EFFECTS} | {"white furnace"}),
    (RR_NO_REWEIGHT, {"unbiased: indirect"}),
])
def test_a_broken_path_fails_the_check(fault, failing):
    card = check("path", faults=(fault,))
    v = _verdicts(card)
    assert not card.passed
    assert {k for k, ok in v.items() if ok is False} >= failing, "\n".join(card.text())
    # what the fault does not touch still holds: determinism and finite values
    assert v["threads and tiles"] and v["hard cases"]


def test_a_biased_integrator_has_its_unbiasedness_reported_not_judged():
    card = check("whitted")
    v = _verdicts(card)
    assert card.tests == 0 and card.passed
    assert claims("whitted") == ("specular", "point_lights")
    assert v["white furnace"] is None and v["convergence"] is None
    assert v["unbiased: specular"] is None and v["unbiased: point_lights"] is None
    furnace = next(x for x in card.lines if x.name == "white furnace")
    assert furnace.p < 1e-6, furnace.figure       # shadow rays to the walls' centres: visibly biased
    assert v["threads and tiles"] and v["hard cases"]


def test_the_claims_come_from_the_registration(monkeypatch):
    assert claims("path") == EFFECTS and "indirect" not in claims("drt")
    assert claims_unbiased("path") and not claims_unbiased("whitted")
    mine = SimpleNamespace(name="mine", description="x", biased=False, unbiased=False,
                           handles=("direct", "caustics"))
    monkeypatch.setitem(integrators.INTEGRATORS, "mine", mine)
    assert claims("mine") == ("direct", "caustics") and not claims_unbiased("mine")
    monkeypatch.setitem(integrators.INTEGRATORS, "plain", SimpleNamespace(name="plain", biased=False))
    assert claims("plain") == check_module.DEFAULT_CLAIMS and claims_unbiased("plain")


def test_an_unknown_name_is_one_line_naming_the_integrators(tmp_path, capsys):
    rc = main(["check", "no-such-integrator", "--out", str(tmp_path / "card.json")])
    err = capsys.readouterr().err
    assert rc == 2 and not list(tmp_path.iterdir())
    assert_one_line_error(err, "NAME")
    assert "integrators: " + ", ".join(integrators.INTEGRATORS) in err
