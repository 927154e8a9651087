"""`report.html`: one self-contained page beside report.md (no network: scripts, styles, plots and
images all inline) with, per scene, an HDR image viewer (the reference and repetition 0 of every
cell, tone-mapped in the browser with an exposure control; flip, zoom, pan, false-colour error
maps, metrics of a crop), the study's plots and its tables as report.md prints them.

Images travel as float16 little-endian, base64: a W x H image is 6 W H bytes, 8 W H characters
(96 x 72: 55 kB each; the default study's 6 scenes x (16 cells + reference) about 5.6 MB). Past
`MAX_IMAGE_BYTES` the largest-N cells are left out, the page says which."""
from __future__ import annotations

import base64
import html
import json
import re
from pathlib import Path

import numpy as np

from drtlab.experiments.files import atomic_write_text
from drtlab.experiments.study.report_html_app import SCRIPT, STYLE

# The images' share of the page: beyond ~50 MB a browser opens the file slowly.
MAX_IMAGE_BYTES = 45_000_000
F16_MAX = 65504.0                 # the largest finite float16: brighter values are clipped to it
COLOURMAP = "viridis"             # perceptually ordered, readable to the colour-blind
COLOURMAP_STOPS = 64


def encode_image(img: np.ndarray) -> tuple[str, bool]:
    """(base64 of the image as float16 little-endian, row-major H x W x 3; whether any finite value
    had to be clipped to float16's range)."""
    a = np.asarray(img, dtype=np.float64)[..., :3]
    finite = np.isfinite(a)
    clipped = bool(np.any(np.abs(a[finite]) > F16_MAX))
    a = np.where(finite, np.clip(a, -F16_MAX, F16_MAX), a)
    return base64.b64encode(np.ascontiguousarray(a, dtype="<f2").tobytes()).decode("ascii"), clipped


def encoded_size(w: int, h: int) -> int:
    """Characters of one encoded image: base64 of 3 float16 per pixel."""
    return 4 * ((6 * w * h + 2) // 3)


def _colourmap() -> list:
    """The colour map as `COLOURMAP_STOPS` sRGB byte triples, sampled from matplotlib's table (the
    page interpolates between them)."""
    from matplotlib import colormaps
    rgba = colormaps[COLOURMAP](np.linspace(0.0, 1.0, COLOURMAP_STOPS))
    return [[int(round(255 * c)) for c in row[:3]] for row in rgba]


def _png_uri(path: Path) -> str:
    return "data:image/png;base64," + base64.b64encode(Path(path).read_bytes()).decode("ascii")


# ---------------------------------------------------------------------------------------------------
# The tables, from report.md's own lines
# ---------------------------------------------------------------------------------------------------

def _inline(md: str) -> str:
    """The inline markdown report.md's table cells use (`code`, **bold**) as HTML."""
    s = html.escape(md, quote=False)
    s = re.sub(r"`([^`]+)`", r"<code>\1</code>", s)
    return re.sub(r"\*\*([^*]+)\*\*", r"<strong>\1</strong>", s)


def _cells(line: str) -> list[str]:
    return [c.strip() for c in line.strip().strip("|").split("|")]


def markdown_to_html(lines: list[str]) -> str:
    """report.md's lines of one table section (pipe tables, paragraphs, <details> wrappers) as
    HTML: the page shows the very strings report.md prints."""
    out: list[str] = []
    table: list[list[str]] = []

    def flush():
        if table:
            head, rows = table[0], table[1:]
            out.append("<div class=scroll><table><thead><tr>" +
                       "".join(f"<th>{_inline(c)}</th>" for c in head) + "</tr></thead><tbody>" +
                       "".join("<tr>" + "".join(f"<td>{_inline(c)}</td>" for c in r) + "</tr>"
                               for r in rows) + "</tbody></table></div>")
            table.clear()

    for raw in "\n".join(lines).split("\n"):
        line = raw.strip()
        if line.startswith("|"):
            if not re.fullmatch(r"\|(\s*-+\s*\|)+", line):
                table.append(_cells(line))
            continue
        flush()
        m = re.fullmatch(r"<details><summary>(.*)</summary>", line)
        if m:
            out.append(f"<details open><summary>{_inline(m.group(1))}</summary>")
        elif line == "</details>":
            out.append("</details>")
        elif line:
            out.append(f"<p>{_inline(line)}</p>")
    flush()
    return "\n".join(out)


# ---------------------------------------------------------------------------------------------------
# The images of each scene
# ---------------------------------------------------------------------------------------------------

def scene_cells(plan, records: dict, study_name: str, scene) -> tuple | None:
    """(group, {(sampler, spp): cell}) of repetition 0's runs of a study's scene, as the image
    strips pick them; None when the plan has no group of it."""
    g = next((r.group for r in plan if r.scene == scene and study_name in r.studies), None)
    if g is None:
        return None
    return g, {(r.sampler, r.spp): r.cell for r in plan
               if r.group == g and r.rep == 0 and r.run_id in records}


def _budget(views: list[dict], limit: int) -> tuple[set, list[int]]:
    """Which (view, sampler, spp) entries fit in `limit` characters of images: the references and
    then the cells by increasing N, whole sample counts at a time. Returns (kept keys, dropped Ns)."""
    used, kept = 0, set()
    for v in views:
        used += encoded_size(v["width"], v["height"])          # the reference: always kept
    by_n: dict[int, list] = {}
    for v in views:
        for (s, n) in v["cells"]:
            by_n.setdefault(n, []).append((id(v), s, n, encoded_size(v["width"], v["height"])))
    dropped: list[int] = []
    for n in sorted(by_n):
        cost = sum(e[3] for e in by_n[n])
        if dropped or used + cost > limit:
            dropped.append(n)
            continue
        used += cost
        kept.update(e[:3] for e in by_n[n])
    return kept, dropped


def _viewers(exp, summary, plan, records: dict, out_dir: Path, gts: dict, limit: int) -> tuple:
    """(scene views per study name, images: key -> base64, notes for the page)."""
    from drtlab.experiments.study.figures import choose_crop
    from drtlab.experiments.study.ground_truth import load_ground_truth
    from drtlab.experiments.study.run_store import first_image
    views: dict[str, list] = {}
    flat: list[dict] = []
    for study_cfg, study in zip(exp.studies, summary.studies):
        for scene_cfg, scene in zip(study_cfg.scenes, study.scenes):
            found = scene_cells(plan, records, study_cfg.name, scene_cfg)
            if found is None:
                continue
            g, cells = found
            w, h = g[2]
            v = {"scene": scene.scene, "group": g, "width": int(w), "height": int(h), "cells": cells,
                 "samplers": list(study.samplers), "spp": list(study.spp),
                 "metric": _plugin_metric(study.metric), "metric_label": study.mse_label,
                 "seconds": {(c.sampler, c.spp): c.seconds for c in scene.cells}}
            views.setdefault(study.name, []).append(v)
            flat.append(v)
    kept, dropped = _budget(flat, limit)
    images: dict[str, str] = {}
    flips: dict[str, str] = {}
    clipped = False
    refs: dict = {}
    stderrs: dict = {}
    for v in flat:
        g = v["group"]
        ref_key = "gt:" + str(gts[g]["dir"])
        if ref_key not in images:
            gt = load_ground_truth(gts[g]["dir"])
            refs[ref_key], stderrs[ref_key] = gt.mean, gt.stderr
            images[ref_key], c = encode_image(refs[ref_key])
            clipped |= c
        y, x, size = choose_crop(refs[ref_key])
        entries = [{"key": ref_key, "label": "reference", "sampler": None, "spp": None}]
        for s in v["samplers"]:
            for n in v["spp"]:
                cell = v["cells"].get((s, n))
                if cell is None or (id(v), s, n) not in kept:
                    continue
                img = None
                if cell not in images:
                    img = first_image(out_dir, cell)
                    if img is None:
                        continue
                    images[cell], c = encode_image(img)
                    clipped |= c
                    flips[cell] = _flip_bytes(img, refs[ref_key])
                sec = v["seconds"].get((s, n))
                entries.append({"key": cell, "label": f"{s} N={n}", "sampler": s, "spp": n,
                                "seconds": sec if sec is not None and np.isfinite(sec) else None})
                if v["metric"] is not None:
                    img = first_image(out_dir, cell) if img is None else img
                    entries[-1]["metric"] = v["metric"].score(img[None], refs[ref_key],
                                                              stderrs[ref_key])[0]
        v.update(images=entries, crop=[int(x), int(y), int(size), int(size)])
    total = sum(len(s) for s in images.values())
    sizes = sorted({(v["width"], v["height"]) for v in flat})
    notes = [f"{len(images)} images embedded as float16 (" +
             ", ".join(f"{encoded_size(w, h) / 1e3:.1f} kB each at {w}×{h}" for w, h in sizes) +
             f"; {total / 1e6:.2f} MB in all)."]
    if dropped:
        notes.append(f"Left out to keep this page under {limit / 1e6:.0f} MB: the cells at N = "
                     f"{', '.join(map(str, dropped))} (report.md and images/ show them).")
    if clipped:
        notes.append(f"Some pixels are brighter than float16 holds: clipped to {F16_MAX:g}.")
    return views, images, {k: v for k, v in flips.items() if v}, notes


def _plugin_metric(name: str):
    """The study's metric when a plugin computes it (the page's script computes MSE and relMSE
    itself, on any crop; a plugin's metric only Python can, on the whole image), else None."""
    from drtlab.experiments.error_metrics import METRICS
    metric = METRICS.get(name)
    return metric if metric is not None and metric.per_run is not None else None


def _flip_bytes(img: np.ndarray, ref: np.ndarray) -> str:
    """The HDR-FLIP map of `img` against the reference as base64 bytes (value x 255: FLIP lies in
    [0, 1], and a quarter-percent step is below what the colour map shows); "" where FLIP is
    undefined (metrics.flip_problem)."""
    from drtlab.experiments.study.metrics import flip_map, flip_problem
    if flip_problem(img, ref) is not None:
        return ""
    q = np.clip(np.rint(flip_map(img, ref) * 255.0), 0, 255).astype(np.uint8)
    return base64.b64encode(q.tobytes()).decode("ascii")


def _view_json(v: dict) -> dict:
    return {"scene": v["scene"], "width": v["width"], "height": v["height"], "samplers": v["samplers"],
            "spp": v["spp"], "images": v["images"], "crop": v["crop"],
            "metric": None if v["metric"] is None else v["metric_label"]}


# ---------------------------------------------------------------------------------------------------
# The page
# ---------------------------------------------------------------------------------------------------

PLOT_CAPTIONS = (("rmse_vs_spp", "{E} vs samples per pixel"), ("rmse_vs_seconds", "{E} vs render time"),
                 ("efficiency", "Speed-up and efficiency against the baseline"))


def _study_section(k: int, study, views: list, plots: dict, tables: list[str]) -> str:
    E = study.metric_label
    parts = [f"<section><h2>Study: {html.escape(study.name)}</h2>"]
    if study.description:
        parts.append(f"<p>{_inline(study.description)}</p>")
    parts.append("<h3>Images</h3>")
    for j, v in enumerate(views):
        parts.append(f'<div class=viewer data-study="{k}" data-view="{j}"></div>')
    parts.append("<h3>Plots</h3>")
    for key, cap in PLOT_CAPTIONS:
        if key in plots and Path(plots[key]).is_file():
            c = html.escape(cap.format(E=E))
            parts.append(f'<figure><img alt="{c}" src="{_png_uri(plots[key])}">'
                         f"<figcaption>{c}</figcaption></figure>")
    parts.append("<h3>Samplers against the baseline</h3>")
    parts.append(markdown_to_html(tables))
    parts.append("</section>")
    return "\n".join(parts)


def _json_script(data) -> str:
    """JSON for a <script> element: no `</` may close it early."""
    return json.dumps(data, separators=(",", ":"), allow_nan=False).replace("</", "<\\/")


def write_report_html(exp, summary, plan, records: dict, out_dir: Path, gts: dict, plots: dict,
                      tables: dict, limit: int = MAX_IMAGE_BYTES) -> Path:
    """`report.html` in `out_dir`. `plots`: study name -> {plot kind: PNG file} (figures.plot_study);
    `tables`: study name -> report.md's lines of its tables (shown as report.md prints them)."""
    from drtlab.kernels.error_sums import REL_EPS
    out_dir = Path(out_dir)
    views, images, flips, notes = _viewers(exp, summary, plan, records, out_dir, gts, limit)
    data = {"studies": [[_view_json(v) for v in views.get(st.name, [])] for st in summary.studies],
            "images": images, "flip": flips, "colourmap": _colourmap(), "relEps": REL_EPS}
    title = f"Experiment {exp.name} (profile {exp.profile})"
    body = [f"<h1>{html.escape(title)}</h1>", f"<p>{_inline(exp.description or '')}</p>",
            "<p class=note>" + " ".join(html.escape(n) for n in notes) + " The full report with every "
            "table and its explanation is <code>report.md</code> beside this page.</p>"]
    for k, study in enumerate(summary.studies):
        body.append(_study_section(k, study, views.get(study.name, []), plots.get(study.name, {}),
                                   tables.get(study.name, [])))
    page = ("<!doctype html>\n<html lang=en><head><meta charset=utf-8>"
            "<meta name=viewport content='width=device-width, initial-scale=1'>"
            f"<title>{html.escape(title)}</title><style>{STYLE}</style></head><body>\n"
            + "\n".join(body) +
            f'\n<script type="application/json" id="drt-data">{_json_script(data)}</script>\n'
            f"<script>{SCRIPT}</script>\n</body></html>\n")
    path = out_dir / "report.html"
    atomic_write_text(path, page)
    return path
