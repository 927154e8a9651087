"""Scenes with closed-form pixel values, for the statistical tests (tests/support/stats_util.py).

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
from dataclasses import dataclass

import numpy as np

from drtlab.kernels.scene_model.scene_file import scene_from_dict

import ggx_util
from scene_pieces import camera_dict, camera_rays, gauss01, inward_box_quads, quad, scene_dict, sphere
# Estimate is part of this module's interface: ClosedForm.region_truth returns one.
from stats_util import Estimate, region_values


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


def _square_light_edges(c, a, quad_normal):
    """(origin, edge_u, edge_v) of the square of side a centred at c whose normal edge_u x edge_v is
    the emitting normal quad_normal."""
    nq = np.array(quad_normal, float)
    nq /= np.linalg.norm(nq)
    t1 = np.cross(nq, [0.0, 0.0, 1.0]) if abs(nq[2]) < 0.9 else np.cross(nq, [1.0, 0.0, 0.0])
    t1 /= np.linalg.norm(t1)
    t2 = np.cross(nq, t1)
    eu, ev = t1 * a, t2 * a
    if np.dot(np.cross(eu, ev), nq) < 0:
        eu, ev = ev, eu
    return c - 0.5 * (eu + ev), eu, ev


def _sphere_light_row(o, dirs, t, x, n, c, r):
    """(light fraction s, emitting side) at the plane points x of one image row lit by the sphere
    light (c, r); raises if a camera ray (o, dirs) meets the light before the plane (at t)."""
    frac = _sphere_light_fraction(x, n, c, r)
    front = np.ones_like(frac, bool)
    # The camera must not see the light itself (nor sit inside it).
    oc = c - o
    tc = np.sum(oc * dirs, axis=-1)
    disc = r ** 2 - (np.sum(oc * oc, axis=-1) - tc ** 2)
    root = np.sqrt(np.maximum(disc, 0.0))
    near = np.where(tc - root > 0, tc - root, tc + root)
    if np.any((disc > 0) & (near > 0) & (near < t)):
        raise ValueError("a camera ray sees the sphere light; move the camera")
    return frac, front


def _quad_light_row(o, dirs, t, x, n, c, verts, quad_normal):
    """(light fraction s, emitting side) at the plane points x of one image row lit by the quad light
    (verts, centre c, emitting along quad_normal); raises if a camera ray sees the light."""
    frac = _polygon_fraction(x, n, verts)
    front = np.sum((x - c) * np.asarray(quad_normal) / np.linalg.norm(quad_normal), axis=-1) > 0
    if np.any(_hits_parallelogram(o, dirs, verts[0], verts[1] - verts[0], verts[3] - verts[0], t)):
        raise ValueError("a camera ray sees the quad light; move the camera")
    return frac, front


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
        o, eu, ev = _square_light_edges(c, float(size) * s, quad_normal)
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
            frac, front = _sphere_light_row(o, dirs, t, x, n, c, float(size) * s)
        else:
            frac, front = _quad_light_row(o, dirs, t, x, n, c, verts, quad_normal)
        L = rho * (le * frac * front + bg * (1.0 - frac))
        truth[row] = 3.0 * np.sum(L * w, axis=-1)
    return ClosedForm(name or f"{kind}-light-over-plane", d, truth)


def phong_albedo(cos_o: np.ndarray, exponent: float, n_quad: int = 400) -> np.ndarray:
    """Directional albedo of the normalized modified Phong lobe of kernels/materials/:
    int_{cos_i > 0, cos_alpha > 0} (n + 2) / (2 pi) cos^n(alpha) cos_i dw, alpha measured from the
    mirror direction. Substituting v = cos^(n + 1)(alpha) and integrating phi in closed form:
        A = (n + 2) / (2 pi (n + 1)) int_0^1 g(v) dv,   g = int_0^2pi max(0, a + b cos phi) dphi,
    a = cos(alpha) cos(theta_o), b = sin(alpha) sin(theta_o); g has a kink at a = b, where the
    integral is split."""
    cos_o = np.atleast_1d(np.asarray(cos_o, float))
    n = float(exponent)
    xg, wg = gauss01(n_quad)
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
                   roulette=False, integrator="path", n_pix=6, name=None,
                   roughness=None) -> ClosedForm:
    """One sphere (radius 1 at the origin) in a uniform background of radiance 1, viewed so that every
    pixel sees the sphere. Truth: 1 for lossless kinds (diffuse/mirror/dielectric with albedo 1);
    the modified-Phong directional albedo for glossy (reflected rays never return to a convex
    sphere; ggx: its albedo by tests/support/ggx_util.py's quadrature at `roughness`).
    glossy_dielectric has no closed form here: truth is None (energy bound only)."""
    mat = {"kind": kind}
    if kind != "emitter":
        mat["albedo"] = [albedo] * 3
    if exponent is not None:
        mat["exponent"] = float(exponent)
    if ior is not None:
        mat["ior"] = float(ior)
    if roughness is not None:
        mat["roughness"] = float(roughness)
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
    elif kind == "ggx":
        table_c = np.linspace(0.0, 1.0, 257) ** 0.5
        normal = np.array([0.0, 0.0, 1.0])
        table_a = [ggx_util.GGX(normal, np.array([math.sqrt(1.0 - c * c), 0.0, c]), roughness)
                   .albedo_value(512, 256) if c > 0 else 0.0 for c in table_c]
        truth = 3.0 * np.sum(np.interp(cos_o, table_c, table_a) * w, axis=-1) * albedo
    elif kind in ("diffuse", "mirror", "dielectric") and albedo == 1.0:
        truth = np.full(cos_o.shape[:2], 3.0)
    else:
        truth = None
    return ClosedForm(name or f"{kind}-sphere-furnace", d, truth)


def fresnel(cos_i, eta):
    """Unpolarised Fresnel reflectance as in kernels/materials/dielectric.py (eta = n_t / n_i)."""
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


# ---------------------------------------------------------------------------------------------------
# Environment lights (kernels/scene_model/environment_map.py)
# ---------------------------------------------------------------------------------------------------
def two_level_irradiance(upper: float, lower: float, tilt_deg: float) -> float:
    """Irradiance on a plane whose normal makes the angle a with +y, under radiance `upper` above the
    horizon (y > 0) and `lower` below, the plane's own half-space not blocking anything else: the
    half-space y > 0 fills the fraction (1 + cos a) / 2 of the projected solid angle pi of the
    plane's hemisphere (the sky view factor), so E = pi [upper (1 + cos a) + lower (1 - cos a)] / 2."""
    c = math.cos(math.radians(tilt_deg))
    return math.pi * (upper * (1.0 + c) + lower * (1.0 - c)) / 2.0


def texel_irradiance(height: int, width: int, row: int) -> float:
    """Irradiance per unit radiance from one lat-long texel of `row` (above the horizon) on an upward
    plane: the integral of cos theta over it, (2 pi / W) (sin^2 theta_1 - sin^2 theta_0) / 2."""
    t0, t1 = row * math.pi / height, (row + 1) * math.pi / height
    assert t1 <= math.pi / 2 + 1e-12, "the texel must lie above the horizon"
    return (2.0 * math.pi / width) * (math.sin(t1) ** 2 - math.sin(t0) ** 2) / 2.0


def environment_over_plane(environment: dict, irradiance: float, *, rho=0.6, tilt_deg=0.0,
                           camera=(2.2, 3.0), fov=30.0, res=(16, 12), integrator="path",
                           max_depth=3, name=None) -> ClosedForm:
    """A diffuse plane (albedo rho) through the origin with normal (0, cos a, sin a), alone under an
    `environment` table whose irradiance on it is `irradiance` (two_level_irradiance,
    texel_irradiance): every pixel is rho E / pi. The camera stands camera[0] above the plane and
    camera[1] along it, looking at the origin; every camera ray must hit the plane."""
    a = math.radians(tilt_deg)
    n = np.array([0.0, math.cos(a), math.sin(a)])
    t = np.array([0.0, -math.sin(a), math.cos(a)])
    e1 = np.array([1.0, 0.0, 0.0])
    half = 40.0
    cam = camera_dict(camera[0] * n + camera[1] * t, (0.0, 0.0, 0.0), fov, up=tuple(n))
    mats = {"plane": {"kind": "diffuse", "albedo": [rho] * 3}}
    shapes = [quad(-half * t - half * e1, 2 * half * t, 2 * half * e1, "plane", name="plane")]
    d = scene_dict("a plane under an environment", cam, mats, shapes, res=res,
                   integrator=integrator, max_depth=max_depth)
    d["environment"] = environment
    o, dirs, _ = camera_rays(cam, res[0], res[1], n_pix=2)
    dist = -(o @ n) / (dirs @ n)
    hit = o + dirs * dist[..., None]
    if not (np.all(dist > 0) and np.all(np.abs(hit @ t) < half) and np.all(np.abs(hit[..., 0]) < half)):
        raise ValueError("every camera ray must hit the plane inside its extent")
    truth = np.full((res[1], res[0]), 3.0 * rho * irradiance / math.pi)
    return ClosedForm(name or "environment-over-plane", d, truth)
