"""Kernel factory: one compiled render kernel per scene feature set.

`build_kernel(features, pointset, strategy)` returns a Warp kernel in which everything the scene does
not use (lens, motion, material kinds, light kinds, shape kinds, roulette, the other integrators) is
removed at code generation by `wp.static`, so a scene without motion blur pays nothing for it.

The kernel renders `count` samples (indices index0 ... index0 + count - 1) of every pixel of one tile
and adds their float64 sum to `accum`. A sample's random numbers come only from the point set keyed by
(seed, pixel, sample index, dimension), so tiles, threads and launch order cannot change the image.
Tracers are loops with a throughput weight (Warp kernels cannot recurse); radiance is traced in
float32 and summed per pixel in float64.
"""
from __future__ import annotations

import warp as wp

from drtlab.estimators import dimensions as dims
from drtlab.estimators.pointsets.base import PointSet
from drtlab.estimators.strategies import Strategy
from drtlab.estimators.warps import INV_PI, PI, square_to_disk
from drtlab.kernels.geometry import Hit, hit_quad, hit_sphere, offset_origin, quad_params
from drtlab.kernels.lights import make_lights
from drtlab.kernels.materials import (DIELECTRIC, DIFFUSE, EMITTER, GLOSSY, GLOSSY_DIELECTRIC,
                                      MIRROR, interface, make_bsdf, refract_dir)
from drtlab.kernels.device_scene import QUAD, SPHERE, Features, SceneData, make_motion

# Whitted splits a ray at up to this many dielectric interfaces (2**N reflect/refract paths).
WHITTED_SPLITS = 4
# Hard cap on path length even for max_depth = -1 with roulette (guards against a stuck loop).
DEPTH_CAP = 512


def build_kernel(f: Features, pointset: PointSet, strategy: Strategy):
    get1d = pointset.get1d
    get2d = pointset.get2d
    WHITTED = f.integrator == "whitted"
    DRT = f.integrator == "drt"
    LENS = f.lens
    MOTION = f.motion
    HAS_SPH = f.spheres
    HAS_QUAD = f.quads
    K_DIEL = "dielectric" in f.kinds
    K_GDIEL = "glossy_dielectric" in f.kinds
    CHECKER = f.checker
    AREA = f.area_lights and not WHITTED
    AREA_CENTRES = f.area_lights and WHITTED
    POINTS = f.point_lights
    DIRS = f.dir_lights
    RR = f.roulette and f.integrator == "path"
    LOBE = strategy.direction == "lobe"
    SOLID_ANGLE = strategy.light == "solid_angle"
    POWER_PICK = strategy.light_pick == "power"
    NEE = strategy.combine in ("nee", "mis") and strategy.light is not None
    COUNT_HITS = strategy.combine in ("bsdf", "mis")
    MIS = strategy.combine == "mis"
    SPLITS = WHITTED_SPLITS if (WHITTED and (K_DIEL or K_GDIEL)) else 0

    # ------------------------------------------------------------------ geometry
    motion_funcs = make_motion(MOTION)
    sphere_center = motion_funcs.sphere_center
    quad_origin = motion_funcs.quad_origin

    @wp.func
    def intersect(sd: SceneData, o: wp.vec3, d: wp.vec3, tmax: float, dt: float) -> Hit:
        h = Hit()
        h.t = tmax
        h.kind = -1
        h.index = -1
        if wp.static(HAS_SPH):
            for i in range(sd.n_spheres):
                c = sphere_center(sd, i, dt)
                t = hit_sphere(o, d, c, sd.sph_radius[i], h.t)
                if t < h.t:
                    h.t = t
                    h.kind = SPHERE
                    h.index = i
        if wp.static(HAS_QUAD):
            for i in range(sd.n_quads):
                q0 = quad_origin(sd, i, dt)
                t = hit_quad(o, d, q0, sd.quad_u[i], sd.quad_v[i], h.t)
                if t < h.t:
                    h.t = t
                    h.kind = QUAD
                    h.index = i
        if h.index >= 0:
            p = o + d * h.t
            h.p = p
            if wp.static(HAS_SPH):
                if h.kind == SPHERE:
                    c = sphere_center(sd, h.index, dt)
                    n = wp.normalize(p - c)
                    h.n = n
                    h.uv = wp.vec2(0.5 + wp.atan2(n[2], n[0]) * (0.5 * INV_PI),
                                   wp.acos(wp.clamp(n[1], -1.0, 1.0)) * INV_PI)
                    h.material = sd.sph_material[h.index]
                    h.light = sd.sph_light[h.index]
            if wp.static(HAS_QUAD):
                if h.kind == QUAD:
                    q0 = quad_origin(sd, h.index, dt)
                    h.n = sd.quad_normal[h.index]
                    h.uv = quad_params(p - q0, sd.quad_u[h.index], sd.quad_v[h.index])
                    h.material = sd.quad_material[h.index]
                    h.light = sd.quad_light[h.index]
        return h

    @wp.func
    def visible(sd: SceneData, o: wp.vec3, d: wp.vec3, dist: float, dt: float,
                target_kind: int, target_index: int) -> int:
        # A light point is visible when nothing is hit before it, or the first hit is the light's
        # own shape (robust against the shadow ray stopping a hair short of or past the point).
        if target_index < 0:
            h = intersect(sd, o, d, dist * (1.0 - 1.0e-4), dt)
            if h.index < 0:
                return 1
            return 0
        h = intersect(sd, o, d, dist * (1.0 + 1.0e-3) + sd.eps, dt)
        if h.index < 0:
            return 1
        if h.kind == target_kind and h.index == target_index:
            return 1
        return 0

    # ------------------------------------------------------------------ materials
    @wp.func
    def surface_albedo(sd: SceneData, m: int, uv: wp.vec2) -> wp.vec3:
        a = sd.mat_albedo[m]
        if wp.static(CHECKER):
            c = sd.mat_checker[m]
            if c[0] > 0.0:
                iu = int(wp.floor(uv[0] * c[0]))
                iv = int(wp.floor(uv[1] * c[1]))
                if (iu + iv) % 2 != 0:
                    a = sd.mat_albedo2[m]
        return a

    bsdf = make_bsdf(f.kinds, LOBE)
    eval_bsdf = bsdf.eval_bsdf
    pdf_bsdf = bsdf.pdf_bsdf
    sample_bsdf = bsdf.sample_bsdf

    # ------------------------------------------------------------------ lights
    lights = make_lights(MOTION, SOLID_ANGLE, POWER_PICK, "light_jacobian" in f.faults)
    pick_light = lights.pick_light
    light_pdf = lights.light_pdf
    sample_light = lights.sample_light

    @wp.func
    def direct_delta_lights(sd: SceneData, kind: int, albedo: wp.vec3, exponent: float,
                            ior: float, p: wp.vec3, n: wp.vec3, wo: wp.vec3, dt: float) -> wp.vec3:
        L = wp.vec3(0.0)
        if wp.static(POINTS):
            for i in range(sd.n_point_lights):
                d = sd.pl_position[i] - p
                dist = wp.length(d)
                wi = d / dist
                fc = eval_bsdf(kind, albedo, exponent, ior, n, wo, wi)
                if fc[0] > 0.0 or fc[1] > 0.0 or fc[2] > 0.0:
                    o = offset_origin(p, n, wi, sd.eps)
                    if visible(sd, o, wi, wp.length(sd.pl_position[i] - o), dt, -1, -1) == 1:
                        L += wp.cw_mul(fc, sd.pl_intensity[i]) / (dist * dist)
        if wp.static(DIRS):
            for i in range(sd.n_dir_lights):
                wi = -sd.dl_direction[i]
                fc = eval_bsdf(kind, albedo, exponent, ior, n, wo, wi)
                if fc[0] > 0.0 or fc[1] > 0.0 or fc[2] > 0.0:
                    o = offset_origin(p, n, wi, sd.eps)
                    if visible(sd, o, wi, 1.0e30, dt, -1, -1) == 1:
                        L += wp.cw_mul(fc, sd.dl_irradiance[i])
        return L

    @wp.func
    def light_centres(sd: SceneData, kind: int, albedo: wp.vec3, exponent: float, ior: float,
                      p: wp.vec3, n: wp.vec3, wo: wp.vec3) -> wp.vec3:
        # Whitted's shadow rays to area-light centres: each light acts as a point source with its
        # radiant intensity towards p (sphere: Le * pi r^2; one-sided quad: Le * A * cos).
        L = wp.vec3(0.0)
        for li in range(sd.n_lights):
            k = sd.light_shape_kind[li]
            s = sd.light_shape[li]
            c = wp.vec3(0.0)
            intensity = float(0.0)
            m = int(0)
            if k == SPHERE:
                c = sd.sph_center[s]
                intensity = PI * sd.sph_radius[s] * sd.sph_radius[s]
                m = sd.sph_material[s]
            else:
                c = sd.quad_origin[s] + 0.5 * (sd.quad_u[s] + sd.quad_v[s])
                m = sd.quad_material[s]
            d = c - p
            dist = wp.length(d)
            wi = d / dist
            if k == QUAD:
                intensity = sd.quad_area[s] * wp.max(0.0, -wp.dot(sd.quad_normal[s], wi))
            if intensity > 0.0:
                fc = eval_bsdf(kind, albedo, exponent, ior, n, wo, wi)
                if fc[0] > 0.0 or fc[1] > 0.0 or fc[2] > 0.0:
                    o = offset_origin(p, n, wi, sd.eps)
                    if visible(sd, o, wi, wp.length(c - o), 0.0, k, s) == 1:
                        L += wp.cw_mul(fc, sd.mat_emission[m]) * (intensity / (dist * dist))
        return L

    # ------------------------------------------------------------------ integrators
    @wp.func
    def camera_ray_dir(sd: SceneData, px: int, py: int, u: wp.vec2, lens: wp.vec2) -> wp.vec3:
        sx = (2.0 * (float(px) + u[0]) / float(sd.width) - 1.0) * sd.half_width
        sy = (1.0 - 2.0 * (float(py) + u[1]) / float(sd.height)) * sd.half_height
        # Thin lens: aim from the lens point at the point the pinhole ray meets the focal plane;
        # written as (x, y, 1) - lens / focus so that a zero aperture reproduces the pinhole exactly.
        cx = sx - lens[0] / sd.focus_distance
        cy = sy - lens[1] / sd.focus_distance
        return wp.normalize(sd.cam_right * cx + sd.cam_up * cy + sd.cam_forward)

    @wp.func
    def emitted(sd: SceneData, h: Hit, wo: wp.vec3) -> wp.vec3:
        # Emitters radiate on the side their normal faces (spheres outward, quads edge_u x edge_v).
        if wp.dot(h.n, wo) > 0.0:
            return sd.mat_emission[h.material]
        return wp.vec3(0.0)

    @wp.func
    def trace_whitted(sd: SceneData, o0: wp.vec3, d0: wp.vec3) -> wp.vec3:
        total = wp.vec3(0.0)
        # A dynamic bound: Warp would unroll a constant one 2**SPLITS times and compile for long.
        for code in range(sd.whitted_codes):
            L = wp.vec3(0.0)
            beta = wp.vec3(1.0)
            o = o0
            d = d0
            used = int(0)
            depth = int(0)
            while True:
                h = intersect(sd, o, d, 1.0e30, 0.0)
                if h.index < 0:
                    L += wp.cw_mul(beta, sd.background)
                    break
                wo = -d
                L += wp.cw_mul(beta, emitted(sd, h, wo))
                if sd.max_depth >= 0 and depth + 1 >= sd.max_depth:
                    break
                m = h.material
                kind = sd.mat_kind[m]
                if kind == EMITTER:
                    break
                albedo = surface_albedo(sd, m, h.uv)
                cos_o = wp.dot(h.n, wo)
                nf = h.n
                if cos_o < 0.0:
                    nf = -h.n
                co = wp.abs(cos_o)
                if kind == DIFFUSE or kind == GLOSSY:
                    direct = wp.vec3(0.0)
                    if wp.static(AREA_CENTRES):
                        direct += light_centres(sd, kind, albedo, sd.mat_exponent[m],
                                                sd.mat_ior[m], h.p, h.n, wo)
                    if wp.static(POINTS or DIRS):
                        direct += direct_delta_lights(sd, kind, albedo, sd.mat_exponent[m],
                                                      sd.mat_ior[m], h.p, h.n, wo, 0.0)
                    L += wp.cw_mul(beta, direct)
                    break
                wi = 2.0 * co * nf - wo
                if kind == MIRROR:
                    beta = wp.cw_mul(beta, albedo)
                if wp.static(SPLITS > 0):
                    if kind == DIELECTRIC or kind == GLOSSY_DIELECTRIC:
                        it = interface(h.n, wo, sd.mat_ior[m])
                        eta = it.eta
                        F = it.F
                        if F < 1.0:
                            if used >= wp.static(SPLITS):
                                break
                            if ((code >> used) & 1) == 1:
                                wi = refract_dir(wo, nf, co, eta)
                                beta = wp.cw_mul(beta, albedo) * ((1.0 - F) / (eta * eta))
                            else:
                                beta = beta * F
                            used += 1
                o = offset_origin(h.p, h.n, wi, sd.eps)
                d = wi
                depth += 1
            # A path that used fewer splits than the code encodes is counted by the code whose
            # unused bits are zero only.
            if (code >> used) == 0:
                total += L
        return total

    @wp.func
    def trace(sd: SceneData, seed: wp.uint32, pix: wp.uint32, idx: wp.uint32, spp: wp.uint32,
              o0: wp.vec3, d0: wp.vec3, dt: float) -> wp.vec3:
        L = wp.vec3(0.0)
        beta = wp.vec3(1.0)
        o = o0
        d = d0
        depth = int(0)
        prev_delta = int(1)      # camera rays and delta bounces see emitters at full weight
        prev_pdf = float(0.0)
        prev_p = o0
        last_segment = int(0)    # drt: after a diffuse scatter only the emission hit counts
        while True:
            h = intersect(sd, o, d, 1.0e30, dt)
            if h.index < 0:
                L += wp.cw_mul(beta, sd.background)
                break
            wo = -d
            m = h.material
            if wp.static(f.area_lights):
                if h.light >= 0:
                    Le = emitted(sd, h, wo)
                    w = float(1.0)
                    if prev_delta == 0:
                        if wp.static(MIS):
                            pl = light_pdf(sd, h.light, prev_p, h.p, h.n, dt)
                            w = prev_pdf * prev_pdf / (prev_pdf * prev_pdf + pl * pl)
                        elif wp.static(not COUNT_HITS):
                            w = 0.0
                    L += wp.cw_mul(beta, Le) * w
            if last_segment == 1:
                break
            if sd.max_depth >= 0 and depth + 1 >= sd.max_depth:
                break
            if depth >= wp.static(DEPTH_CAP):
                break
            kind = sd.mat_kind[m]
            if kind == EMITTER:
                break
            base = wp.uint32(wp.static(dims.BOUNCE_BASE)) + wp.uint32(
                wp.static(dims.PER_BOUNCE)) * wp.uint32(depth)
            if wp.static(RR):
                if depth >= sd.rr_depth:
                    q = wp.min(wp.max(beta[0], wp.max(beta[1], beta[2])), 0.95)
                    if get1d(seed, pix, idx, base + wp.uint32(wp.static(dims.ROULETTE)),
                             spp) >= q:
                        break
                    if wp.static("rr_no_reweight" not in f.faults):
                        beta = beta / q
            albedo = surface_albedo(sd, m, h.uv)
            exponent = sd.mat_exponent[m]
            ior = sd.mat_ior[m]
            is_delta = kind == MIRROR or kind == DIELECTRIC
            if not is_delta:
                if wp.static(AREA and NEE):
                    ul = get1d(seed, pix, idx, base + wp.uint32(wp.static(dims.LIGHT_CHOICE)), spp)
                    li = pick_light(sd, ul)
                    up = get2d(seed, pix, idx, base + wp.uint32(wp.static(dims.LIGHT_POSITION)),
                               spp)
                    ls = sample_light(sd, li, h.p, up, dt)
                    if ls.valid == 1:
                        fc = eval_bsdf(kind, albedo, exponent, ior, h.n, wo, ls.wi)
                        if wp.static("drop_cosine" in f.faults):
                            fc = fc / wp.abs(wp.dot(h.n, ls.wi))
                        if fc[0] > 0.0 or fc[1] > 0.0 or fc[2] > 0.0:
                            so = offset_origin(h.p, h.n, ls.wi, sd.eps)
                            lk = sd.light_shape_kind[li]
                            if visible(sd, so, ls.wi, ls.dist, dt, lk, sd.light_shape[li]) == 1:
                                w = float(1.0)
                                if wp.static(MIS):
                                    pb = pdf_bsdf(kind, exponent, ior, h.n, wo, ls.wi)
                                    w = ls.pdf * ls.pdf / (ls.pdf * ls.pdf + pb * pb)
                                L += wp.cw_mul(beta, wp.cw_mul(fc, ls.radiance)) * (w / ls.pdf)
                if wp.static(POINTS or DIRS):
                    L += wp.cw_mul(beta, direct_delta_lights(sd, kind, albedo, exponent, ior,
                                                             h.p, h.n, wo, dt))
            u_lobe = get1d(seed, pix, idx, base + wp.uint32(wp.static(dims.LOBE_CHOICE)), spp)
            u_dir = get2d(seed, pix, idx, base + wp.uint32(wp.static(dims.DIRECTION)), spp)
            s = sample_bsdf(kind, albedo, exponent, ior, h.n, wo, u_lobe, u_dir)
            if s.valid == 0:
                break
            beta = wp.cw_mul(beta, s.weight)
            if wp.static("drop_cosine" in f.faults):
                if s.delta == 0:
                    beta = beta / wp.abs(wp.dot(h.n, s.wi))
            if wp.static("pdf_high_10pct" in f.faults):
                if s.delta == 0:
                    beta = beta / 1.1
            if wp.static(DRT):
                if kind == DIFFUSE:
                    last_segment = 1
                    if wp.static(not (COUNT_HITS or f.background)):
                        break
            prev_delta = s.delta
            prev_pdf = s.pdf
            prev_p = h.p
            o = offset_origin(h.p, h.n, s.wi, sd.eps)
            d = s.wi
            depth += 1
        return L

    @wp.kernel(enable_backward=False, module="unique")
    def render_tile(sd: SceneData, seed: wp.uint32, index0: int, count: int, spp: int,
                    x0: int, y0: int, tile_w: int, tile_h: int, accum: wp.array(dtype=wp.vec3d)):
        tid = wp.tid()
        px = x0 + tid % tile_w
        py = y0 + tid / tile_w
        if px >= sd.width or py >= sd.height:
            return
        pixel = py * sd.width + px
        pix = wp.uint32(pixel)
        uspp = wp.uint32(spp)
        total = wp.vec3d(wp.float64(0.0), wp.float64(0.0), wp.float64(0.0))
        nx = int(1)
        if wp.static(WHITTED):
            nx = int(wp.floor(wp.sqrt(float(spp)) + 0.5))
            while nx * nx > spp:
                nx -= 1
            while spp % nx != 0:
                nx -= 1
        for k in range(count):
            idx = wp.uint32(index0 + k)
            if wp.static(WHITTED):
                # Regular sub-pixel grid at stratum centres, lens centre, shutter-open time.
                sub = (index0 + k) % spp
                ny = spp / nx
                u = wp.vec2((float(sub % nx) + 0.5) / float(nx), (float(sub / nx) + 0.5) / float(ny))
                d = camera_ray_dir(sd, px, py, u, wp.vec2(0.0, 0.0))
                Ls = trace_whitted(sd, sd.cam_position, d)
            else:
                u = get2d(seed, pix, idx, wp.uint32(wp.static(dims.PIXEL)), uspp)
                lens = wp.vec2(0.0, 0.0)
                o = sd.cam_position
                if wp.static(LENS):
                    lens = square_to_disk(get2d(seed, pix, idx, wp.uint32(wp.static(dims.LENS)),
                                                uspp)) * sd.aperture
                    o = o + sd.cam_right * lens[0] + sd.cam_up * lens[1]
                d = camera_ray_dir(sd, px, py, u, lens)
                dt = float(0.0)
                if wp.static(MOTION):
                    dt = (sd.shutter_close - sd.shutter_open) * get1d(
                        seed, pix, idx, wp.uint32(wp.static(dims.TIME)), uspp)
                Ls = trace(sd, seed, pix, idx, uspp, o, d, dt)
            total += wp.vec3d(wp.float64(Ls[0]), wp.float64(Ls[1]), wp.float64(Ls[2]))
        accum[pixel] = accum[pixel] + total

    return render_tile
