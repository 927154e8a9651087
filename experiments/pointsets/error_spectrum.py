"""Screen-space power spectrum of the error image: does a sampler's error look like white noise or
like blue noise (Ahmed & Wonka 2020, pbrt-v4's ZSobolSampler promise)?

    python -m drtlab.experiments.pointsets.error_spectrum results/pointsets --scene aa-edges --spp 64 \
        --samplers zsobol+importance,sobol+importance

reads the finished runs of an experiment folder (`run_store`) and the scene's reference
(`study/ground_truth`), and writes RESULTS_DIR/spectrum/error_spectrum.json and error_spectrum.png.

Per run (one repetition of (scene, sampler, spp)):
* error image e = luminance(run - reference) (Rec. 709 Y), mean removed;
* periodogram P(f) = |FFT2(e)|^2 / (W H) at the image's frequencies f = (i/W, j/H) cycles per pixel;
  for white error of variance s^2, E[P(f)] = s^2 at every f != 0 (the flat reference);
* radial spectrum: mean of P over the rings round(|f| / df) = 1, 2, ..., df = 1 / min(W, H) (ring
  r has radius r df; the corner (1/2, 1/2), a checkerboard, is the last ring);
* low-frequency fraction: power with 0 < |f| < cutoff * Nyquist (Nyquist = 1/2 cycle per pixel)
  over all power but DC. White error gives `white_fraction` (the share of frequencies under the
  cutoff); blue-noise error sits below it. The same fraction along one axis (|f_x| < cutoff * Nyq,
  any f_y; and transposed) separates diffusion along rows from diffusion along columns.
Over repetitions: means with standard errors (ring power) and Student-t 95% intervals (fractions,
error power); the comparison of each listed sampler with the first is a Welch interval of the
difference of fractions. The reference's own noise (white, of power ~ reference variance) adds to
every ring; it is recorded as `reference_noise_power`.
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

from drtlab.cli_args import Help, Parser, int_flag, run_main
from drtlab.errors import InputError
from drtlab.experiments.files import atomic_write_bytes, atomic_write_json
from drtlab.experiments.stats.hypothesis_tests import CI_LEVEL, welch_dof
from drtlab.experiments.study.metrics import mean_ci
from drtlab.experiments.pointsets.analysis import radial_average

DEFAULT_CUTOFF = 0.25                  # of Nyquist
DEFAULT_SAMPLERS = ("zsobol+importance", "sobol+importance")
OUT_SUBDIR = "spectrum"
JSON_FILE = "error_spectrum.json"
PNG_FILE = "error_spectrum.png"
NYQUIST = 0.5                          # cycles per pixel


# ---------------------------------------------------------------------------------------------------
# One error image
# ---------------------------------------------------------------------------------------------------

def _frequencies(shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """(H, W) arrays of f_y and f_x in cycles per pixel (numpy's FFT order)."""
    h, w = shape
    fy, fx = np.meshgrid(np.fft.fftfreq(h), np.fft.fftfreq(w), indexing="ij")
    return fy, fx


def ring_bins(shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """(bins (H, W) ring index of each frequency, -1 at DC; radii (K,) cycles per pixel of rings 1..K)."""
    h, w = shape
    fy, fx = _frequencies(shape)
    df = 1.0 / min(h, w)
    bins = np.rint(np.hypot(fx, fy) / df).astype(np.int64)
    bins[0, 0] = -1
    bins[bins == 0] = 1                 # cannot happen for df = 1/min(H, W); kept off DC regardless
    k = int(bins.max())
    return bins, df * np.arange(1, k + 1)


def periodogram2d(err: np.ndarray) -> np.ndarray:
    """(H, W) |FFT2(e - mean e)|^2 / (W H): E = variance at every f != 0 for white e."""
    e = np.asarray(err, dtype=np.float64)
    if e.ndim != 2 or min(e.shape) < 2:
        raise InputError("error image", f"must be a 2D array of at least 2 x 2 pixels, got shape {e.shape}")
    f = np.fft.fft2(e - e.mean())
    return (f.real ** 2 + f.imag ** 2) / e.size


def image_spectrum(err: np.ndarray, cutoff: float = DEFAULT_CUTOFF) -> dict:
    """Radial spectrum and low-frequency fractions of one error image."""
    p = periodogram2d(err)
    bins, radii = ring_bins(p.shape)
    fy, fx = _frequencies(p.shape)
    r = np.hypot(fx, fy)
    ac = bins >= 1                                         # everything but DC
    total = float(p[ac].sum())
    cut = cutoff * NYQUIST
    low = ac & (r < cut)

    def frac(mask):
        return float(p[mask].sum() / total) if total > 0 else float("nan")

    return {
        "radii": radii,
        "radial": radial_average(p, bins, len(radii)),
        "power": total / ac.sum(),                         # mean power per frequency = variance of e
        "low_fraction": frac(low),
        "low_fraction_x": frac(ac & (np.abs(fx) < cut)),
        "low_fraction_y": frac(ac & (np.abs(fy) < cut)),
        "white_fraction": float(low.sum() / ac.sum()),
        "white_fraction_x": float((ac & (np.abs(fx) < cut)).sum() / ac.sum()),
        "white_fraction_y": float((ac & (np.abs(fy) < cut)).sum() / ac.sum()),
    }


def spectrum_stats(error_images, cutoff: float = DEFAULT_CUTOFF) -> dict:
    """Over repetitions (error images of one shape): the radial spectrum's mean and standard error
    per ring, the fractions' and error power's mean with a Student-t interval."""
    imgs = [np.asarray(e, dtype=np.float64) for e in error_images]
    if not imgs:
        raise InputError("error images", "need at least one")
    if len({e.shape for e in imgs}) != 1:
        raise InputError("error images", f"must share one shape, got {sorted({e.shape for e in imgs})}")
    if not (isinstance(cutoff, (int, float)) and 0 < cutoff <= math.sqrt(2)):
        raise InputError("--cutoff", f"must be a fraction of Nyquist in (0, 1.414], got {cutoff!r}")
    per = [image_spectrum(e, cutoff) for e in imgs]
    radial = np.stack([s["radial"] for s in per])          # (R, K)
    n = len(per)
    se = radial.std(axis=0, ddof=1) / math.sqrt(n) if n > 1 else np.full(radial.shape[1], np.nan)
    out = {
        "repetitions": n,
        "shape": list(imgs[0].shape),
        "cutoff_of_nyquist": float(cutoff),
        "radii": per[0]["radii"].tolist(),
        "radial_mean": radial.mean(axis=0).tolist(),
        "radial_se": se.tolist(),
        "power": mean_ci([s["power"] for s in per]),
    }
    for key in ("low_fraction", "low_fraction_x", "low_fraction_y"):
        out[key] = mean_ci([s[key] for s in per])
        out[key]["values"] = [s[key] for s in per]
        out[key.replace("low", "white")] = per[0][key.replace("low", "white")]
    out["low_fraction_relative_to_white"] = (out["low_fraction"]["mean"] / out["white_fraction"]
                                             if out["white_fraction"] > 0 else float("nan"))
    return out


def welch_difference(a, b, level: float = CI_LEVEL) -> dict:
    """mean(a) - mean(b) with a Welch t interval (independent repetitions)."""
    from scipy.special import stdtrit
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    d = float(a.mean() - b.mean())
    if len(a) < 2 or len(b) < 2:
        return {"diff": d, "lo": float("nan"), "hi": float("nan")}
    va, vb = a.var(ddof=1) / len(a), b.var(ddof=1) / len(b)
    s = math.sqrt(va + vb)
    if s == 0:
        return {"diff": d, "lo": d, "hi": d}
    dof = welch_dof(va, len(a), vb, len(b))
    h = float(stdtrit(dof, 0.5 + level / 2)) * s
    return {"diff": d, "lo": d - h, "hi": d + h, "dof": dof}


# ---------------------------------------------------------------------------------------------------
# An experiment folder
# ---------------------------------------------------------------------------------------------------

def _canonical(name: str) -> str | None:
    try:
        from drtlab.estimators.registry import parse_sampler
        return parse_sampler(name).name
    except Exception:                                      # noqa: BLE001 - unknown is reported below
        return None


def _reference_dir(results_dir: Path, rec: dict, gt_root: Path | None) -> Path:
    name = f"{rec['scene_key']}__{rec['integrator']}__{rec['width']}x{rec['height']}"
    candidates = []
    if gt_root is not None:
        candidates.append(Path(gt_root) / name)
    try:
        import json
        m = json.loads((results_dir / "manifest.json").read_text())
        candidates += [Path(d) for d in m.get("seeds", {}).get("ground_truth", {}) if Path(d).name == name]
    except (OSError, ValueError):
        pass
    from drtlab.experiments.paths import default_gt_root
    candidates.append(default_gt_root() / name)
    for c in candidates:
        if (c / "gt.npz").is_file():
            return c
    raise InputError("--gt-dir", f"no reference '{name}' (looked in {', '.join(str(c.parent) for c in candidates)})")


def error_spectra(results_dir, scene: str, spp: int, samplers=DEFAULT_SAMPLERS,
                  cutoff: float = DEFAULT_CUTOFF, gt_root=None) -> dict:
    """The error spectrum of each sampler's runs of (scene, spp) in a finished experiment folder."""
    from drtlab.experiments.study.ground_truth import load_ground_truth
    from drtlab.experiments.study.run_store import cell_images, load_records
    from drtlab.kernels.colour import luminance

    results_dir = Path(results_dir)
    records = load_records(results_dir) if results_dir.is_dir() else {}
    if not records:
        raise InputError("RESULTS_DIR", f"no finished experiment runs in '{results_dir}' "
                                        f"(expected the folder `drtlab experiment` wrote, with runs.parquet)")
    recs = list(records.values())
    scenes = sorted({r["scene"] for r in recs})
    if scene not in scenes:
        raise InputError("--scene", f"'{scene}' is not a scene of this experiment; it has {', '.join(scenes)}")
    recs = [r for r in recs if r["scene"] == scene]
    have = sorted({r["sampler"] for r in recs})
    samplers = list(samplers)
    if not samplers:
        raise InputError("--samplers", "give at least one sampler")
    names = []
    for s in samplers:
        name = s if s in have else _canonical(s)
        if name not in have:
            raise InputError("--samplers", f"'{s}' has no runs of scene '{scene}'; samplers run: {', '.join(have)}")
        if name in names:
            raise InputError("--samplers", f"'{s}' is listed twice")
        names.append(name)
    for name in names:
        ladder = sorted({r["spp"] for r in recs if r["sampler"] == name})
        if spp not in ladder:
            raise InputError("--spp", f"{spp} is not on the experiment's spp ladder for {scene} / {name}: {ladder}")
    gt_dir = _reference_dir(results_dir, next(r for r in recs if r["spp"] == spp), gt_root)
    gt = load_ground_truth(gt_dir)
    ref_y = luminance(gt.mean)
    out = {"results_dir": str(results_dir), "scene": scene, "spp": spp, "cutoff_of_nyquist": cutoff,
           "reference": {"dir": str(gt_dir), "spp": gt.spp, "key": gt.manifest.get("key")},
           "reference_noise_power": float(np.mean(luminance(gt.stderr) ** 2)),
           "samplers": {}, "comparisons": []}
    stale = False
    for name in names:
        rs = sorted((r for r in recs if r["sampler"] == name and r["spp"] == spp), key=lambda r: r["rep"])
        stale |= any(r.get("gt_key") != gt.manifest.get("key") for r in rs)
        kept = cell_images(results_dir, rs[0]["cell"])
        if kept is None:
            raise InputError("RESULTS_DIR", f"'{results_dir}' keeps no per-run images of {scene} / "
                                            f"{name}; rerun the experiment with --keep-images (or "
                                            f"keep_images = true in its file)")
        by_rep = dict(zip(kept[0].tolist(), kept[1]))
        errs = [luminance(by_rep[r["rep"]]) - ref_y for r in rs]
        st = spectrum_stats(errs, cutoff)
        st["run_ids"] = [r["run_id"] for r in rs]
        st["rmse_luminance"] = mean_ci([float(np.sqrt(np.mean(e ** 2))) for e in errs])
        out["samplers"][name] = st
    out["reference_matches_runs"] = not stale
    first = names[0]
    for other in names[1:]:
        a, b = out["samplers"][first], out["samplers"][other]
        out["comparisons"].append({
            "sampler": first, "versus": other,
            **{f"{k}_difference": welch_difference(a[k]["values"], b[k]["values"])
               for k in ("low_fraction", "low_fraction_x", "low_fraction_y")},
            "power_ratio": a["power"]["mean"] / b["power"]["mean"] if b["power"]["mean"] > 0 else float("nan"),
        })
    return out


def spectrum_png(result: dict) -> bytes:
    from drtlab.experiments.plotting import compact_pyplot, png_bytes
    plt = compact_pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.2), dpi=110)
    for i, (name, st) in enumerate(result["samplers"].items()):
        r, m = np.asarray(st["radii"]), np.asarray(st["radial_mean"])
        se = np.nan_to_num(np.asarray(st["radial_se"]))
        c = f"C{i}"
        lf = st["low_fraction"]
        ax.plot(r, m, color=c, lw=1.5, label=f"{name}: low-freq. {lf['mean']:.3f} "
                                            f"[{lf['lo']:.3f}, {lf['hi']:.3f}]")
        ax.fill_between(r, np.maximum(m - se, m * 1e-3), m + se, color=c, alpha=0.2, lw=0)
        ax.axhline(st["power"]["mean"], color=c, ls=":", lw=1)
    ax.axvline(result["cutoff_of_nyquist"] * NYQUIST, color="0.4", ls="--", lw=1)
    ax.axhline(result["reference_noise_power"], color="0.6", ls="-.", lw=1, label="reference noise")
    ax.set_yscale("log")
    ax.set_xlabel("radial frequency |f| (cycles / pixel; Nyquist 0.5, corner 0.707)")
    ax.set_ylabel("error power (luminance$^2$)")
    st0 = next(iter(result["samplers"].values()))
    ax.set_title(f"{result['scene']}, {result['spp']} spp, {st0['shape'][1]}x{st0['shape'][0]}, "
                 f"{st0['repetitions']} reps (band: ±1 se; dotted: white level)", fontsize=9)
    ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    return png_bytes(fig)


def write_spectrum(result: dict, out_dir: Path) -> list[Path]:
    out_dir = Path(out_dir)
    png = spectrum_png(result)               # before anything is written
    out_dir.mkdir(parents=True, exist_ok=True)
    atomic_write_json(out_dir / JSON_FILE, result)
    atomic_write_bytes(out_dir / PNG_FILE, png)
    return [out_dir / JSON_FILE, out_dir / PNG_FILE]


# ---------------------------------------------------------------------------------------------------
# Command line
# ---------------------------------------------------------------------------------------------------

def build_parser() -> Parser:
    p = Parser(prog="python -m drtlab.experiments.pointsets.error_spectrum", formatter_class=Help,
               description="Screen-space power spectrum of the error images of a finished experiment "
                           "(run - reference luminance), per sampler, with its low-frequency fraction.")
    p.add_argument("results_dir", type=Path, metavar="RESULTS_DIR", help="an experiment's output folder")
    p.add_argument("--scene", required=True, help="scene label in the experiment")
    p.add_argument("--spp", required=True, type=int_flag(1), help="a sample count on the experiment's ladder")
    p.add_argument("--samplers", default=",".join(DEFAULT_SAMPLERS),
                   help="comma-separated samplers; the first is compared with each other one")
    p.add_argument("--cutoff", type=float, default=DEFAULT_CUTOFF,
                   help="low-frequency radius as a fraction of Nyquist")
    p.add_argument("--gt-dir", type=Path, default=None, help="ground-truth cache (default: as the run)")
    p.set_defaults(func=_command)
    return p


def _command(args) -> int:
    samplers = [s.strip() for s in args.samplers.split(",") if s.strip()]
    if not 0 < args.cutoff <= math.sqrt(2):
        raise InputError("--cutoff", f"must be a fraction of Nyquist in (0, 1.414], got {args.cutoff}")
    result = error_spectra(args.results_dir, args.scene, args.spp, samplers, args.cutoff, args.gt_dir)
    files = write_spectrum(result, Path(args.results_dir) / OUT_SUBDIR)
    for name, st in result["samplers"].items():
        lf = st["low_fraction"]
        print(f"{name}: low-frequency fraction {lf['mean']:.4f} [{lf['lo']:.4f}, {lf['hi']:.4f}] "
              f"(white {st['white_fraction']:.4f}), error power {st['power']['mean']:.3g}", file=sys.stderr)
    print(f"error_spectrum: wrote {', '.join(str(f) for f in files)}", file=sys.stderr)
    return 0


def main(argv: list[str] | None = None) -> int:
    return run_main(build_parser, argv)


if __name__ == "__main__":
    sys.exit(main())
