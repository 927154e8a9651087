"""report.md defines speed-up and efficiency ratio once, and its findings quote the study's
comparisons (their intervals, or "not resolved") rather than deriving claims of their own."""
from __future__ import annotations

from drtlab.experiments.study import report as R
from drtlab.experiments.study.report_sections import fmt
from synthetic_study import synthetic_study


def test_the_figures_of_merit_are_defined_once_near_the_top():
    intro = R.INTRO
    assert intro.count("defined once") == 1
    assert intro.index("*speed-up*") < intro.index("*efficiency ratio*") < 2000
    assert "the same quality in half the time* only at equal slopes" in intro.replace("\n", " ")


def test_findings_quote_the_comparisons_and_their_intervals():
    study = synthetic_study(3, n_scenes=1)
    scene, top = study.scenes[0], study.spp[-1]
    lines = R._findings(study)
    text = "\n".join(lines)
    good, bad = scene.row("sampler-1", top), scene.row("sampler-2", top)
    assert good.speedup_resolved and not bad.resolved
    # The resolved comparison: its speed-up and 95% interval, as compare.py computed them.
    assert f"{fmt(good.speedup)}× faster (95% CI {fmt(good.speedup_lo)}–{fmt(good.speedup_hi)}×)" in text
    assert f"**{good.claim}**" in text
    # The unresolved one: no ratio, no claim, the reason it is not resolved.
    part = text.split("`sampler-2`")[1]
    assert "**not resolved**" in part and bad.why in part and "faster" not in part
    table = "\n".join(R._study_table(study))
    assert "Efficiency ratio vs sampler-0" in table
    # Each comparison's own target error, named by sampler when a scene has several.
    assert f"{fmt(good.target_rmse)} (`sampler-1`)" in table
