"""`make crosscheck-suite`: Mitsuba 3's own render-test scenes against Mitsuba's reference images.

The suite (`../shared/mitsuba-tests` beside the checkout, or $DRTLAB_MITSUBA_TESTS, or --suite-dir)
holds Mitsuba 3's regression scenes `tests/scenes/*/NAME_INTEGRATOR.xml` and, per scene, Mitsuba's
reference `refs/NAME_ref_rgb.exr` with its per-pixel variance of one sample `refs/NAME_ref_rgb_var.exr`
(what Mitsuba's `moment` integrator records). Every scene drtlab loads is rendered at its own
resolution (independent samples, as its sampler) and judged by two rules:

- channel means: each within 1% of the reference's, or within 3 standard errors (the render's own,
  from its per-pixel sample variance, or from its batches where it splats): a correct render fails a channel's 3-sigma test with
  probability 0.27%, so 3 channels of the 6 scenes that load today fail one with at most 4.9%
  (Bonferroni), less with the 1% allowance; the seed is fixed, so a run repeats exactly;
- block L1: the mean absolute difference of the 4 x 4-pixel block means, over the reference's mean,
  at most 1.5 times the L1 Mitsuba's own render of the same spp has against the reference: measured,
  the mean over 4 seeds of Mitsuba 3.9.1's renders (suite_baseline.py, committed as
  suite_baseline.json) where the baseline has that spp; otherwise predicted from the reference's
  variance image (each block mean of an spp-sample render is Gaussian with variance sum(var) /
  (16^2 spp), its expected |error| that sd times sqrt(2 / pi)), which leaves the reference's own
  noise out and so is a lower bound. It leaves out the reference's float32 rounding too: a pixel
  whose samples are all equal (a constant background seen directly) is its film's float32 sum of
  32000 equal XYZ samples, up to 1e-3 off the exact value, an offset Mitsuba's own renders carry
  into their measured L1 as drtlab's do.

Every scene is rendered RUNS times with independent seeds, each at the given spp: the L1 rule holds
their mean block L1 to Mitsuba's mean over its seeds; the channel means pool them. A scene whose
film filter is not the box is rendered as Mitsuba renders it: every sample splatted into each pixel
its filter reaches (drtlab's `+splat` pixel estimator); the spread of its runs' channel means gives
their standard errors. Filter importance sampling, drtlab's
default, has the same expectation but 2-3x the block L1 of Mitsuba's splatting (measured on
texture_interp, whose sharp texture the Gaussian filter spreads), and the rule compares noise.

A scene drtlab does not load is listed with the one-line refusal, not judged. Writes
results/mitsuba-suite/suite.json and suite.md (the table, also printed); --docs PATH writes the table
as a documentation page. Exit 0 when every loaded scene agrees, 1 otherwise.
"""
from __future__ import annotations

import json
import math
import os
import re
import sys
from pathlib import Path

import numpy as np

from drtlab.cli_args import Help, Parser, int_flag, run_main
from drtlab.errors import InputError
from drtlab.experiments.bench.mitsuba.crosscheck_stats import block_means
from drtlab.experiments.files import atomic_write_text
from drtlab.experiments.paths import results_root

REPO = Path(__file__).resolve().parents[3]
BASELINE = Path(__file__).with_name("suite_baseline.json")      # written by suite_baseline.py
BLOCK = 4
REL_TOL, Z_TOL, L1_RATIO_TOL = 0.01, 3.0, 1.5
SAMPLER = "independent+importance"
# Independent renders per scene: a render's block L1 varies (0.0027-0.0068 over 12 seeds of one scene
# at 256 spp, where few blocks hold its noise), so the rule compares the mean over RUNS renders
# with the mean of Mitsuba's own over its SEEDS (suite_baseline.py).
RUNS = 4
COMMAND = "make crosscheck-suite"
DOCS_HEAD = """# Mitsuba 3's test scenes in drtlab

Mitsuba 3's render regression scenes (its `tests/scenes`: `../shared/mitsuba-tests` beside the
checkout, or `$DRTLAB_MITSUBA_TESTS`), loaded by drtlab, rendered at their own resolution with
independent samples and compared with Mitsuba's reference images (`refs/NAME_ref_rgb.exr`). Mitsuba
3.9.1's own renders of each scene at the same spp (4 seeds; `python -m
drtlab.experiments.bench.mitsuba.suite_baseline` measures them) give the mean L1 that 4 renders of
drtlab's are held to. Regenerate this page with

```sh
{command} SUITE_ARGS='--spp {spp} --docs docs/mitsuba-suite.md'
```

"""


def suite_dir() -> Path:
    """Where the suite lies: $DRTLAB_MITSUBA_TESTS, else ../shared/mitsuba-tests beside the checkout."""
    env = os.environ.get("DRTLAB_MITSUBA_TESTS")
    return Path(env) if env else REPO.parent / "shared" / "mitsuba-tests"


def scenes(root: Path) -> list[dict]:
    """Every scene of the suite, by name: its file and its reference and variance images."""
    out = []
    for xml in sorted((root / "tests" / "scenes").glob("*/*.xml")):
        stem = xml.stem.rsplit("_", 1)[0]
        refs = xml.parent / "refs"
        out.append({"name": xml.stem, "file": xml, "ref": refs / f"{stem}_ref_rgb.exr",
                    "var": refs / f"{stem}_ref_rgb_var.exr"})
    return out


def load(job: dict):
    """(the drtlab Scene, None) or (None, the one-line refusal)."""
    from drtlab.kernels.scene_model.scene_file import load_scene
    try:
        return load_scene(job["file"]), None
    except InputError as exc:
        return None, str(exc).split(": ", 1)[-1] if str(exc).startswith(str(job["file"])) else str(exc)


def read_baseline(path: Path = BASELINE) -> dict:
    """{spp: {scene: mean L1 of Mitsuba's renders}} of the committed baseline ({} where none)."""
    if not path.is_file():
        return {}
    data = json.loads(path.read_text())
    return {int(spp): {name: float(np.mean(v)) for name, v in rows.items()}
            for spp, rows in data["l1"].items()}


def predicted_l1(var: np.ndarray, spp: int, mean: float, block: int = BLOCK) -> float:
    """The block L1 (over `mean`) an spp-sample render with per-sample variance `var` has against
    the expectation: sqrt(2 / pi) times each block mean's standard deviation, averaged."""
    # A block of n pixels: its mean's variance is (sum of var) / (n^2 spp) = mean(var) / (n spp).
    sd = np.sqrt(np.maximum(block_means(var, block), 0.0) / (_block_counts(var.shape, block) * spp))
    return float(np.mean(sd) * math.sqrt(2.0 / math.pi) / mean)


def _block_counts(shape, block: int) -> np.ndarray:
    h, w = shape[:2]
    rows = np.diff(np.append(np.arange(0, h, block), h))
    cols = np.diff(np.append(np.arange(0, w, block), w))
    return np.outer(rows, cols)[..., None].astype(np.float64)


def channel_se(variance: np.ndarray, spp: int) -> list[float]:
    """The standard error of each channel's image mean, from the per-pixel sample variance."""
    npix = variance.shape[0] * variance.shape[1]
    return [math.sqrt(float(variance[..., c].sum()) / spp) / npix for c in range(3)]


def judge(image: np.ndarray, se: list[float], spp: int, ref: np.ndarray, ref_var: np.ndarray,
          measured: float | None = None, z_tol: float = Z_TOL, rel_tol: float = REL_TOL) -> dict:
    """The two rules on independent renders of spp samples each (`image`: one (H, W, 3) or several
    (R, H, W, 3); `se`: the standard errors of their channel means) against the reference: their
    channel means, and their mean block L1 against `measured`, the mean L1 of Mitsuba's own
    spp-sample renders (the baseline), else the predicted one; `z_tol` the channel means' standard
    errors allowed beyond `rel_tol` (a caller judging many scenes at once corrects it for their
    number; one at fewer spp than the rule's 256 widens rel_tol as the noise, by sqrt(256 / spp))."""
    runs = image[None] if image.ndim == 3 else image
    image = runs.mean(axis=0)
    channels = []
    for c in range(3):
        d, m = float(image[..., c].mean()), float(ref[..., c].mean())
        se_c = se[c]
        rel = abs(d - m) / abs(m) if m else (0.0 if d == m else math.inf)
        channels.append({"channel": "RGB"[c], "drtlab": d, "reference": m, "se": se_c,
                         "relative_difference": rel, "ok": bool(rel <= rel_tol or abs(d - m) <= z_tol * se_c)})
    mean = float(ref.mean())
    ref_blocks = block_means(ref, BLOCK)
    l1 = float(np.mean([np.mean(np.abs(block_means(r, BLOCK) - ref_blocks)) for r in runs])) / mean
    predicted = predicted_l1(ref_var, spp, mean)
    expected = measured if measured is not None else predicted
    ratio = l1 / expected if expected > 0 else (1.0 if l1 == 0 else math.inf)
    ok_l1 = bool(ratio <= L1_RATIO_TOL)
    why = [f"{c['channel']} mean {c['relative_difference']:.2%} off" for c in channels if not c["ok"]]
    if not ok_l1:
        why.append(f"block L1 {ratio:.2f}x Mitsuba's")
    return {"channels": channels, "block_l1": l1, "mitsuba_l1": expected,
            "mitsuba_l1_source": "measured" if measured is not None else "predicted",
            "mitsuba_l1_predicted": predicted, "l1_ratio": ratio,
            "agrees": all(c["ok"] for c in channels) and ok_l1, "why_not": "; ".join(why)}


def run_scene(job: dict, spp: int, seed: int = 0, threads: int | None = None, z_tol: float = Z_TOL,
              rel_tol: float = REL_TOL, runs: int = RUNS) -> dict:
    """One scene: loaded or refused; rendered at its own resolution and judged when loaded."""
    from drtlab.kernels.imageio import read_linear
    scene, refusal = load(job)
    row = {"scene": job["name"], "loaded": scene is not None, "refusal": refusal}
    if scene is None:
        return row
    ref = read_linear(job["ref"])[0][..., :3].astype(np.float64)
    var = read_linear(job["var"])[0][..., :3].astype(np.float64)
    images, se, seconds, estimator = render(scene, spp, seed, threads, runs)
    if images.shape[1:] != ref.shape:
        row.update(agrees=False, why_not=f"image {images.shape[1:3]} against the reference's {ref.shape[:2]}")
        return row
    measured = read_baseline().get(spp, {}).get(job["name"])
    row.update(judge(images, se, spp, ref, var, measured, z_tol, rel_tol), spp=spp, runs=runs, pixel_estimator=estimator,
               resolution=[scene.width, scene.height], render_seconds=round(seconds, 2))
    return row


def render(scene, spp: int, seed: int, threads: int | None, runs: int = RUNS):
    """(`runs` independent spp-sample images (R, H, W, 3), the standard errors of their pooled channel
    means, seconds, the pixel estimator): from their sample variance; with a filter other than the
    box, splatted (Mitsuba's estimator), from the spread of the runs' channel means."""
    from drtlab.kernels.filters import BOX
    from drtlab.kernels.render import render_batch_with_stats
    seeds = [seed * runs + k for k in range(runs)]
    if scene.camera.filter == BOX:
        b = render_batch_with_stats(scene, seeds, spp=spp, sampler=SAMPLER, threads=threads,
                                    progress=False, variance=True)
        se = [x / math.sqrt(runs) for x in channel_se(np.mean(b.variances, axis=0), spp)]
        return b.images, se, b.render_seconds, "fis"
    b = render_batch_with_stats(scene, seeds, spp=spp, sampler=SAMPLER + "+splat", threads=threads,
                                progress=False)
    se = list(b.images.mean(axis=(1, 2)).std(axis=0, ddof=1) / math.sqrt(runs))
    return b.images, se, b.render_seconds, "splat"


def short(refusal: str) -> str:
    """A refusal for the table: its element's path and what is wrong, without the file's name and
    the list of what is supported."""
    text = re.sub(r"^[^:/]+\.xml: ", "", refusal)
    return re.sub(r" \((supported|drtlab reads|drtlab has)[^()]*(\([^()]*\)[^()]*)*\)$", "", text)


def markdown(rows: list[dict], spp: int) -> str:
    loaded = [r for r in rows if r["loaded"]]
    agree = [r for r in loaded if r.get("agrees")]
    lines = [f"{len(loaded)} of {len(rows)} scenes load; {len(agree)} of them agree with Mitsuba's",
             f"reference at {spp} spp (channel means within {REL_TOL:.0%} or {Z_TOL:g} standard errors;",
             f"the mean block L1 of {RUNS} renders ({BLOCK}x{BLOCK} blocks) at most {L1_RATIO_TOL}x "
             f"the mean L1 of Mitsuba's own {spp}-spp renders", "against the reference: measured, or "
             "predicted from the reference's variance image where marked *).", "",
             "| scene | loaded | agrees | block L1 (Mitsuba's) | ratio | why not |",
             "|---|---|---|---|---|---|"]
    for r in rows:
        if not r["loaded"]:
            lines.append(f"| {r['scene']} | no | | | | {short(r['refusal']).replace('|', '/')} |")
        else:
            lines.append(f"| {r['scene']} | yes | {'yes' if r.get('agrees') else 'no'} | "
                         f"{r.get('block_l1', math.nan):.4f} ({r.get('mitsuba_l1', math.nan):.4f}"
                         f"{'*' if r.get('mitsuba_l1_source') == 'predicted' else ''}) | "
                         f"{r.get('l1_ratio', math.nan):.2f} | {r.get('why_not', '')} |")
    return "\n".join(lines) + "\n"


def build_parser() -> Parser:
    p = Parser(prog="python -m drtlab.experiments.bench.mitsuba.suite", formatter_class=Help,
               description="Mitsuba 3's render-test scenes: which drtlab loads, and whether each "
                           "agrees with Mitsuba's reference image.")
    p.add_argument("--spp", type=int_flag(1, 1 << 20), default=256, help="samples per pixel of each render")
    p.add_argument("--suite-dir", type=Path, default=None, help="the suite's folder (default: "
                   "$DRTLAB_MITSUBA_TESTS or ../shared/mitsuba-tests beside the checkout)")
    p.add_argument("--only", action="append", default=None, metavar="NAME", help="this scene only (repeatable)")
    p.add_argument("--docs", type=Path, default=None, help="also write the table as this Markdown page")
    p.add_argument("--out-dir", type=Path, default=results_root() / "mitsuba-suite", help="folder written")
    p.set_defaults(func=_command)
    return p


def _command(args) -> int:
    root = args.suite_dir or suite_dir()
    if not (root / "tests" / "scenes").is_dir():
        print(f"crosscheck-suite: no Mitsuba test suite at {root}; skipped", file=sys.stderr)
        return 0
    jobs = [j for j in scenes(root) if not args.only or j["name"] in args.only]
    rows = []
    for job in jobs:
        rows.append(run_scene(job, args.spp))
        print(f"crosscheck-suite: {job['name']}: " + ("refused" if not rows[-1]["loaded"] else
              "agrees" if rows[-1]["agrees"] else f"differs ({rows[-1]['why_not']})"), file=sys.stderr)
    table = markdown(rows, args.spp)
    args.out_dir.mkdir(parents=True, exist_ok=True)
    atomic_write_text(args.out_dir / "suite.json", json.dumps(rows, indent=1, default=str) + "\n")
    atomic_write_text(args.out_dir / "suite.md", table)
    if args.docs is not None:
        atomic_write_text(args.docs, DOCS_HEAD.format(command=COMMAND, spp=args.spp) + table)
    print(table)
    return 0 if all(r.get("agrees") for r in rows if r["loaded"]) else 1


def main(argv: list[str] | None = None) -> int:
    return run_main(build_parser, argv)


if __name__ == "__main__":
    sys.exit(main())
