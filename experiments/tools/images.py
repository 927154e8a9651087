"""Image tools in the spirit of pbrt-v4's `imgtool`: what an EXR holds (`info`) and how two images
differ (`compare`), with the same metrics the experiments report.

A standard-error image travels beside its mean: `X.stderr.exr` next to `X.exr` (what
`drtlab render --variance` writes), or `stderr.exr` next to a ground truth's `mean.exr`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from drtlab import fields
from drtlab.errors import InputError


def rgb(pixels: np.ndarray, path, field_name: str) -> np.ndarray:
    """An image's pixels as RGB for `compare`: 3 channels as they are (a 4th, alpha, and more
    dropped), one grey channel as R = G = B; 2 channels (grey and alpha? red and green?) refused."""
    channels = pixels.shape[2]
    if channels == 1:
        return np.repeat(pixels, 3, axis=2)
    if channels == 2:
        raise InputError(field_name, f"{path} has 2 channels: compare reads RGB images (3 channels; "
                                     f"a 4th, alpha, is left out) or grey ones (1 channel, as R = G = B)")
    return pixels[..., :3]


def read_image(path, field_name: str) -> tuple[np.ndarray, dict]:
    """(H, W, C) linear float32 pixels (8-bit sRGB files decoded) and drtlab metadata; a missing or
    unreadable file is an InputError."""
    return _read_stored(path, field_name)[:2]


def _read_stored(path, field_name: str) -> tuple[np.ndarray, dict, str]:
    from drtlab.kernels.imageio import read_linear
    p = fields.existing_file(path, field_name, "an image file")
    try:
        return read_linear(p)
    except OSError as exc:
        raise InputError(field_name, f"cannot read '{path}' as an image: "
                                     f"{str(exc).splitlines()[0] if str(exc) else 'unknown format'}") from None


def stderr_beside(path) -> Path | None:
    """The standard-error image stored beside `path`, if there is one."""
    p = Path(path)
    for candidate in (p.with_name(p.stem + ".stderr.exr"),
                      p.with_name("stderr.exr") if p.name == "mean.exr" else None):
        if candidate is not None and candidate.is_file():
            return candidate
    return None


# ---------------------------------------------------------------------------------------------------
# info
# ---------------------------------------------------------------------------------------------------

@dataclass
class ChannelStats:
    name: str
    min: float
    max: float
    mean: float
    nan: int
    inf: int
    negative: int


@dataclass
class ImageInfo:
    path: str
    width: int
    height: int
    channels: list[ChannelStats]
    metadata: dict = field(default_factory=dict)
    stored: str = "float32"         # the file's pixel type (kernels.imageio.read_linear)

    def lines(self) -> list[str]:
        out = [f"{self.path}: {self.width}x{self.height}, {len(self.channels)} channels ({self.stored})"]
        out.append(f"  {'channel':8s} {'min':>12s} {'max':>12s} {'mean':>12s} {'NaN':>6s} {'Inf':>6s} "
                   f"{'<0':>6s}")
        for c in self.channels:
            out.append(f"  {c.name:8s} {c.min:12.6g} {c.max:12.6g} {c.mean:12.6g} {c.nan:6d} "
                       f"{c.inf:6d} {c.negative:6d}")
        for key in sorted(self.metadata):
            out.append(f"  drtlab:{key} = {self.metadata[key]}")
        return out


def image_info(path) -> ImageInfo:
    pixels, meta, stored = _read_stored(path, "FILE")
    h, w = pixels.shape[:2]
    planes = pixels.reshape(h, w, -1)
    names = "RGBA" if planes.shape[2] <= 4 else [f"c{i}" for i in range(planes.shape[2])]
    channels = []
    for i in range(planes.shape[2]):
        x = planes[..., i].astype(np.float64)
        finite = x[np.isfinite(x)]
        channels.append(ChannelStats(
            name=names[i], min=float(finite.min()) if finite.size else math.nan,
            max=float(finite.max()) if finite.size else math.nan,
            mean=float(finite.mean()) if finite.size else math.nan,
            nan=int(np.isnan(x).sum()), inf=int(np.isinf(x).sum()), negative=int((x < 0).sum())))
    return ImageInfo(path=str(path), width=w, height=h, channels=channels, metadata=meta, stored=stored)


# ---------------------------------------------------------------------------------------------------
# compare
# ---------------------------------------------------------------------------------------------------

@dataclass
class ZScores:
    """Per-pixel (A - B) / sqrt(se_A^2 + se_B^2) where the two agree within their noise: Student's t
    at the Welch-Satterthwaite degrees of freedom of the two standard errors (each estimated from
    the number of samples or batches its image's metadata gives; unknown counts as infinite, N(0, 1))."""
    mean: float
    sd: float
    sd_expected: float              # sd of that t (1 for N(0, 1))
    beyond_3: float                 # fraction of |z| > 3 (0.0027 for N(0, 1))
    ks_pvalue: float                # Kolmogorov-Smirnov test against that t, pixel by pixel
    pixels: int
    dropped: int                    # values without a standard error (zero), left out of it all
    image: np.ndarray | None = None     # (H, W, 3) z, NaN where dropped


@dataclass
class Comparison:
    image: str
    reference: str
    rmse: float
    relmse: float
    mae: float
    ciede2000: float
    mean_error: float
    z: ZScores | None = None

    def line(self) -> str:
        text = (f"{self.image} vs {self.reference}: RMSE {self.rmse:.6g}, relMSE {self.relmse:.6g}, "
                f"MAE {self.mae:.6g}, CIEDE2000 {self.ciede2000:.4g}, mean error {self.mean_error:+.6g}")
        if self.z is not None:
            z = self.z
            text += (f"; z: mean {z.mean:+.3f}, sd {z.sd:.3f} (expected {z.sd_expected:.3f}), "
                     f"|z|>3 {100 * z.beyond_3:.2f}%, KS p {z.ks_pvalue:.3g} ({z.pixels} values"
                     f"{f'; {z.dropped} with zero standard error dropped' if z.dropped else ''})")
        return text


def samples_behind(meta: dict) -> int | None:
    """How many independent values a standard-error image was estimated from: a ground truth's
    batches, or a render's spp (`drtlab render --variance`); None when its metadata does not say."""
    for key in ("batches", "spp"):
        if isinstance(meta.get(key), (int, np.integer)) and meta[key] >= 2:
            return int(meta[key])
    return None


def z_scores(a: np.ndarray, b: np.ndarray, se_a: np.ndarray | None, se_b: np.ndarray,
             n_a: int | None = None, n_b: int | None = None) -> ZScores:
    """ZScores of `a` against `b` with their standard errors, estimated from n_a and n_b values."""
    from scipy import stats
    from drtlab.experiments.stats.hypothesis_tests import welch_dof
    var_b = np.square(se_b.astype(np.float64))
    var_a = np.zeros_like(var_b) if se_a is None else np.square(se_a.astype(np.float64))
    var = var_a + var_b
    ok = var > 0
    z_image = np.full(var.shape, np.nan)
    z_image[ok] = (a.astype(np.float64) - b.astype(np.float64))[ok] / np.sqrt(var[ok])
    z = z_image[ok]
    if z.size == 0:
        raise InputError("--per-pixel-z", "the standard error is zero everywhere")
    huge = 1e12                             # an unknown count: the estimate is taken as exact
    with np.errstate(divide="ignore", invalid="ignore"):
        dof = welch_dof(var_a[ok], n_a or huge, var_b[ok], n_b or huge)
    dof = np.where(np.isfinite(dof), dof, huge)
    t = dof > 2.05                           # t's variance exists only for dof > 2
    sd_expected = float(np.sqrt(np.mean(dof[t] / (dof[t] - 2)))) if t.any() else float("nan")
    return ZScores(mean=float(z.mean()), sd=float(z.std()), sd_expected=sd_expected,
                   beyond_3=float(np.mean(np.abs(z) > 3)),
                   ks_pvalue=float(stats.kstest(stats.t.cdf(z, dof), "uniform").pvalue),
                   pixels=int(z.size), dropped=int((~ok).sum()), image=z_image)


def compare_images(a: np.ndarray, b: np.ndarray, *, names=("A", "B"), se_a=None, se_b=None,
                   n_a: int | None = None, n_b: int | None = None) -> Comparison:
    """Metrics of image `a` against reference `b` (RGB, (H, W, 3)); z-scores when `se_b` is given
    (standard errors estimated from n_a and n_b values, see `z_scores`)."""
    from drtlab.experiments.study.metrics import image_metrics
    a3, b3 = np.asarray(a, dtype=np.float64)[..., :3], np.asarray(b, dtype=np.float64)[..., :3]
    if a3.shape[:2] == b3.shape[:2] and a3.shape != b3.shape:
        raise InputError("B", f"{names[1]} has {np.shape(b)[-1]} channels but {names[0]} has "
                              f"{np.shape(a)[-1]}: images must have the same channels (R, G, B)")
    if a3.shape != b3.shape:
        raise InputError("B", f"{names[1]} is {b3.shape[1]}x{b3.shape[0]} but {names[0]} is "
                              f"{a3.shape[1]}x{a3.shape[0]}: images must have the same resolution")
    m = image_metrics(a3, b3, np.zeros_like(b3))
    z = None if se_b is None else z_scores(a3, b3, None if se_a is None else se_a[..., :3],
                                           se_b[..., :3], n_a, n_b)
    return Comparison(image=names[0], reference=names[1], rmse=m["rmse"], relmse=m["relmse"],
                      mae=m["mae"], ciede2000=m["ciede2000"], mean_error=m["mean_error"], z=z)


def pair_stems(pairs: list[tuple[str, str]], fields: tuple[str, ...]) -> list[str]:
    """The output stem of each (image, reference) pair, `IMAGE-vs-REFERENCE` by file stems; where
    two pairs would share one, their images are named by as many trailing folders as tell them
    apart (`run1_img-vs-c`, `run2_img-vs-c`). Two pairs of the same image are refused (InputError
    naming the second's field in `fields`)."""
    import os

    def tail(path: str, k: int) -> str:
        parts = Path(os.path.abspath(path)).with_suffix("").parts
        return "_".join(p.strip("/") or "root" for p in parts[-k:])

    images = [a for a, _ in pairs]
    for i, a in enumerate(images):
        if os.path.abspath(a) in {os.path.abspath(x) for x in images[:i]}:
            raise InputError(fields[i], f"{a} is given twice; each image is compared once")
    depth = max(len(Path(os.path.abspath(a)).parts) for a in images)
    for k in range(1, depth + 1):
        stems = [f"{tail(a, k) if k > 1 else Path(a).stem}-vs-{Path(r).stem}" for a, r in pairs]
        if len(set(stems)) == len(stems):
            return stems
    raise AssertionError("distinct paths have distinct tails")


def error_image_paths(out_stem: Path, z: bool) -> list[Path]:
    """The files `write_error_images` writes for `out_stem` (with z-scores or without)."""
    suffixes = (".diff.exr", ".error.png", ".z.exr") if z else (".diff.exr", ".error.png")
    return [Path(f"{out_stem}{suffix}") for suffix in suffixes]


def write_error_images(a: np.ndarray, b: np.ndarray, out_stem: Path,
                       z: np.ndarray | None = None) -> list[Path]:
    """`STEM.diff.exr` (signed A - B, linear) and `STEM.error.png` (false-colour |A - B| luminance,
    with its scale bar); with `z` (ZScores.image) also `STEM.z.exr`, NaN where no standard error."""
    from drtlab.kernels.colour import luminance
    from drtlab.kernels.imageio import write_exr
    from drtlab.experiments.plotting import pyplot
    plt = pyplot()
    diff = np.asarray(a, dtype=np.float64)[..., :3] - np.asarray(b, dtype=np.float64)[..., :3]
    exr, png, *z_path = error_image_paths(out_stem, z is not None)
    write_exr(exr, diff, {"what": "signed difference A - B"})
    err = np.abs(luminance(diff))
    h, w = err.shape
    fig, ax = plt.subplots(figsize=(max(3.0, w / 60 + 1.2), max(2.4, h / 60)), dpi=100)
    im = ax.imshow(err, cmap="inferno", interpolation="nearest", vmin=0.0,
                   vmax=float(np.percentile(err, 99.5)) or 1.0)
    ax.set_axis_off()
    ax.set_title("|A - B| (luminance)", fontsize=8)
    fig.colorbar(im, ax=ax, fraction=0.046, pad=0.04)
    fig.savefig(png, bbox_inches="tight")
    plt.close(fig)
    if z is None:
        return [exr, png]
    write_exr(z_path[0], z, {"what": "per-pixel z = (A - B) / sqrt(se_A^2 + se_B^2), NaN without a "
                                     "standard error"})
    return [exr, png, *z_path]
