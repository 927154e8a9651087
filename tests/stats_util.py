"""Shared helpers for the statistical tests (test_unbiased, test_analytic, test_hard_cases).

The one statistical test every estimator check uses
---------------------------------------------------
An estimate is K independent renders (distinct fixed seeds) of the same scene, each at low spp. Each
render is reduced to region values: the image is cut into `block` x `block` pixel regions and a
region's value is the mean over its pixels (and the K runs) of R + G + B. Aggregating many pixels x
spp samples into one number per region is what gives the test power and makes it close to normal.
The variance of a region's mean comes from the per-pixel spread over the K runs (pixels and runs are
independent), with Satterthwaite's effective degrees of freedom (Estimate.from_images).

Two estimates (or an estimate and an exact value) are compared region by region with Welch's t:
    t_r = (mean_a - mean_b) / sqrt(var_a + var_b + floor_r^2),  Welch-Satterthwaite dof,
each t_r is mapped to the standard normal deviate z_r with the same two-sided p-value (so a small K
does not inflate the false-alarm rate the way treating t as z would), and the regions are combined by
    X = sum_r z_r^2  ~  chi-square(R)   under H0 (regions are disjoint pixels: independent).
The null (no bias) is rejected when P(chi2_R >= X) < alpha_test, where alpha_test is the Sidak
correction of ALPHA = 0.01 over the family of tests of the calling module:
    alpha_test = 1 - (1 - ALPHA)^(1 / m).
`floor_r` = 1e-5 * |reference| + 1e-9 absorbs float32 rounding of the tracer (the renders trace in
float32) and the quadrature error of closed forms (< 1e-7 relative, 2e-6 for the thin lens); it is
far below every standard error the tests reach, so it never hides a bias the test could see.

Scenes with closed-form pixel values
------------------------------------
Builders return a ClosedForm: the scene dict (fed to `scene_from_dict`) and the exact expected value
of every pixel (float64 Gauss-Legendre quadrature over the pixel footprint and the lens):
    furnace_box       closed diffuse box, albedo rho, emission Le, camera inside:
                      path: Le (1 - rho^d) / (1 - rho) for max_depth d (Le / (1 - rho) for d = -1);
                      drt (no diffuse interreflection): Le for d = 1, Le (1 + rho) for d >= 2.
                      (Next-event estimation alone has infinite variance in it: see furnace_box.)
    light_over_plane  a Lambertian plane lit by a sphere light (irradiance pi Le (r/dist)^2 cos theta)
                      or a one-sided quad light (Lambert's polygon formula), plus a uniform background:
                      L(x) = rho [Le s(x) [x on the emitting side] + Bg (1 - s(x))], s = E_geom / pi.
                      Pinhole or thin lens, optional zero-velocity motion.
    sphere_furnace    one sphere of a given BSDF in a uniform background of radiance 1: 1 for lossless
                      kinds (diffuse albedo 1, mirror, dielectric); the modified-Phong directional
                      albedo (quadrature) for glossy.
    slab              a dielectric slab before a uniform emitter: Le (1 - F) / (1 + F) per ray.
    cube_furnace      a clear dielectric cube in a uniform background: 1 (lossless, unbounded paths).
    sphere_interior   camera inside a diffuse sphere lit by a central sphere light: uniform wall
                      radiance rho Le s sum_k (rho (1 - s))^k, s = (r / R)^2.
Kernel variants are what cost time (2-6 s to compile each), so the builders can add invisible
"feature" shapes that make a closed-form scene compile to the same variant as a built-in scene.
"""
from __future__ import annotations

import math
import os
import zlib
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from drtlab.kernels.render import render
from drtlab.kernels.scene_file import scene_from_dict

# ---------------------------------------------------------------------------------------------------
# Tiers
# ---------------------------------------------------------------------------------------------------

TIER = os.environ.get("DRTLAB_TEST_TIER", "fast").strip().lower() or "fast"
FULL = TIER == "full"
ALPHA = 0.01
REL_FLOOR = 1e-5
ABS_FLOOR = 1e-9


def tier(fast, full):
    """The fast-tier value, or the full-tier one under DRTLAB_TEST_TIER=full."""
    return full if FULL else fast


def sidak(alpha: float, m: int) -> float:
    """Per-test level that keeps the family-wise error rate of m independent tests at alpha."""
    return 1.0 - (1.0 - alpha) ** (1.0 / max(int(m), 1))


# Part of every seed. The suite's seeds are fixed (salt 0); DRTLAB_TEST_SEED_SALT=N re-draws all of
# them, which is how the tests were calibrated (a correct estimator must pass for most salts: each
# test's false-alarm rate is its Sidak alpha). Never set it for a real run.
SEED_SALT = int(os.environ.get("DRTLAB_TEST_SEED_SALT", "0"))


def seed_for(*key) -> int:
    """A fixed 32-bit seed derived from a readable key (so every test is reproducible alone)."""
    return zlib.crc32(repr((SEED_SALT,) + key).encode()) & 0xFFFFFFFF


# ---------------------------------------------------------------------------------------------------
# Estimates and the comparison
# ---------------------------------------------------------------------------------------------------

def region_values(img: np.ndarray, block: int) -> np.ndarray:
    """(R,) mean of R+G+B over each block x block region (the image is cropped to whole blocks)."""
    h, w = img.shape[0] // block * block, img.shape[1] // block * block
    if h == 0 or w == 0:
        raise ValueError(f"image {img.shape[:2]} smaller than one {block}x{block} region")
    s = img[:h, :w].sum(axis=2)
    return s.reshape(h // block, block, w // block, block).mean(axis=(1, 3)).ravel()


@dataclass
class Estimate:
    mean: np.ndarray            # (R,) region means
    var: np.ndarray             # (R,) variance of the mean
    dof: np.ndarray | float     # (R,) degrees of freedom of var (inf for exact values)
    runs: int = 0
    nonfinite: int = 0          # non-finite pixel values over all runs
    negative: int = 0           # negative pixel values over all runs
    min_value: float = 0.0
    max_value: float = 0.0

    @classmethod
    def from_images(cls, images: np.ndarray, block: int, **kw) -> "Estimate":
        """Region means of K independent images (K, H, W) (R + G + B per pixel) and the variance of
        each region mean from the per-pixel spread: pixels of one render are independent (every
        point set keys its samples by pixel) and so are the renders, so
            Var(region mean) = sum_p s_p^2 / (P^2 K),   s_p^2 = pixel p's sample variance over K runs,
        with Satterthwaite's effective degrees of freedom (sum s_p^2)^2 / sum(s_p^4 / (K - 1)).
        Compared with the spread of K region means (K - 1 dof) this variance estimate has up to
        P (K - 1) dof, so a few runs that happen to agree cannot make a region look precise; where a
        few pixels carry the variance (heavy tails) the dof drops towards K - 1 by itself."""
        images = np.asarray(images, dtype=np.float64)
        k = images.shape[0]
        if k < 2:
            raise ValueError("an estimate needs at least 2 independent runs")
        h, w = images.shape[1] // block * block, images.shape[2] // block * block
        if h == 0 or w == 0:
            raise ValueError(f"image {images.shape[1:]} smaller than one {block}x{block} region")
        x = images[:, :h, :w].reshape(k, h // block, block, w // block, block)
        x = x.transpose(0, 1, 3, 2, 4).reshape(k, -1, block * block)      # (K, R, P)
        p = block * block
        mean = x.mean(axis=(0, 2))
        s2 = x.var(axis=0, ddof=1)                                         # (R, P)
        var = s2.sum(axis=1) / (p * p * k)
        den = np.sum(s2 ** 2, axis=1) / (k - 1)
        with np.errstate(divide="ignore", invalid="ignore"):
            dof = np.where(den > 0, s2.sum(axis=1) ** 2 / np.where(den > 0, den, 1.0), np.inf)
        return cls(mean, var, dof, runs=k, **kw)

    @classmethod
    def exact(cls, values: np.ndarray) -> "Estimate":
        values = np.asarray(values, dtype=np.float64).ravel()
        return cls(values, np.zeros_like(values), math.inf)


@dataclass
class Comparison:
    z: np.ndarray               # (R,) signed normal deviates
    chi2: float
    regions: int
    p: float
    alpha: float
    rel_err: np.ndarray         # (R,) |a - b| / |b| (b = reference)
    diff: np.ndarray = field(repr=False, default=None)

    @property
    def rejected(self) -> bool:
        return self.p < self.alpha

    @property
    def max_abs_z(self) -> float:
        return float(np.max(np.abs(self.z)))

    def worst_rel_err(self, ref: np.ndarray, min_fraction: float = 0.05) -> float:
        """Worst relative error over regions whose reference is not negligible (>= min_fraction of
        the largest region value: a relative error of a near-black region means nothing)."""
        ref = np.abs(np.asarray(ref))
        keep = ref >= min_fraction * ref.max() if ref.max() > 0 else np.ones_like(ref, bool)
        return float(np.max(self.rel_err[keep])) if keep.any() else 0.0

    def summary(self) -> str:
        i = int(np.argmax(np.abs(self.z)))
        return (f"chi2={self.chi2:.1f} (dof {self.regions}) p={self.p:.3g} alpha={self.alpha:.3g} "
                f"max|z|={self.max_abs_z:.2f} (region {i}, rel err {self.rel_err[i]:.3g}) "
                f"-> {'REJECT' if self.rejected else 'accept'}")


def compare(a: Estimate, b: Estimate, alpha: float) -> Comparison:
    """Welch t per region -> equal-p normal deviate -> chi-square over regions (see module doc)."""
    diff = a.mean - b.mean
    floor = REL_FLOOR * np.abs(b.mean) + ABS_FLOOR
    v = a.var + b.var + floor ** 2
    t = diff / np.sqrt(v)
    # Welch-Satterthwaite: v^2 / sum(v_i^2 / dof_i); exact terms (dof inf) contribute nothing.
    den = np.zeros_like(v)
    for var, dof in ((a.var, a.dof), (b.var, b.dof)):
        dof = np.broadcast_to(np.asarray(dof, dtype=np.float64), v.shape)
        den = den + np.where(np.isfinite(dof), var ** 2 / np.where(np.isfinite(dof), dof, 1.0), 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        dof = np.where(den > 0, v ** 2 / np.where(den > 0, den, 1.0), np.inf)
    p_two = np.where(np.isfinite(dof), 2.0 * stats.t.sf(np.abs(t), np.where(np.isfinite(dof), dof, 1.0)),
                     2.0 * stats.norm.sf(np.abs(t)))
    p_two = np.clip(p_two, 1e-300, 1.0)
    z = np.sign(t) * stats.norm.isf(p_two / 2.0)
    chi2 = float(np.sum(z ** 2))
    p = float(stats.chi2.sf(chi2, len(z)))
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.abs(diff) / np.maximum(np.abs(b.mean), 1e-300)
    return Comparison(z=z, chi2=chi2, regions=len(z), p=p, alpha=alpha, rel_err=rel, diff=diff)


def render_estimate(scene, sampler: str, integrator: str, spp: int, runs: int, key,
                    res=None, block: int = 8, faults=()) -> Estimate:
    """`runs` independent renders (seeds derived from `key`) reduced to an Estimate of region means."""
    imgs, nonfinite, negative, lo, hi = [], 0, 0, math.inf, -math.inf
    for k in range(runs):
        img = render(scene, spp=spp, sampler=sampler, integrator=integrator,
                     seed=seed_for(key, k), res=res, progress=False, faults=tuple(faults))
        finite = np.isfinite(img)
        nonfinite += int(img.size - finite.sum())
        negative += int(np.sum(img[finite] < 0))
        if finite.any():
            lo = min(lo, float(img[finite].min()))
            hi = max(hi, float(img[finite].max()))
        imgs.append(np.where(finite, img, 0.0).sum(axis=2))
    return Estimate.from_images(np.array(imgs), block, nonfinite=nonfinite, negative=negative,
                                min_value=lo, max_value=hi)


# ---------------------------------------------------------------------------------------------------
# Cameras: the same rays as kernels/tracer.py camera_ray_dir, in float64, for quadrature
# ---------------------------------------------------------------------------------------------------

def camera_dict(position, look_at, fov, up=(0.0, 1.0, 0.0), aperture=0.0, focus=None,
                shutter=None) -> dict:
    cam = {"position": list(map(float, position)), "look_at": list(map(float, look_at)),
           "up": list(map(float, up)), "fov": float(fov)}
    if aperture > 0:
        cam["aperture_radius"] = float(aperture)
        cam["focus_distance"] = float(focus)
    if shutter is not None:
        cam["shutter"] = [float(shutter[0]), float(shutter[1])]
    return cam


def _gauss01(n: int) -> tuple[np.ndarray, np.ndarray]:
    x, w = np.polynomial.legendre.leggauss(n)
    return 0.5 * (x + 1.0), 0.5 * w


def camera_rays(cam: dict, width: int, height: int, n_pix: int = 6, n_lens_r: int = 0,
                n_lens_phi: int = 0, rows: bool = False):
    """Quadrature rays of every pixel: origins (H, W, Q, 3), unit directions (H, W, Q, 3) and weights
    (Q,) summing to 1. Gauss-Legendre over the pixel square; Gauss-Legendre in r^2 x the periodic
    trapezoid rule in phi over the lens disk (uniform density), for a thin lens. rows=True returns
    (a generator of (origins, directions) per image row, each (W, Q, 3); weights), to bound memory."""
    pos = np.asarray(cam["position"], float)
    fwd = np.asarray(cam["look_at"], float) - pos
    fwd /= np.linalg.norm(fwd)
    right = np.cross(fwd, np.asarray(cam.get("up", (0, 1, 0)), float))
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    half_h = math.tan(math.radians(cam["fov"]) / 2)
    half_w = half_h * width / height
    gx, gw = _gauss01(n_pix)
    u0, u1 = np.meshgrid(gx, gx, indexing="ij")
    wpix = np.outer(gw, gw).ravel()
    u0, u1 = u0.ravel(), u1.ravel()
    aperture = float(cam.get("aperture_radius", 0.0))
    if aperture > 0 and n_lens_r > 0:
        tr, tw = _gauss01(n_lens_r)
        phi = (np.arange(n_lens_phi) + 0.5) * 2 * np.pi / n_lens_phi
        rr, pp = np.meshgrid(np.sqrt(tr) * aperture, phi, indexing="ij")
        lx, ly = (rr * np.cos(pp)).ravel(), (rr * np.sin(pp)).ravel()
        wl = np.repeat(tw, n_lens_phi) / n_lens_phi
        focus = float(cam["focus_distance"])
    else:
        lx, ly, wl, focus = np.zeros(1), np.zeros(1), np.ones(1), 1.0
    # Combine pixel and lens nodes: Q = n_pix^2 * n_lens.
    U0 = np.repeat(u0, len(lx))
    U1 = np.repeat(u1, len(lx))
    LX = np.tile(lx, len(u0))
    LY = np.tile(ly, len(u0))
    W = np.repeat(wpix, len(lx)) * np.tile(wl, len(u0))
    px = np.arange(width)[None, :, None]
    o_lens = pos + right * LX[:, None] + up * LY[:, None]            # (Q, 3)

    def row_rays(py):
        py = np.asarray(py)[:, None, None]
        sx = (2.0 * (px + U0[None, None, :]) / width - 1.0) * half_w
        sy = (1.0 - 2.0 * (py + U1[None, None, :]) / height) * half_h
        cx = sx - LX / focus
        cy = sy - LY / focus
        cx, cy = np.broadcast_arrays(cx, cy)
        d = right * cx[..., None] + up * cy[..., None] + fwd
        d = d / np.linalg.norm(d, axis=-1, keepdims=True)
        return np.broadcast_to(o_lens, d.shape), d

    weights = W / W.sum()
    if rows:
        return (tuple(a[0] for a in row_rays([py])) for py in range(height)), weights
    o, d = row_rays(np.arange(height))
    return o, d, weights


# ---------------------------------------------------------------------------------------------------
# Scene pieces
# ---------------------------------------------------------------------------------------------------

def scene_dict(description: str, camera: dict, materials: dict, shapes: list, *, res=(16, 12),
               integrator="path", max_depth=5, background=(0.0, 0.0, 0.0), roulette=False,
               rr_depth=None) -> dict:
    s = {"description": description, "resolution": [int(res[0]), int(res[1])], "spp": 16,
         "integrator": integrator, "max_depth": int(max_depth),
         "background": [float(b) for b in background]}
    if roulette:
        s["russian_roulette"] = True
        if rr_depth is not None:
            s["rr_depth"] = int(rr_depth)
    return {"scene": s, "camera": camera, "materials": materials, "shapes": shapes}


def quad(origin, edge_u, edge_v, material, **kw) -> dict:
    q = {"kind": "quad", "material": material, "origin": [float(x) for x in origin],
         "edge_u": [float(x) for x in edge_u], "edge_v": [float(x) for x in edge_v]}
    q.update(kw)
    return q


def sphere(center, radius, material, **kw) -> dict:
    s = {"kind": "sphere", "material": material, "center": [float(x) for x in center],
         "radius": float(radius)}
    s.update(kw)
    return s


def inward_box_quads(lo, hi, material, split_face: bool = False) -> list[dict]:
    """The 6 faces of [lo, hi]^3 as quads whose normals (edge_u x edge_v) point INTO the box, so an
    emissive material radiates inwards. `split_face` cuts the +z face in two along x (a shared edge)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    ext = hi - lo
    out = []
    for a in range(3):
        b, c = (a + 1) % 3, (a + 2) % 3
        for side in (0, 1):
            origin = lo.copy()
            origin[a] = hi[a] if side else lo[a]
            eu = np.zeros(3)
            eu[b] = ext[b]
            ev = np.zeros(3)
            ev[c] = ext[c]
            inward = np.zeros(3)
            inward[a] = -1.0 if side else 1.0
            if np.dot(np.cross(eu, ev), inward) < 0:
                eu, ev = ev, eu
            if split_face and a == 2 and side == 1:
                # The +z face as two quads sharing the edge x = lo + ext / 2.
                half = np.zeros(3)
                half[0] = ext[0] / 2
                e_x = eu if eu[0] != 0 else ev
                e_o = ev if eu[0] != 0 else eu
                first_is_u = eu[0] != 0
                for k in range(2):
                    o2 = origin + half * k
                    ex = e_x / 2
                    q = (ex, e_o) if first_is_u else (e_o, ex)
                    out.append(quad(o2, q[0], q[1], material))
                continue
            out.append(quad(origin, eu, ev, material))
    return out


# ---------------------------------------------------------------------------------------------------
# Closed-form scenes
# ---------------------------------------------------------------------------------------------------

@dataclass
class ClosedForm:
    name: str
    scene: dict                         # the scene dict
    truth: np.ndarray                   # (H, W) expected R+G+B of every pixel
    note: str = ""

    def load(self):
        return scene_from_dict(self.scene, name=self.name)

    def region_truth(self, block: int) -> Estimate:
        return Estimate.exact(region_values(np.repeat(self.truth[..., None] / 3.0, 3, axis=2), block))


# Camera inside the furnace box looking at the middle of the +x wall: every visible point is >= 0.25
# of the half-size away from an edge (so direct light by area sampling has finite variance).
EDGE_FREE_VIEW = dict(camera_pos=(-0.5, 0.1, 0.05), look=(1.0, 0.1, 0.05), fov=40.0)


def furnace_value(rho: float, le: float, depth: int, integrator: str) -> float:
    """Radiance everywhere in a closed diffuse enclosure of albedo rho emitting le (Mitsuba depth)."""
    if integrator == "drt":
        return le if depth == 1 else le * (1.0 + rho)
    if depth == -1:
        return le / (1.0 - rho)
    return le * (1.0 - rho ** depth) / (1.0 - rho)


def furnace_box(rho=0.6, le=1.0, depth=4, integrator="path", scale=1.0, res=(16, 12), look=None,
                camera_pos=None, lens=None, roulette=False, rr_depth=1, split_face=False, fov=70.0,
                name="furnace-box") -> ClosedForm:
    """Camera inside a closed cube [-scale, scale]^3 of inward quads, material diffuse rho + emission le.
    Compiles to the same kernel variant as cornell-box (quads, area lights, diffuse).

    Caution: next-event estimation alone (strategies uniform and light: emitters area-sampled, no
    MIS) has INFINITE variance here. Where two emitting walls meet, a shading point at distance e
    from the edge and a light sample at distance d ~ e on the other wall weigh G A ~ A / d^2, and
    the second moment over the band near the edge diverges like the integral of de / e^2 (tail
    P(X > s) ~ s^-1.5: finite mean, no CLT). A camera that sees no edge (EDGE_FREE_VIEW) makes
    depth 2 (direct light) finite; any deeper bounce lands near edges again."""
    s = float(scale)
    pos = np.array(camera_pos if camera_pos is not None else (0.13, -0.07, 0.21)) * s
    tgt = np.array(look if look is not None else (0.9, 0.35, -1.0)) * s
    cam = camera_dict(pos, tgt, fov) if lens is None else camera_dict(
        pos, tgt, fov, aperture=lens[0] * s, focus=lens[1] * s)
    mats = {"wall": {"kind": "diffuse", "albedo": [rho] * 3, "emission": [le] * 3}}
    shapes = inward_box_quads([-s] * 3, [s] * 3, "wall", split_face=split_face)
    d = scene_dict(f"white furnace rho={rho} Le={le} depth={depth}", cam, mats, shapes, res=res,
                   integrator=integrator, max_depth=depth, roulette=roulette,
                   rr_depth=rr_depth if roulette else None)
    v = furnace_value(rho, le, depth, integrator)
    return ClosedForm(name, d, np.full((res[1], res[0]), 3.0 * v))


def _sphere_light_fraction(x, n, c, r):
    """Cosine-weighted solid-angle fraction s = E / (pi Le) of a sphere fully above x's horizon."""
    d = c - x
    dist2 = np.sum(d * d, axis=-1)
    cos_t = np.sum(d * n, axis=-1) / np.sqrt(dist2)
    return r * r / dist2 * cos_t


def _polygon_fraction(x, n, verts):
    """Lambert's formula: (1 / 2pi) |sum_i Theta_i n . (v_i x v_{i+1}) / |v_i x v_{i+1}||, i.e. the
    cosine-weighted solid-angle fraction of a polygon fully above the horizon of x (normal n)."""
    v = [vv - x for vv in verts]
    v = [vv / np.linalg.norm(vv, axis=-1, keepdims=True) for vv in v]
    total = np.zeros(x.shape[:-1])
    for i in range(len(v)):
        a, b = v[i], v[(i + 1) % len(v)]
        cr = np.cross(a, b)
        ncr = np.linalg.norm(cr, axis=-1)
        theta = np.arctan2(ncr, np.sum(a * b, axis=-1))
        total += theta * np.sum(cr * n, axis=-1) / ncr
    return np.abs(total) / (2 * np.pi)


def _hits_parallelogram(o, d, p0, eu, ev, tmax):
    """Whether rays (o, d) meet the parallelogram p0 + s eu + t ev (s, t in [0, 1]) before tmax."""
    n = np.cross(eu, ev)
    denom = d @ n
    with np.errstate(divide="ignore", invalid="ignore"):
        t = ((p0 - o) @ n) / denom
    x = o + d * t[..., None] - p0
    w = n / np.dot(n, n)
    a = np.cross(x, ev) @ w
    b = np.cross(eu, x) @ w
    return (denom != 0) & (t > 0) & (t < tmax) & (a >= 0) & (a <= 1) & (b >= 0) & (b <= 1)


def light_over_plane(kind="sphere", *, rho=0.7, le=5.0, bg=0.25, size=0.5, light_pos=(0.3, 1.6, -0.2),
                     quad_normal=(0.0, -1.0, 0.0), cam_pos=(0.0, 2.2, 3.0), look=(0.1, 0.0, 0.0),
                     fov=30.0, res=(16, 12), lens=None, scale=1.0, integrator="path", max_depth=3,
                     zero_velocity_motion=False, checker=False, plane_half=None, n_pix=6,
                     n_lens=(12, 32), name=None) -> ClosedForm:
    """A diffuse plane y = 0 (albedo rho) under a sphere light (radius `size`) or a square one-sided
    quad light (side `size`, emitting along `quad_normal`) of radiance `le`, uniform background `bg`.

    Every camera ray must hit the plane; the light must lie entirely above it. Variant sharing:
      pinhole, no checker, bg > 0            -> aa-edges (spheres, quads, area lights, background)
      lens + checker, bg > 0                 -> dof
      zero_velocity_motion + checker, bg = 0 -> motion-blur (a moving diffuse sphere below the plane,
                                                never seen, switches motion on; the lit objects
                                                have velocity 0)
    A quad light also gets a tiny diffuse sphere below the plane so that `spheres` is in the variant.
    """
    s = float(scale)
    c = np.array(light_pos, float) * s
    mats = {"plane": {"kind": "diffuse", "albedo": [rho] * 3},
            "light": {"kind": "emitter", "emission": [le] * 3}}
    if checker:
        # A checker of one colour: the checker code path runs, the albedo is uniform.
        mats["plane"]["albedo2"] = [rho] * 3
        mats["plane"]["checker"] = [4, 4]
    cam = camera_dict(np.array(cam_pos) * s, np.array(look) * s, fov) if lens is None else camera_dict(
        np.array(cam_pos) * s, np.array(look) * s, fov, aperture=lens[0] * s, focus=lens[1] * s,
        shutter=(0.0, 1.0) if zero_velocity_motion else None)
    if zero_velocity_motion and lens is None:
        cam["shutter"] = [0.0, 1.0]
    half = (plane_half if plane_half is not None else 40.0) * s
    shapes = [quad((-half, 0.0, half), (2 * half, 0, 0), (0, 0, -2 * half), "plane", name="plane")]
    if kind == "sphere":
        r = float(size) * s
        assert c[1] > r, "the sphere light must be fully above the plane"
        shapes.append(sphere(c, r, "light", name="light"))
        verts = None
    else:
        a = float(size) * s
        nq = np.array(quad_normal, float)
        nq /= np.linalg.norm(nq)
        t1 = np.cross(nq, [0.0, 0.0, 1.0]) if abs(nq[2]) < 0.9 else np.cross(nq, [1.0, 0.0, 0.0])
        t1 /= np.linalg.norm(t1)
        t2 = np.cross(nq, t1)
        # edge_u x edge_v must be the emitting normal nq: (t2 x t1) = -nq, so use (t1, t2)? check.
        eu, ev = t1 * a, t2 * a
        if np.dot(np.cross(eu, ev), nq) < 0:
            eu, ev = ev, eu
        o = c - 0.5 * (eu + ev)
        verts = [o, o + eu, o + eu + ev, o + ev]
        assert min(v[1] for v in verts) > 0, "the quad light must be fully above the plane"
        shapes.append(quad(o, eu, ev, "light", name="light"))
        shapes.append(sphere((0.0, -10.0 * s, 0.0), 0.01 * s, "plane", name="feature-sphere"))
    if zero_velocity_motion:
        shapes[0]["velocity"] = [0.0, 0.0, 0.0]
        shapes[1]["velocity"] = [0.0, 0.0, 0.0]
        shapes.append(sphere((0.0, -5.0 * s, 0.0), 0.5 * s, "plane", name="mover-below-plane",
                             velocity=[0.3 * s, 0.0, 0.0]))
    d = scene_dict(f"{kind} light over a Lambertian plane", cam, mats, shapes, res=res,
                   integrator=integrator, max_depth=max_depth, background=(bg, bg, bg))

    # Truth: quadrature of L(x) over the pixel (and lens) footprint, one image row at a time.
    rows, w = camera_rays(cam, res[0], res[1], n_pix=n_pix, n_lens_r=n_lens[0] if lens else 0,
                          n_lens_phi=n_lens[1] if lens else 0, rows=True)
    n = np.array([0.0, 1.0, 0.0])
    truth = np.empty((res[1], res[0]))
    for row, (o, dirs) in enumerate(rows):
        t = -o[..., 1] / dirs[..., 1]
        if not np.all(t > 0):
            raise ValueError("every camera ray must hit the plane (it points away from it)")
        x = o + dirs * t[..., None]
        if not np.all(np.abs(x[..., 0]) < half) or not np.all(np.abs(x[..., 2]) < half):
            raise ValueError("every camera ray must hit the plane inside its extent")
        if kind == "sphere":
            frac = _sphere_light_fraction(x, n, c, float(size) * s)
            front = np.ones_like(frac, bool)
            # The camera must not see the light itself (nor sit inside it).
            oc = c - o
            tc = np.sum(oc * dirs, axis=-1)
            disc = (float(size) * s) ** 2 - (np.sum(oc * oc, axis=-1) - tc ** 2)
            root = np.sqrt(np.maximum(disc, 0.0))
            near = np.where(tc - root > 0, tc - root, tc + root)
            if np.any((disc > 0) & (near > 0) & (near < t)):
                raise ValueError("a camera ray sees the sphere light; move the camera")
        else:
            frac = _polygon_fraction(x, n, verts)
            front = np.sum((x - c) * np.asarray(quad_normal) / np.linalg.norm(quad_normal),
                           axis=-1) > 0
            if np.any(_hits_parallelogram(o, dirs, verts[0], verts[1] - verts[0],
                                          verts[3] - verts[0], t)):
                raise ValueError("a camera ray sees the quad light; move the camera")
        L = rho * (le * frac * front + bg * (1.0 - frac))
        truth[row] = 3.0 * np.sum(L * w, axis=-1)
    return ClosedForm(name or f"{kind}-light-over-plane", d, truth)


def phong_albedo(cos_o: np.ndarray, exponent: float, n_quad: int = 400) -> np.ndarray:
    """Directional albedo of the normalized modified Phong lobe of kernels/materials.py:
    int_{cos_i > 0, cos_alpha > 0} (n + 2) / (2 pi) cos^n(alpha) cos_i dw, alpha measured from the
    mirror direction. Substituting v = cos^(n + 1)(alpha) and integrating phi in closed form:
        A = (n + 2) / (2 pi (n + 1)) int_0^1 g(v) dv,   g = int_0^2pi max(0, a + b cos phi) dphi,
    a = cos(alpha) cos(theta_o), b = sin(alpha) sin(theta_o); g has a kink at a = b, where the
    integral is split."""
    cos_o = np.atleast_1d(np.asarray(cos_o, float))
    n = float(exponent)
    xg, wg = _gauss01(n_quad)
    out = np.empty_like(cos_o)
    for i, co in enumerate(cos_o):
        co = min(max(co, 0.0), 1.0)
        so = math.sqrt(max(0.0, 1.0 - co * co))
        # Kink: cos(alpha) cos(theta_o) = sin(alpha) sin(theta_o) <=> alpha = pi/2 - theta_o,
        # cos(alpha*) = so, v* = so^(n + 1).
        vstar = so ** (n + 1.0) if so > 0 else 0.0
        total = 0.0
        for lo, hi in ((0.0, vstar), (vstar, 1.0)):
            if hi <= lo:
                continue
            v = lo + (hi - lo) * xg
            # cos(alpha) = v^(1/(n+1)) computed in log space (v > 0 at Gauss nodes).
            with np.errstate(divide="ignore"):      # v = 0 (a denormal v* rounds away) -> ca = 0
                ca = np.exp(np.log(v) / (n + 1.0))
            sa = np.sqrt(np.maximum(0.0, 1.0 - ca * ca))
            a = ca * co
            b = sa * so
            g = np.where(a >= b, 2 * np.pi * a, 0.0)
            mid = (a < b) & (a > -b)
            with np.errstate(invalid="ignore", divide="ignore"):
                phi0 = np.arccos(np.clip(-a / np.where(b > 0, b, 1.0), -1.0, 1.0))
            g = np.where(mid, 2.0 * (a * phi0 + b * np.sin(phi0)), g)
            total += (hi - lo) * np.sum(wg * g)
        out[i] = (n + 2.0) / (2.0 * np.pi * (n + 1.0)) * total
    return out


def sphere_furnace(kind: str, *, exponent=None, ior=None, albedo=1.0, res=(16, 12), depth=8,
                   roulette=False, integrator="path", n_pix=6, name=None) -> ClosedForm:
    """One sphere (radius 1 at the origin) in a uniform background of radiance 1, viewed so that every
    pixel sees the sphere. Truth: 1 for lossless kinds (diffuse/mirror/dielectric with albedo 1);
    the modified-Phong directional albedo for glossy (reflected rays never return to a convex
    sphere). glossy_dielectric has no closed form here: truth is None (energy bound only)."""
    mat = {"kind": kind}
    if kind != "emitter":
        mat["albedo"] = [albedo] * 3
    if exponent is not None:
        mat["exponent"] = float(exponent)
    if ior is not None:
        mat["ior"] = float(ior)
    cam = camera_dict((0.0, 0.0, 4.0), (0.0, 0.0, 0.0), 16.0)
    d = scene_dict(f"{kind} sphere furnace", cam, {"m": mat}, [sphere((0, 0, 0), 1.0, "m")], res=res,
                   integrator=integrator, max_depth=depth, background=(1.0, 1.0, 1.0),
                   roulette=roulette, rr_depth=1 if roulette else None)
    o, dirs, w = camera_rays(cam, res[0], res[1], n_pix=n_pix)
    # Every ray must hit the sphere.
    b = np.sum(o * dirs, axis=-1)
    disc = b * b - (np.sum(o * o, axis=-1) - 1.0)
    if not np.all(disc > 0):
        raise ValueError("every pixel must see the sphere")
    t = -b - np.sqrt(disc)
    p = o + dirs * t[..., None]
    cos_o = np.clip(np.sum(p * -dirs, axis=-1), 0.0, 1.0)
    if kind == "glossy":
        table_c = np.linspace(0.0, 1.0, 1025) ** 0.5     # denser near grazing
        table_a = phong_albedo(table_c, exponent)
        A = np.interp(cos_o, table_c, table_a)
        truth = 3.0 * np.sum(A * w, axis=-1) * albedo
    elif kind in ("diffuse", "mirror", "dielectric") and albedo == 1.0:
        truth = np.full(cos_o.shape[:2], 3.0)
    else:
        truth = None
    return ClosedForm(name or f"{kind}-sphere-furnace", d, truth)


def fresnel(cos_i, eta):
    """Unpolarised Fresnel reflectance as in kernels/materials.py (eta = n_t / n_i)."""
    cos_i = np.asarray(cos_i, float)
    sin2_t = (1.0 - cos_i ** 2) / eta ** 2
    tir = sin2_t >= 1.0
    cos_t = np.sqrt(np.maximum(0.0, 1.0 - sin2_t))
    rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
    rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
    return np.where(tir, 1.0, 0.5 * (rs ** 2 + rp ** 2))


def slab(ior: float, *, le=2.0, thickness=0.3, res=(16, 12), depth=40, tilt_deg=35.0, scale=1.0,
         n_pix=6, name=None) -> ClosedForm:
    """A clear dielectric slab (albedo 1) between the camera and a uniform emitter quad, viewed
    obliquely. A ray crossing parallel faces exits parallel to itself, so every pixel sees
    Le * (1 - F)^2 * sum_k F^(2k) (k internal round trips, each emitter hit counted while its path
    index stays below max_depth): Le (1 - F) / (1 + F) for deep paths. F at the outer face equals F
    at the inner one (Fresnel reciprocity). The eta^2 radiance factors cancel (in, then out)."""
    s = float(scale)
    w = 50.0 * s
    mats = {"glass": {"kind": "dielectric", "albedo": [1.0] * 3, "ior": float(ior)},
            "light": {"kind": "emitter", "emission": [le] * 3}}
    shapes = [{"kind": "box", "material": "glass", "min": [-w, -w, -thickness * s], "max": [w, w, 0.0]},
              quad((-4 * w, -4 * w, -2.0 * s), (8 * w, 0, 0), (0, 8 * w, 0), "light", name="light")]
    tilt = math.radians(tilt_deg)
    pos = np.array([0.0, math.sin(tilt) * 3.0, math.cos(tilt) * 3.0]) * s
    cam = camera_dict(pos, (0.0, 0.0, 0.0), 20.0)
    d = scene_dict(f"dielectric slab ior={ior}", cam, mats, shapes, res=res, integrator="path",
                   max_depth=depth)
    o, dirs, wq = camera_rays(cam, res[0], res[1], n_pix=n_pix)
    cos_i = np.abs(dirs[..., 2])
    F = fresnel(cos_i, ior)
    # Vertex indices: front face 0, back face 1, emitter 2 + 2k for k internal round trips.
    k = np.arange(0, max(0, (depth - 3) // 2) + 1)
    T = (1 - F[..., None]) ** 2 * F[..., None] ** (2 * k)
    val = le * T.sum(axis=-1)
    truth = 3.0 * np.sum(val * wq, axis=-1)
    return ClosedForm(name or f"slab-ior{ior}", d, truth)


def cube_furnace(ior: float, *, res=(16, 12), name=None, look=(0.0, 0.0, 0.0),
                 cam_pos=(2.2, 1.9, 2.6), fov=40.0) -> ClosedForm:
    """A clear dielectric cube [-0.5, 0.5]^3 (albedo 1) in a uniform background of radiance 1, seen
    from outside with its corner and three edges in view. Lossless, so every pixel is exactly 1
    for unbounded paths (max_depth -1 with roulette from depth 1, unbiased). A ray entering a face
    keeps |direction . axis| under axis-aligned reflections, so total internal reflection at the
    side faces (ior > sqrt(2) or so) delays but never traps it."""
    mats = {"glass": {"kind": "dielectric", "albedo": [1.0] * 3, "ior": float(ior)}}
    shapes = [{"kind": "box", "material": "glass", "min": [-0.5] * 3, "max": [0.5] * 3}]
    cam = camera_dict(cam_pos, look, fov)
    d = scene_dict(f"glass cube furnace ior={ior}", cam, mats, shapes, res=res, integrator="path",
                   max_depth=-1, background=(1.0, 1.0, 1.0), roulette=True, rr_depth=1)
    return ClosedForm(name or f"cube-furnace-ior{ior}", d, np.full((res[1], res[0]), 3.0))


def sphere_interior(*, rho=0.5, le=4.0, R=2.0, r=0.3, depth=5, res=(16, 12), scale=1.0, name=None):
    """Camera inside a diffuse sphere (radius R) lit by a central sphere light (radius r); the camera
    looks away from the light. By symmetry the wall radiance is uniform:
        L = rho Le s sum_{k=0}^{d-2} (rho (1 - s))^k,  s = (r / R)^2 (cosine-weighted fraction of the
    light seen from the wall). A diffuse quad far outside the sphere (never reached) puts `quads` in
    the kernel variant, which is then soft-shadows'."""
    sc = float(scale)
    mats = {"wall": {"kind": "diffuse", "albedo": [rho] * 3},
            "light": {"kind": "emitter", "emission": [le] * 3}}
    shapes = [sphere((0, 0, 0), R * sc, "wall", name="enclosure"),
              sphere((0, 0, 0), r * sc, "light", name="light"),
              quad((50 * sc, 50 * sc, 50 * sc), (sc, 0, 0), (0, 0, sc), "wall", name="feature-quad")]
    cam = camera_dict((0.0, 0.0, 0.6 * R * sc), (0.3 * sc, 0.2 * sc, 2.0 * R * sc), 60.0)
    d = scene_dict("camera inside a sphere", cam, mats, shapes, res=res, integrator="path",
                   max_depth=depth)
    s = (r / R) ** 2
    kmax = (depth - 2) if depth != -1 else None
    if kmax is None:
        L = rho * le * s / (1 - rho * (1 - s))
    else:
        L = rho * le * s * sum((rho * (1 - s)) ** k for k in range(kmax + 1)) if kmax >= 0 else 0.0
    return ClosedForm(name or "sphere-interior", d, np.full((res[1], res[0]), 3.0 * L))

