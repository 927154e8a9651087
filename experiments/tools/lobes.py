"""`drtlab lobe KIND`: a material's BSDF lobe in the plane of incidence beside its sampling density.

The lecture figure "reflected light as a function of viewing angle". The surface normal is +z and the
plane of incidence the xz-plane; the fixed direction at incident angle theta_i is
wo = (-sin theta_i, 0, cos theta_i) (on the left), so the mirror direction is at +theta_i (on the
right). A direction w of the plane has the signed angle alpha = atan2(w_x, w_z) from the normal
(degrees in the figure; beyond +-90 it lies below the surface: transmission).

For every incident angle, all through the chi-square adapters (experiments/stats/chi2/adapters.py
`BSDFAdapter`, i.e. kernels/materials/bsdf.py make_bsdf: no BSDF maths is repeated here):

* the lobe: eval_bsdf = f(wo, w) |cos theta| at w in the plane (exact, mean over R, G, B), polar;
* the sampling density: N directions from sample_bsdf, those within `band` degrees of the plane
  (|w_y| < sin band) histogrammed in alpha and divided by N times each bin's solid angle
  (d omega = cos beta d beta d alpha, beta = asin w_y, so a bin holds delta_alpha * 2 sin band sr);
  the curve is the claimed density of valid samples (pdf_bsdf where f > 0) in the plane;
* the agreement: each bin's expected count N * integral of the claimed pdf over the bin and the band
  (midpoint rule, 8 x 8 points), and over the bins expecting >= MIN_EXPECTED samples: the largest
  |histogram - pdf| / pdf, the largest |z| = |observed - expected| / sqrt(expected), and
  count_ratio = sum observed / sum expected with its Poisson standard error;
* the chi-square test of the same samples against the same pdf (experiments/stats/chi2/harness.py
  `run_chi2`, 101 x 202 cells in (cos, phi) about +y, see `_chi2_domain`; a zoomed cap about the
  mirror direction for glossy importance sampling with n >= 100), at the Sidak-corrected level of
  the family of incident angles (alpha = 0.01 for the family);
* the directional albedo estimate: the mean sample weight f|cos|/pdf (0 for failed samples), per
  channel, with its standard error; and the largest relative difference between the pdf a sample
  carries and pdf_bsdf evaluated on its own.

`pdf_scale` and `pdf_exponent` change only the *claimed* pdf (histogram comparison and chi-square),
not the sampler: negative controls through the same path (tests/experiments/tools/test_lobe_cli.py).
"""
from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from drtlab.kernels.scene_model.material_kinds import kinds_where

from drtlab import fields
from drtlab.errors import InputError
from drtlab.experiments.paths import results_root
from drtlab.fields import MAX_SEED

DELTA_KINDS = kinds_where(lambda k: k.delta)        # all light leaves in one or two directions
NO_SCATTER_KINDS = kinds_where(lambda k: k.emitter)  # sample_bsdf never returns a direction
LOBE_KINDS = kinds_where(lambda k: not (k.delta or k.emitter))
USES_EXPONENT = kinds_where(lambda k: k.phong)
USES_ROUGHNESS = kinds_where(lambda k: k.microfacet or k.anisotropic)   # alpha (an anisotropic one: both)
USES_ALBEDO_MEAN = kinds_where(lambda k: k.albedo_shape)     # their shape is the albedo's mean
USES_IOR = kinds_where(lambda k: k.ior and k.name in LOBE_KINDS)
# Lobes below the surface too: a full circle.
TRANSMITS = kinds_where(lambda k: k.transmits and k.name in LOBE_KINDS)
# importance-ggxd: GGX normals from D cos instead of the visible normals (Strategy.microfacet).
STRATEGIES = ("importance", "importance-ggxd", "uniform")

DEFAULT_INCIDENT = (0.0, 30.0, 60.0, 80.0)
MAX_INCIDENT = 89.0
MAX_ANGLES = 6
MAX_EXPONENT = 10_000.0
MIN_SAMPLES, MAX_SAMPLES, DEFAULT_SAMPLES = 10_000, 10_000_000, 1_000_000
BAND_DEG = 2.0                 # half-width of the band around the plane of incidence
BINS_PER_HALF = 90             # histogram bins over 180 degrees of alpha
MIN_EXPECTED = 200.0           # "well-populated": a bin expecting at least this many samples
CURVE_POINTS = 1441
FILES = ("lobe.png", "lobe.json", "manifest.json")
FAMILY_ALPHA = 0.01
NORMAL = (0.0, 0.0, 1.0)


# ---------------------------------------------------------------------------------------------------
# Input checks (one InputError line each; the CLI runs them before any work)
# ---------------------------------------------------------------------------------------------------

def check_kind(text: str, field_name: str = "KIND") -> str:
    if text in DELTA_KINDS:
        raise InputError(field_name, f"{text} is a delta BSDF (light leaves in single directions): "
                                     f"it has no lobe to plot; kinds with a lobe: "
                                     f"{', '.join(LOBE_KINDS)}")
    if text in NO_SCATTER_KINDS:
        raise InputError(field_name, f"{text} does not scatter light: it has no lobe to plot; kinds "
                                     f"with a lobe: {', '.join(LOBE_KINDS)}")
    if text not in LOBE_KINDS:
        raise InputError(field_name, f"must be a material kind with a lobe, one of "
                                     f"{', '.join(LOBE_KINDS)}; got {fields.show(text)}")
    return text


def _float(text: str, field_name: str, rule: str, ok) -> float:
    try:
        value = float(text)
    except (TypeError, ValueError):
        raise InputError(field_name, f"must be a number {rule}, got {fields.show(text)}") from None
    return fields.number(value, field_name, f"{rule}", ok)


def check_exponent(text: str, field_name: str = "--exponent") -> float:
    return _float(text, field_name, f"in [0, {MAX_EXPONENT:g}] (the Phong exponent)",
                  lambda v: 0.0 <= v <= MAX_EXPONENT)


def check_roughness(text: str, field_name: str = "--roughness") -> float:
    from drtlab.kernels.scene_model.material_kinds import ROUGHNESS_MIN
    return _float(text, field_name, f"in [{ROUGHNESS_MIN:g}, 1] (the microfacet alpha)",
                  lambda v: ROUGHNESS_MIN <= v <= 1.0)


def check_ior(text: str, field_name: str = "--ior") -> float:
    return _float(text, field_name, "in [0.1, 10], not 1 (index of refraction inside / outside)",
                  lambda v: 0.1 <= v <= 10.0 and v != 1.0)


def check_albedo(text: str, field_name: str = "--albedo") -> tuple[float, float, float]:
    rule = "three numbers R,G,B in [0, 1], e.g. 0.8,0.8,0.8"
    parts = text.split(",") if isinstance(text, str) else []
    try:
        vals = [float(p) for p in parts]
    except ValueError:
        vals = []
    if len(vals) != 3 or not all(math.isfinite(v) and 0.0 <= v <= 1.0 for v in vals):
        raise InputError(field_name, f"must be {rule}; got {fields.show(text)}")
    return tuple(vals)


def check_incident(text: str, field_name: str = "--incident") -> tuple[float, ...]:
    rule = (f"1 to {MAX_ANGLES} different angles in degrees in [0, {MAX_INCIDENT:g}], comma "
            f"separated, e.g. 0,30,60,80")
    parts = text.split(",") if isinstance(text, str) else []
    try:
        vals = [float(p) for p in parts]
    except ValueError:
        vals = []
    if (not 1 <= len(vals) <= MAX_ANGLES or len(set(vals)) != len(vals)
            or not all(math.isfinite(v) and 0.0 <= v <= MAX_INCIDENT for v in vals)):
        raise InputError(field_name, f"must be {rule}; got {fields.show(text)}")
    return tuple(vals)


def default_out_dir(kind: str, exponent: float, ior: float, strategy: str,
                    roughness: float = 0.2) -> Path:
    parts = [kind]
    if kind in USES_EXPONENT:
        parts.append(f"n{exponent:g}")
    if kind in USES_ROUGHNESS:
        parts.append(f"a{roughness:g}")
    if kind in USES_IOR:
        parts.append(f"ior{ior:g}")
    parts.append(strategy)
    return results_root() / "lobes" / "_".join(parts)


# ---------------------------------------------------------------------------------------------------
# The analysis
# ---------------------------------------------------------------------------------------------------

def _in_plane(alpha_rad: np.ndarray, beta_rad: np.ndarray | float = 0.0) -> np.ndarray:
    """Unit directions at in-plane angle alpha (from +z toward +x) and out-of-plane angle beta."""
    a = np.asarray(alpha_rad, dtype=np.float64)
    b = np.broadcast_to(np.asarray(beta_rad, dtype=np.float64), a.shape)
    cb = np.cos(b)
    return np.stack([cb * np.sin(a), np.sin(b), cb * np.cos(a)], axis=1)


def incident_direction(theta_deg: float) -> np.ndarray:
    th = math.radians(theta_deg)
    return np.array([-math.sin(th), 0.0, math.cos(th)])


@dataclass
class AngleResult:
    theta_deg: float
    summary: dict
    curve_alpha_deg: np.ndarray      # the plotted curves
    curve_f: np.ndarray              # eval_bsdf, mean over channels
    curve_pdf: np.ndarray            # claimed pdf in the plane
    bin_edges_deg: np.ndarray
    hist_density: np.ndarray
    expected_density: np.ndarray


@dataclass
class LobeResult:
    summary: dict
    angles: list[AngleResult] = field(default_factory=list)
    seconds: float = 0.0


def _chi2_domain(C, kind, strategy, exponent, wo):
    """(domain, ires) of the chi-square test; `exponent` is the lobe's shape (GGX: alpha). See
    _phong_domain; a GGX lobe of alpha is about as wide as a Phong lobe of n = 2 / alpha^2, and
    importance-sampled GGX reflection with alpha < 0.1 uses the zoomed cap (8 alpha about the
    mirror direction, as tests/kernels/test_ggx.py)."""
    if kind in USES_ROUGHNESS:
        if kind not in TRANSMITS and strategy != "uniform" and exponent < 0.1:
            refl = 2.0 * wo[2] * np.array(NORMAL) - wo
            return C.CapDomain(refl, 1.0 - math.cos(8.0 * exponent)), 8
        n = 2.0 / (exponent * exponent) if strategy != "uniform" else 0.0
        return C.SphericalDomain((0.0, 1.0, 0.0)), int(np.clip(math.ceil(0.9 * math.sqrt(n)), 4, 16))
    return _phong_domain(C, kind, strategy, exponent, wo)


def _phong_domain(C, kind, strategy, exponent, wo):
    """(domain, ires) of the chi-square test. The sphere's grid has its pole at +y, out of the plane
    of incidence, so that no lobe (all centred in that plane) sits at a pole of (cos, phi), where
    the midpoint rule in cos underestimates a Phong lobe's mass by ~ n^2 (h / ires)^2 / 24 (4e-4 at
    n = 20, ires = 4: a rest cell expecting ~400 samples that never come); on the equator the error
    is ~ n (h / ires)^2 / 24, kept near 2e-5 by ires ~ 0.9 sqrt(n) (4 to 16). Glossy importance
    sampling with n >= 100 uses the zoomed cap about the mirror direction, as tests/estimators/test_chi2.py."""
    if kind == "glossy" and strategy == "importance" and exponent >= 100.0:
        refl = 2.0 * wo[2] * np.array(NORMAL) - wo
        return C.CapDomain(refl, 20.0 / (exponent + 1.0)), 8
    n = exponent if kind in USES_EXPONENT and strategy == "importance" else 0.0
    return C.SphericalDomain((0.0, 1.0, 0.0)), int(np.clip(math.ceil(0.9 * math.sqrt(n)), 4, 16))


def analyse(kind: str, *, exponent: float = 20.0, ior: float = 1.5,
            albedo=(0.8, 0.8, 0.8), incident=DEFAULT_INCIDENT, strategy: str = "importance",
            samples: int = DEFAULT_SAMPLES, seed: int = 0, pdf_scale: float = 1.0,
            pdf_exponent: float | None = None, roughness: float = 0.2) -> LobeResult:
    """Lobes, sampled densities, chi-square tests and albedos of one material (see the module
    docstring). `pdf_scale` / `pdf_exponent` alter only the claimed pdf (negative controls;
    `pdf_exponent` is the claimed lobe shape: the exponent, or GGX's alpha)."""
    from drtlab.experiments.stats import chi2 as C
    t0 = time.perf_counter()
    check_kind(kind)
    if kind in USES_ROUGHNESS:
        exponent = float(roughness)          # the kernels' lobe shape parameter (the microfacet alpha)
    if kind in USES_ALBEDO_MEAN:
        exponent = float(np.mean(albedo))
    ad = C.BSDFAdapter(strategy != "uniform", "d" if strategy == "importance-ggxd" else "vndf")
    m = len(incident)
    level = C.sidak(FAMILY_ALPHA, m)
    half = 180.0 if kind in TRANSMITS else 90.0
    nbins = BINS_PER_HALF * (2 if kind in TRANSMITS else 1)
    edges = np.linspace(-half, half, nbins + 1)
    width = math.radians(edges[1] - edges[0])
    sin_band = math.sin(math.radians(BAND_DEG))
    bin_sr = width * 2.0 * sin_band
    curve_a = np.linspace(-half, half, CURVE_POINTS)
    claimed_n = exponent if pdf_exponent is None else float(pdf_exponent)
    result = LobeResult(summary={})
    rows = []
    for i, theta in enumerate(incident):
        wo = incident_direction(theta)
        case = (kind, tuple(albedo), float(exponent), float(ior), NORMAL, tuple(wo))
        claim_case = (kind, tuple(albedo), claimed_n, float(ior), NORMAL, tuple(wo))
        base_pdf = ad.pdf(claim_case)

        def pdf(pts, base_pdf=base_pdf):
            return pdf_scale * base_pdf(pts)

        s_seed = (int(seed) + 7919 * i) & MAX_SEED
        s = ad.sample(case, int(samples), s_seed)
        # The lobe and the claimed density in the plane.
        dirs = _in_plane(np.radians(curve_a))
        _, f = ad.evaluate(case, dirs)
        curve_f = f.astype(np.float64).mean(axis=1)
        curve_pdf = pdf(dirs)
        # The histogram of the samples in the band, and the expected counts of its bins.
        wi = s.wi.astype(np.float64)
        v = s.valid & ~s.delta
        in_band = v & (np.abs(wi[:, 1]) < sin_band * np.linalg.norm(wi, axis=1))
        alpha = np.degrees(np.arctan2(wi[in_band, 0], wi[in_band, 2]))
        counts = np.histogram(alpha, bins=edges)[0].astype(np.float64)
        k = (np.arange(8) + 0.5) / 8.0
        qa = (edges[:-1, None] + np.outer(np.ones(nbins), k) * (edges[1] - edges[0]))   # (bins, 8)
        qb = np.arcsin((2.0 * k - 1.0) * sin_band)        # uniform in sin beta: d(sin b) = cos b db
        A = np.repeat(np.radians(qa)[:, :, None], 8, axis=2).ravel()
        B = np.broadcast_to(qb, (nbins, 8, 8)).ravel()
        expected = pdf(_in_plane(A, B)).reshape(nbins, -1).mean(axis=1) * bin_sr * samples
        good = expected >= MIN_EXPECTED
        with np.errstate(divide="ignore", invalid="ignore"):
            rel = np.abs(counts - expected) / expected
            z = (counts - expected) / np.sqrt(expected)
        so, se_ = float(counts[good].sum()), float(expected[good].sum())
        hist = {
            "band_samples": int(in_band.sum()),
            "well_populated_bins": int(good.sum()),
            "max_rel_dev": float(rel[good].max()) if good.any() else None,
            "max_abs_z": float(np.abs(z[good]).max()) if good.any() else None,
            "count_ratio": so / se_ if se_ > 0 else None,
            "count_ratio_se": math.sqrt(so) / se_ if se_ > 0 else None,
        }
        # The chi-square test of the same samples against the same claimed pdf.
        domain, ires = _chi2_domain(C, kind, strategy, claimed_n, wo)
        r = C.run_chi2(domain, lambda n, sd, s=s, v=v: (s.wi, v), pdf,     # a mirror lobe is no density
                       name=f"{kind} {strategy} theta_i={theta:g}", sample_count=int(samples),
                       res=(101, 202), ires=ires, seed=s_seed, test_count=m, alpha=FAMILY_ALPHA)
        w = np.where(s.valid[:, None], s.weight.astype(np.float64), 0.0)
        consist = C.relative_error(s.pdf[v], s.pdf_eval[v]).max() if v.any() else None
        row = {
            "theta_deg": float(theta), "seed": s_seed,
            "wo": wo.tolist(),
            "albedo_estimate": {"mean": w.mean(axis=0).tolist(),
                                "se": (w.std(axis=0, ddof=1) / math.sqrt(samples)).tolist()},
            "valid_fraction": float(s.valid.mean()),
            "chi2": {"statistic": r.statistic, "dof": r.dof, "p_value": r.p_value,
                     "level": r.alpha, "passed": r.passed, "domain": domain.name, "ires": ires,
                     "pdf_integral": r.integral, "messages": list(r.messages)},
            "histogram": hist,
            "pdf_consistency_max_rel_err": consist,
        }
        rows.append(row)
        result.angles.append(AngleResult(theta, row, curve_a, curve_f, curve_pdf, edges,
                                         counts / (samples * bin_sr), expected / (samples * bin_sr)))
    result.summary = {
        "kind": kind, "strategy": strategy,
        "exponent": float(exponent) if kind in USES_EXPONENT else None,
        "roughness": float(exponent) if kind in USES_ROUGHNESS else None,
        "ior": float(ior) if kind in USES_IOR else None,
        "albedo": list(albedo), "samples": int(samples), "seed": int(seed),
        "claimed_pdf": {"scale": float(pdf_scale), "exponent": claimed_n},
        "geometry": "normal +z, plane of incidence xz, wo = (-sin theta_i, 0, cos theta_i); "
                    "alpha = atan2(w_x, w_z)",
        "band_half_width_deg": BAND_DEG, "bin_width_deg": float(edges[1] - edges[0]),
        "min_expected_per_bin": MIN_EXPECTED,
        "family_alpha": FAMILY_ALPHA, "sidak_level": level,
        "passed": all(row["chi2"]["passed"] for row in rows),
        "incident": rows,
    }
    result.seconds = time.perf_counter() - t0
    return result


# ---------------------------------------------------------------------------------------------------
# The figure and the files
# ---------------------------------------------------------------------------------------------------

def lobe_png(result: LobeResult) -> bytes:
    import io

    from drtlab.experiments.plotting import pyplot
    plt = pyplot()
    S = result.summary
    full = S["kind"] in TRANSMITS
    from matplotlib.ticker import MaxNLocator
    rows = len(result.angles)
    fig = plt.figure(figsize=(12.5, (3.9 if full else 3.4) * rows + 0.7))
    gs = fig.add_gridspec(rows, 2, width_ratios=(1.15, 1.0))
    params = [f"n = {S['exponent']:g}" if S["exponent"] is not None else None,
              f"α = {S['roughness']:g}" if S.get("roughness") is not None else None,
              f"ior = {S['ior']:g}" if S["ior"] is not None else None,
              "albedo " + ",".join(f"{a:g}" for a in S["albedo"]),
              f"{S['strategy']} sampling", f"N = {S['samples']:,}"]
    fig.suptitle(f"{S['kind']} BSDF lobe in the plane of incidence ({', '.join(p for p in params if p)})",
                 fontsize=13)
    for i, a in enumerate(result.angles):
        row = a.summary
        ax = fig.add_subplot(gs[i, 0], projection="polar")
        ax.set_theta_zero_location("N")
        ax.set_theta_direction(-1)
        ax.set_thetamin(-180 if full else -90)
        ax.set_thetamax(180 if full else 90)
        th = np.radians(a.curve_alpha_deg)
        ax.plot(th, a.curve_f, color="C0", lw=1.8, label="f·cos θ (eval_bsdf, mean of R,G,B)")
        rmax = float(np.max(a.curve_f)) if np.max(a.curve_f) > 0 else 1.0
        ti = math.radians(a.theta_deg)
        ax.plot([-ti, -ti], [0, rmax * 1.1], color="C3", lw=1.5,
                label=f"incident direction θᵢ = {a.theta_deg:g}°")
        ax.plot([ti, ti], [0, rmax * 1.1], color="0.4", lw=1.0, ls="--", label="mirror direction")
        if full:
            ax.plot([-math.pi / 2, 0.0, math.pi / 2], [rmax * 1.1, 0.0, rmax * 1.1], color="k",
                    lw=0.8, label="surface (below: transmission)")
        ax.set_ylim(0, rmax * 1.1)
        ax.yaxis.set_major_locator(MaxNLocator(3))
        ax.set_xticks(np.radians(np.arange(-150 if full else -90, 181 if full else 91, 30)))
        ax.tick_params(labelsize=8)
        ax.set_title(f"lobe f·cos θ (radius, sr⁻¹) vs. angle from the normal (°), "
                     f"θᵢ = {a.theta_deg:g}°", fontsize=10)
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, 0.02 if not full else -0.09), ncol=2,
                  fontsize=8, frameon=False)
        bx = fig.add_subplot(gs[i, 1])
        bx.stairs(a.hist_density, a.bin_edges_deg, fill=True, color="C1", alpha=0.4)
        bx.stairs(a.hist_density, a.bin_edges_deg, color="C1", lw=1.0,
                  label=f"histogram of sampled directions within {S['band_half_width_deg']:g}° "
                        f"of the plane")
        bx.plot(a.curve_alpha_deg, a.curve_pdf, color="k", lw=1.2, label="pdf_bsdf (claimed)")
        bx.axvline(-a.theta_deg, color="C3", lw=1.0)
        bx.axvline(a.theta_deg, color="0.4", lw=0.8, ls="--")
        c, h = row["chi2"], row["histogram"]
        alb = row["albedo_estimate"]["mean"]
        txt = (f"χ² p = {c['p_value']:.3g} ({'pass' if c['passed'] else 'REJECTED'} at "
               f"{c['level']:.2g})\nalbedo ≈ {np.mean(alb):.4f}"
               + (f"\nmax |hist − pdf|/pdf = {h['max_rel_dev']:.3f}" if h["max_rel_dev"] is not None
                  else ""))
        bx.text(0.02, 0.70, txt, transform=bx.transAxes, va="top", fontsize=8.5,
                bbox={"facecolor": "white", "alpha": 0.8, "edgecolor": "0.8"})
        half = 180 if full else 90
        bx.set_xlim(-half, half)
        bx.set_xticks(np.arange(-half, half + 1, 30 if not full else 60))
        bx.set_xlabel("signed angle from the normal α (degrees; incident side < 0)")
        bx.set_ylabel("density (sr⁻¹)")
        bx.set_title(f"sampling density, θᵢ = {a.theta_deg:g}°", fontsize=10)
        bx.legend(loc="upper left", fontsize=8)
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90)
    plt.close(fig)
    return buf.getvalue()


def write_lobe(result: LobeResult, out_dir: Path, argv=None) -> list[Path]:
    """lobe.png, lobe.json and manifest.json (the figure made in memory first, each file written
    atomically, the manifest last)."""
    from drtlab.experiments.files import atomic_write_bytes, atomic_write_json
    png = lobe_png(result)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    atomic_write_bytes(out_dir / "lobe.png", png)
    atomic_write_json(out_dir / "lobe.json", result.summary)
    atomic_write_json(out_dir / "manifest.json", _manifest(result, argv))
    return [out_dir / f for f in FILES]


def _manifest(result: LobeResult, argv) -> dict:
    import datetime as dt

    from drtlab.experiments.provenance import (
        git_info,
        machine_info,
        package_versions,
        peak_rss_mib,
    )
    from drtlab.kernels import CODE_VERSION

    from drtlab.version import __version__
    S = result.summary
    return {"what": "drtlab lobe", "command": argv if argv is not None else sys.argv,
            "finished": dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
            "version": __version__, "code_version": CODE_VERSION, "git": git_info(),
            "material": {k: S[k] for k in ("kind", "exponent", "roughness", "ior", "albedo")},
            "strategy": S["strategy"], "samples": S["samples"],
            "seeds": {"scheme": "incident angle i: seed + 7919 i (mod 2^32); sample j's random "
                                "numbers uniform(seed_i, j, 0|1|2) (experiments/stats/chi2/adapters.py)",
                      "root": S["seed"], "per_angle": [r["seed"] for r in S["incident"]]},
            "packages": package_versions(), "machine": machine_info(),
            "wall_seconds": round(result.seconds, 3), "peak_rss_mib": peak_rss_mib(),
            "files": list(FILES)}
