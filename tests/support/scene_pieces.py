"""Building blocks of the test scenes: camera dicts and the camera's quadrature rays (the same rays
as kernels/render_kernel.py camera_ray_dir, in float64), scene dicts, quads, spheres and inward boxes."""
from __future__ import annotations

import math

import numpy as np


# ---------------------------------------------------------------------------------------------------
# Cameras: the same rays as kernels/render_kernel.py camera_ray_dir, in float64, for quadrature
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


def gauss01(n: int) -> tuple[np.ndarray, np.ndarray]:
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
    gx, gw = gauss01(n_pix)
    u0, u1 = np.meshgrid(gx, gx, indexing="ij")
    wpix = np.outer(gw, gw).ravel()
    u0, u1 = u0.ravel(), u1.ravel()
    aperture = float(cam.get("aperture_radius", 0.0))
    if aperture > 0 and n_lens_r > 0:
        tr, tw = gauss01(n_lens_r)
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
    from drtlab.kernels.scene_model.procedural import inward_box_faces
    ext = np.asarray(hi, float) - np.asarray(lo, float)
    out = []
    for a, side, origin, eu, ev in inward_box_faces(lo, hi):
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


def glossy_ggx_as(kind: str, integrator: str, **attrs):
    """The built-in glossy-ggx scene at 12x9 under `integrator`, its ggx material made a `kind` with
    `attrs` (arrays as float64): one kind in a lit scene, as cheap to compile as a kind can be."""
    import drtlab
    scene = drtlab.load_scene("glossy-ggx", {"scene.resolution": [12, 9], "scene.integrator": integrator})
    for m in scene.materials:
        if m.kind == "ggx":
            m.kind = kind
            for key, value in attrs.items():
                setattr(m, key, np.asarray(value, dtype=np.float64))
    return scene
