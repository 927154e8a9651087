"""Calibration of kernels/lights.py's per-shading-point switch between area and solid-angle
(spherical rectangle) sampling of a rectangle light: where does solid angle pay per unit time?

One square light (side a, facing down, centred at height h) over a diffuse plane, seen from below
the light's height so that every pixel shows the plane, from just under the light out to grazing
angles. For each geometry, `importance` (solid angle wherever the old thresholds allowed) and
`importance-area` render the same pixels with independent samples: per-pixel sample variance at
high spp, ns per sample by best-of timing with one thread. A pixel's efficiency ratio is
(var_area t_area) / (var_sa t_sa): above 1 solid angle pays there. Each pixel is tagged with
candidate measures of its centre's shading point (solid angle, the spread of cos_l / d^2 over the
light), and the script prints the ratio binned by each.

    python -m drtlab.experiments.bench.light_switch [--spp 2048] [--out results/bench/light_switch.npz]
"""
from __future__ import annotations

import argparse
import math
import os

import numpy as np

from drtlab.kernels import lights
from drtlab.kernels.render import render_with_stats
from drtlab.kernels.scene_model.scene_file import scene_from_dict

# (side a, height h, camera distance behind the light's foot, look-at offset, camera height; in h)
GEOMETRIES = [(a, 1.0, dz, look, cy) for a in (0.03, 0.1, 0.3, 1.0, 2.0, 4.0)
              for dz, look, cy in ((2.5, 0.0, 0.6), (5.0, -1.0, 0.95))]
RES = (48, 36)
FOV = 16.0


def scene(a: float, h: float, dz: float, look: float, cy: float) -> tuple[dict, np.ndarray, np.ndarray]:
    cam_pos = np.array([0.3 * h, cy * h, dz * h])
    cam_look = np.array([0.0, 0.0, look * h])
    half = 400.0 * h
    light_o = [-a / 2, h, -a / 2]
    d = {"scene": {"description": "square light over a plane", "resolution": list(RES), "spp": 16,
                   "integrator": "drt", "max_depth": 2, "background": [0.0, 0.0, 0.0]},
         "camera": {"position": cam_pos.tolist(), "look_at": cam_look.tolist(), "up": [0, 1, 0],
                    "fov": FOV},
         "materials": {"plane": {"kind": "diffuse", "albedo": [0.7] * 3},
                       "light": {"kind": "emitter", "emission": [5.0] * 3}},
         "shapes": [{"kind": "quad", "material": "plane", "origin": [-half, 0.0, half],
                     "edge_u": [2 * half, 0, 0], "edge_v": [0, 0, -2 * half]},
                    # edge_u x edge_v = (0, -1, 0): emits downwards.
                    {"kind": "quad", "material": "light", "origin": light_o,
                     "edge_u": [a, 0.0, 0.0], "edge_v": [0.0, 0.0, a]}]}
    # Pixel-centre rays (kernels/camera.py's pinhole: vertical fov, right = forward x up).
    fwd = cam_look - cam_pos
    fwd /= np.linalg.norm(fwd)
    right = np.cross(fwd, [0.0, 1.0, 0.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    th = math.tan(math.radians(FOV) / 2)
    tw = th * RES[0] / RES[1]
    px, py = np.meshgrid(np.arange(RES[0]) + 0.5, np.arange(RES[1]) + 0.5)
    dirs = (right * ((2 * px / RES[0] - 1) * tw)[..., None] + up * ((1 - 2 * py / RES[1]) * th)[..., None]
            + fwd)
    t = -cam_pos[1] / dirs[..., 1]
    assert np.all(t > 0)
    x = cam_pos + dirs * t[..., None]
    corners = np.array([[-a / 2, h, -a / 2], [a / 2, h, -a / 2], [a / 2, h, a / 2], [-a / 2, h, a / 2]])
    return d, x, corners


def measures(x: np.ndarray, corners: np.ndarray) -> dict:
    """Candidate predictors at shading points x (..., 3) on the plane y = 0 (normal +y)."""
    a = corners[2, 0] - corners[0, 0]
    h = corners[0, 1]
    # Solid angle (Van Oosterom-Strackee over two triangles).
    def tri(p0, p1, p2):
        r0, r1, r2 = p0 - x, p1 - x, p2 - x
        l0, l1, l2 = (np.linalg.norm(r, axis=-1) for r in (r0, r1, r2))
        num = np.abs(np.einsum("...i,...i", r0, np.cross(r1, r2)))
        den = (l0 * l1 * l2 + np.einsum("...i,...i", r0, r1) * l2 + np.einsum("...i,...i", r0, r2) * l1
               + np.einsum("...i,...i", r1, r2) * l0)
        return 2 * np.arctan2(num, den)
    omega = tri(corners[0], corners[1], corners[2]) + tri(corners[0], corners[2], corners[3])
    # Nearest point of the square and farthest corner: cos_l / d^2 = h / d^3 spans (d_far/d_near)^3.
    near = np.stack([np.clip(x[..., 0], -a / 2, a / 2), np.full(x.shape[:-1], h),
                     np.clip(x[..., 2], -a / 2, a / 2)], -1)
    dn2 = np.sum((near - x) ** 2, -1)
    df2 = np.max([np.sum((c - x) ** 2, -1) for c in corners], axis=0)
    # Receiver cosines at the nearest/farthest point.
    # The small-light solid angle A cos_l / d^2 at the centre (kernels/lights.py's switch).
    c = corners.mean(0)
    dc2 = np.sum((c - x) ** 2, -1)
    proxy = a * a * h / dc2 ** 1.5
    return {"omega": omega, "omega_centre": proxy, "dist_ratio2": df2 / dn2, "a2_over_dn2": a * a / dn2,
            "omega_x_ratio": omega * (df2 / dn2)}


def best_times(d, samplers, spp, reps):
    """Best-of-reps ns per sample of each sampler, one thread, the samplers interleaved (a shared
    machine's load drifts)."""
    best = {smp: math.inf for smp in samplers}
    for _ in range(reps):
        for smp in samplers:
            s = render_with_stats(scene_from_dict(d, name="light-switch"), spp=spp, sampler=smp,
                                  seed=1, threads=1)
            best[smp] = min(best[smp], s.render_seconds)
    return {smp: t / (RES[0] * RES[1] * spp) * 1e9 for smp, t in best.items()}


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--spp", type=int, default=2048)
    ap.add_argument("--time-spp", type=int, default=256)
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--out", default="results/bench/light_switch.npz")
    args = ap.parse_args(argv)
    # The switch off (before any kernel is built: wp.static reads it at code generation, and its
    # value is part of the kernel's hash): `importance` then samples by solid angle wherever the
    # precision thresholds allow, which is what is measured against area here.
    lights.SPHERICAL_PAYS = 0.0
    samplers = ("independent+importance-area", "independent+importance")
    rows = {k: [] for k in ("geom", "cost_ratio", "ratio", "var_ratio", "omega", "omega_centre", "dist_ratio2", "a2_over_dn2",
                            "omega_x_ratio")}
    for gi, geom in enumerate(GEOMETRIES):
        a, h, dz = geom[:3]
        d, x, corners = scene(*geom)
        var = {}
        for smp in samplers:
            st = render_with_stats(scene_from_dict(d, name="light-switch"), spp=args.spp,
                                   sampler=smp, seed=7 + gi, threads=2, variance=True)
            var[smp] = st.variance.sum(-1)
        ns = best_times(d, samplers, args.time_spp, args.reps)
        vr = var[samplers[0]] / np.maximum(var[samplers[1]], 1e-30)
        tr = ns[samplers[0]] / ns[samplers[1]]
        m = measures(x, corners)
        lit = var[samplers[1]] > 0
        print(f"a={a} h={h} dz={dz}: ns area {ns[samplers[0]]:.0f} sa {ns[samplers[1]]:.0f}; "
              f"omega {m['omega'][lit].min():.2e}..{m['omega'][lit].max():.2e}; "
              f"median var ratio {np.median(vr[lit]):.3f}", flush=True)
        rows["geom"].append(np.full(lit.sum(), gi))
        rows["cost_ratio"].append(np.full(lit.sum(), 1.0 / tr))
        rows["ratio"].append((vr * tr)[lit])
        rows["var_ratio"].append(vr[lit])
        for k in m:
            rows[k].append(m[k][lit])
    out = {k: np.concatenate(v) for k, v in rows.items()}
    os.makedirs(os.path.dirname(args.out), exist_ok=True)
    # One cost ratio for all: solid angle's ns/sample over area's where every pixel uses it.
    full = np.array([out["omega"][out["geom"] == g].min() > 2 * lights.SPHERICAL_MIN
                     for g in range(len(GEOMETRIES))])
    kappa = float(np.median([out["cost_ratio"][out["geom"] == g][0] for g in np.flatnonzero(full)]))
    out["ratio_kappa"] = out["var_ratio"] / kappa
    print(f"cost ratio t_sa / t_area where every pixel is sampled by solid angle: {kappa:.2f}")
    np.savez(args.out, **out)
    for k in ("omega", "omega_centre", "dist_ratio2", "omega_x_ratio"):
        report(out, k)


def report(out, key, nbins=20):
    v = out[key]
    edges = np.quantile(v, np.linspace(0, 1, nbins + 1))
    print(f"\nefficiency ratio (area / solid angle, >1: solid angle pays) binned by {key}")
    for lo, hi in zip(edges[:-1], edges[1:]):
        sel = (v >= lo) & (v <= hi)
        r = out["ratio"][sel]
        print(f"  {lo:10.3e} .. {hi:10.3e}  n={sel.sum():5d}  median {np.median(r):6.3f}  "
              f"q25 {np.quantile(r, .25):6.3f} q75 {np.quantile(r, .75):6.3f}  "
              f"var-only {np.median(out['var_ratio'][sel]):6.3f}  "
              f"var / kappa {np.median(out['ratio_kappa'][sel]):6.3f}")


if __name__ == "__main__":
    main()
