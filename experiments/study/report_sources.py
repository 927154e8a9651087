"""The variance-sources part of a study's report: each scene's decomposition (`variance_sources`
setting) as a table of first-order and total indices per dimension group, and in words whether its
variance is first-order, beside the samplers' measured speed-ups."""
from __future__ import annotations

from pathlib import Path

from drtlab.experiments.study.report_sections import comparison_ratio
from drtlab.experiments.study.results import StudyResult


# A decomposition whose widest 95% interval is wider than +-this says "not resolved" in the report.
SOURCES_RESOLVED = 0.15


def _share(v: float) -> str:
    """An index to two decimals (a tiny negative estimate reads 0.00, not -0.00)."""
    return f"{v:.2f}" if round(v, 2) != 0 else "0.00"


def sources_section(study: StudyResult, study_cfg, out_dir: Path) -> list[str]:
    """The study's variance decompositions (`variance_sources` setting): a table of S / T per
    group and, per scene, whether its variance is first-order (what stratifying each group's
    dimensions reaches) beside the samplers' measured speed-ups."""
    from drtlab.experiments.study.variance_sources import SOURCES_DIR, load_sources, stem
    refs = {ref.label: ref for ref in study_cfg.scenes}
    stems = {sc.scene: stem(study_cfg, refs[sc.scene]) for sc in study.scenes if sc.scene in refs}
    found = {k: load_sources(out_dir, v) for k, v in stems.items()}
    found = {k: v for k, v in found.items() if v}
    if not study_cfg.settings.variance_sources or not found:
        return []
    groups = [g["group"] for g in next(iter(found.values()))["groups"]]
    any_src = next(iter(found.values()))
    lines = [f"**Where the variance comes from** (`drtlab sources`: {any_src['samples_per_pixel']} "
             f"samples per pixel of `{any_src['sampler']}`, {any_src['metric']}; first-order S / total T "
             f"share of one sample's variance per dimension group, 95% intervals in the JSON files):\n",
             "| scene | " + " | ".join(groups) + " | 1 − ΣS | figure |",
             "|---|" + "---|" * (len(groups) + 2)]
    from drtlab.experiments.sources.report import INDEX_SLACK, NOT_RESOLVED, group_resolved

    def index(g: dict, key: str) -> str:
        return _share(g[key]) + ("" if group_resolved(g, key) else f" ({NOT_RESOLVED})")

    flagged = False
    for scene, src in found.items():
        cells = [f"{index(g, 'first_order')} / {index(g, 'total')}" if g["total"] > 0 else "0"
                 for g in src["groups"]]
        flagged |= any(NOT_RESOLVED in c for c in cells)
        fig = f"{SOURCES_DIR}/{stems[scene]}.png"
        lines.append(f"| {scene} | " + " | ".join(cells) + f" | {_share(src['interaction']['value'])} | "
                     f"[map]({fig}) |")
    lines.append("")
    if flagged:
        lines.append(f"({NOT_RESOLVED}): the index or its 95% interval lies outside [0, 1] by more than "
                     f"{INDEX_SLACK:g}; an index is a share of the variance, so these samples per pixel do "
                     f"not resolve it.\n")
    for sc in study.scenes:
        src = found.get(sc.scene)
        if not src:
            continue
        tops = [sc.row(s, study.spp[-1]) for s in study.samplers if s != study.baseline]
        gains = [f"`{r.sampler}` {comparison_ratio(r, 'speedup')}" for r in tops if r is not None]
        widest = max(max(g["first_order_hi"] - g["first_order_lo"], g["total_hi"] - g["total_lo"])
                     for g in src["groups"])
        outside = [g["group"] for g in src["groups"]
                   if not (group_resolved(g, "first_order") and group_resolved(g, "total"))]
        if widest > 2 * SOURCES_RESOLVED or outside:
            why = (f"an interval {widest:.2f} wide" if widest > 2 * SOURCES_RESOLVED else
                   f"indices of {', '.join(f'`{g}`' for g in outside)} outside [0, 1]")
            where = (f"**not resolved** with {src['samples_per_pixel']} samples per pixel ({why}: rare, "
                     f"very bright samples, as in its errors); "
                     f"`drtlab sources {sc.scene_name} --spp 4096` decides it")
        else:
            top = max(src["groups"], key=lambda g: g["total"])
            first = 1.0 - src["interaction"]["value"]
            where = (f"the `{top['group']}` group holds the most (T = {top['total']:.2f}); " +
                     (f"{first:.0%} of it is first-order (each group alone), which stratifying each "
                      f"group's dimensions can remove" if first >= 0.7 else
                      f"only {first:.0%} of it is first-order: the rest is interaction between groups, "
                      f"which stratifying each group's dimensions separately does not reach"))
        lines.append(f"- **{sc.scene}**: {where}" + (f". Measured speed-ups: {', '.join(gains)}."
                                                      if gains else "."))
    lines.append("")
    return lines
