"""report.html on the fake renderer: a tiny study's page is self-contained (nothing fetched, every
image and FLIP map inline) and complete (every scene, sampler and N); the default study's page (its
experiment file at 16 x 12 pixels) works in a real headless Chromium (its 12 viewers load, no
console error, no request beyond the file, a key flips the canvas, exposure brightens it, the crop
table's numbers are numpy's on the same float16 pixels, the FLIP map and the error maps differ). The
page's screenshot is kept under results/test-artefacts/."""
import base64
import re
import shutil

import numpy as np
import pytest

from repo_paths import REPO
from test_runner import run, tiny_experiment

SCREENSHOT = REPO / "results" / "test-artefacts" / "report-html.png"


@pytest.fixture(scope="module")
def tiny_report(tmp_path_factory):
    """One tiny study (two scenes, two samplers, four N) analysed with short chains: the slopes'
    precision does not matter here, only the files."""
    from drtlab.experiments.study import analysis
    tmp = tmp_path_factory.mktemp("report-html")
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(analysis, "STUDY_CHAIN", {"nsteps": 200, "burn": 50})
        exp = tiny_experiment(tmp)
        run(exp, tmp / "out", tmp / "gt", analyze=True)
    return tmp / "out"


@pytest.fixture(scope="module")
def default_report(tmp_path_factory):
    """The default study (experiments/studies/stratified.toml: two studies, six scenes, four
    samplers) on the fake renderer at 16 x 12 pixels and N = 1, 4, without its variance
    decompositions: the page `make experiment-stratified` writes, in miniature."""
    from drtlab.experiments.study import analysis
    from drtlab.experiments.study.config import EXPERIMENT_DIR
    text = (EXPERIMENT_DIR / "stratified.toml").read_text()
    text = (text[:text.index("[profile.quick]")] + "[profile.quick]\nspp = [1, 4]\nrepetitions = 3\n"
            "resolution = [16, 12]\ngt_spp = 1024\ngt_batch_spp = 256\n\n" + text[text.index("[profile.full]"):])
    text = re.sub(r"(?m)^variance_sources = .*$", "", text)
    tmp = tmp_path_factory.mktemp("default-report")
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(analysis, "STUDY_CHAIN", {"nsteps": 200, "burn": 50})
        run(tiny_experiment(tmp, text), tmp / "out", tmp / "gt", analyze=True)
    return tmp / "out"


def test_the_page_is_self_contained_and_complete(tiny_report):
    page = (tiny_report / "report.html").read_text()
    assert not re.search(r"""(src|href)\s*=\s*["']?\s*(https?:)?//""", page, re.I)
    assert "http://" not in page and "https://" not in page
    srcs = re.findall(r"""<img[^>]*\ssrc=["']([^"']*)""", page)
    assert len(srcs) == 3 and all(s.startswith("data:image/png;base64,") for s in srcs)
    for s in srcs:                  # each plot is the PNG file report.md links, byte for byte
        png = base64.b64decode(s.split(",", 1)[1])
        assert png.startswith(b"\x89PNG") and png in {p.read_bytes() for p in (tiny_report / "plots").iterdir()}
    import json
    data = json.loads(re.search(r'<script type="application/json" id="drt-data">(.*?)</script>', page, re.S)
                      .group(1).replace("<\\/", "</"))
    views = data["studies"][0]
    assert [v["scene"] for v in views] == ["aa-edges", "glossy"]
    for v in views:
        labels = [e["label"] for e in v["images"]]
        assert labels == ["reference"] + [f"{s} N={n}" for s in ("uniform", "stratified") for n in (1, 4, 16, 64)]
        for e in v["images"]:       # float16, 3 channels, the view's size
            assert len(base64.b64decode(data["images"][e["key"]])) == 2 * 3 * v["width"] * v["height"]
    # Each rendered image's FLIP map: flip_map against the reference, one byte a pixel.
    from drtlab.experiments.study.ground_truth import load_ground_truth
    from drtlab.experiments.study.metrics import flip_map
    from drtlab.experiments.study.run_store import first_image
    v = views[0]
    gt = load_ground_truth(next(d for d in (tiny_report.parent / "gt").iterdir() if "aa-edges" in d.name)).mean
    for e in v["images"][1:]:
        q = np.frombuffer(base64.b64decode(data["flip"][e["key"]]), np.uint8).reshape(v["height"], v["width"])
        assert np.abs(q / 255.0 - flip_map(first_image(tiny_report, e["key"]), gt)).max() <= 0.5 / 255 + 1e-6
    assert v["images"][0]["key"] not in data["flip"]
    # The tables are report.md's own: every comparison row's claim and numbers appear in the page.
    md = (tiny_report / "report.md").read_text()
    section = md.split("Every comparison with the baseline", 1)[1].split("</details>", 1)[0]
    rows = [line for line in section.splitlines() if line.startswith("| aa-edges | `stratified` | ")]
    assert len(rows) == 4
    for line in rows:
        cells = [c.strip().replace("`", "") for c in line.strip("|").split("|")]
        for c in cells:
            assert c.replace("**", "") in re.sub(r"<[^>]+>", "", page.replace("&#x27;", "'")), c


def test_an_image_budget_drops_the_largest_n_first():
    from drtlab.experiments.study.report_html import _budget, encoded_size
    one = encoded_size(16, 12)
    views = [{"width": 16, "height": 12, "cells": {(s, n): "c" for s in "ab" for n in (1, 4, 16)}}
             for _ in range(2)]
    # References (2) + N=1 (4 images) + N=4 (4) fit; N=16 would be 4 more.
    kept, dropped = _budget(views, 10 * one + one // 2)
    assert dropped == [16] and {k[2] for k in kept} == {1, 4} and len(kept) == 8


def _chromium():
    exe = shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")
    if exe is None:
        pytest.skip("no Chromium on PATH (Debian: apt-get install chromium)")
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        pytest.skip("playwright is not installed (pip install -e '.[dev]')")
    return exe, sync_playwright


CANVAS = "Array.from(window.drtViewers[0].ctx.getImageData(0, 0, {w}, {h}).data)"


def test_the_page_in_headless_chromium(request):
    exe, sync_playwright = _chromium()
    report = request.getfixturevalue("default_report")          # built only where a browser runs
    from drtlab.experiments.study.figures import choose_crop
    from drtlab.experiments.study.ground_truth import load_ground_truth
    html = report / "report.html"
    errors, requests = [], []
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=exe, args=["--no-sandbox"])
        try:
            page = browser.new_page(viewport={"width": 1280, "height": 900})
            page.on("console", lambda m: m.type == "error" and errors.append(m.text))
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.on("request", lambda r: requests.append(r.url))
            page.route(re.compile(r"^(?!file:|data:)"), lambda route: route.abort())
            page.goto(html.as_uri())
            page.wait_for_function("window.drtViewers && window.drtViewers.length === 12")  # 2 studies x 6 scenes
            w, h = page.evaluate("[window.drtViewers[0].W, window.drtViewers[0].H]")
            canvas = lambda: np.array(page.evaluate(CANVAS.format(w=w, h=h)), dtype=np.uint8).reshape(h, w, 4)  # noqa: E731
            reference = canvas()
            assert page.evaluate("window.drtViewers[0].v.images[window.drtViewers[0].cur].label") == "reference"
            page.keyboard.press("ArrowRight")              # the reference -> uniform N=1
            assert page.evaluate("window.drtViewers[0].v.images[window.drtViewers[0].cur].label") == "uniform N=1"
            flipped = canvas()
            assert np.any(flipped != reference)
            page.keyboard.press("0")                       # back: the same pixels again
            assert np.array_equal(canvas(), reference)
            for _ in range(4):                             # +2 stops: brighter, nothing darker
                page.keyboard.press("+")
            brighter = canvas()
            assert brighter[..., :3].astype(int).sum() > reference[..., :3].astype(int).sum()
            assert np.all(brighter[..., :3] >= reference[..., :3])
            # The crop table: whole-image and crop MSE of uniform N=1 against the reference, as numpy
            # computes them on the same float16 pixels (three significant digits shown).
            row = page.evaluate("Array.from(window.drtViewers[0].rows[1].children).map(c => c.textContent)")
            key = page.evaluate("window.drtViewers[0].v.images[1].key")
            gt_dir = next(d for d in (report.parent / "gt").iterdir() if "aa-edges" in d.name)
            gt = load_ground_truth(gt_dir).mean
            from drtlab.experiments.study.run_store import first_image
            x16, g16 = (a.astype(np.float16).astype(np.float64) for a in (first_image(report, key), gt))
            y, x, size = choose_crop(gt)
            crop = (slice(y, y + size), slice(x, x + size))
            assert float(row[3]) == pytest.approx(np.mean((x16 - g16) ** 2), rel=6e-3)
            assert float(row[1]) == pytest.approx(np.mean((x16[crop] - g16[crop]) ** 2), rel=6e-3)
            page.keyboard.press("ArrowRight")              # uniform N=1 again
            for _ in range(3):                             # E thrice: the FLIP map, linear 0 to 1
                page.keyboard.press("e")
            assert page.evaluate("window.drtViewers[0].mode") == "flip"
            flip_view = canvas()
            assert len(np.unique(flip_view.reshape(-1, 4), axis=0)) > 1      # not one flat colour
            page.keyboard.press("e")                       # ... and round to the image
            page.keyboard.press("e")                       # the relative-error map, with its scale
            assert np.any(canvas() != flip_view)
            assert page.is_visible(".viewer .cbar")
            SCREENSHOT.parent.mkdir(parents=True, exist_ok=True)
            page.screenshot(path=str(SCREENSHOT), full_page=True)
        finally:
            browser.close()
    assert not errors, errors
    assert all(u.startswith(("file:", "data:")) for u in requests), requests
    assert SCREENSHOT.stat().st_size > 0


def test_the_image_strips_carry_each_crops_flip(tiny_report):
    """Under each crop of a strip, its image's HDR-FLIP as the run table stores it (repetition 0)."""
    import pandas as pd
    from drtlab.experiments.study.figures import image_strip
    from drtlab.experiments.study.ground_truth import load_ground_truth
    runs = pd.read_parquet(tiny_report / "runs.parquet")
    first = runs[(runs["scene"] == "aa-edges") & (runs["rep"] == 0)]
    cells = {(r.sampler, r.spp): r.cell for r in first.itertuples()}
    flips = {(r.sampler, r.spp): r.flip for r in first.itertuples()}
    assert all(np.isfinite(v) and v > 0 for v in flips.values())
    gt = load_ground_truth(next(d for d in (tiny_report.parent / "gt").iterdir() if "aa-edges" in d.name)).mean
    fig = image_strip("aa-edges", ["uniform", "stratified"], [1, 4], gt, cells, tiny_report, None, flips)
    labels = {ax.get_xlabel() for ax in fig.axes} - {""}
    assert labels == {f"FLIP {flips[(s, n)]:.3f}" for s in ("uniform", "stratified") for n in (1, 4)}
