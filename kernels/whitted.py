"""Whitted's deterministic tracer per kernel variant: mirror chains, dielectric splits, shadow rays.

`make_whitted(features, rays=rays, bsdf=bsdf, lighting=lighting)` (from make_intersect, make_bsdf
and make_direct) returns the Warp function trace_whitted(sd, o, d) -> radiance. Its area lights
light a surface by light_centres(sd, mat, p, n, ns, wo): each seen as a point source at its centre
(a mesh light: at its area-weighted centroid; n geometric, ns shading normal, as in
kernels/direct.py).
"""
import warp as wp

from drtlab.estimators.domain_maps import PI
from drtlab.kernels.device_scene import MESH, QUAD, SPHERE, SceneData
from drtlab.kernels.direct import DirectLighting
from drtlab.kernels.environment import env_radiance
from drtlab.kernels.features import Features
from drtlab.kernels.intersection.scene_rays import SceneRays
from drtlab.kernels.intersection.primitives import offset_origin, shading_consistent
from drtlab.kernels.materials import EMITTER, Bsdf, emitted
from drtlab.kernels.materials.kinds import model_module
from drtlab.kernels.materials.material_at import MaterialAt, material_at
from drtlab.kernels.scene_model.material_kinds import KINDS, MATERIAL_CODE
from drtlab.kernels.materials.dielectric import interface, refract_dir
from drtlab.kernels.static_tag import variant_tag


def make_whitted(f: Features, *, rays: SceneRays, bsdf: Bsdf,
                 lighting: DirectLighting) -> wp.Function:
    AREA_CENTRES = f.light_centres
    DELTA_LIGHTS = f.delta_lights
    SPLITS = f.whitted_splits
    MESHES = f.meshes
    ENV = f.environment
    # From the kind table's flags: a reflecting non-delta kind (diffuse, glossy, plastic, ggx, ...)
    # ends the ray with its direct light; a reflecting delta kind (mirror, conductor) continues it
    # by its module's sample; a transmitting one splits as a smooth dielectric.
    ENDS = tuple(MATERIAL_CODE[k.name] for k in KINDS
                 if not (k.delta or k.transmits or k.emitter) and k.name in f.kinds)
    MIRRORS = tuple((MATERIAL_CODE[k.name], model_module(k))
                    for k in KINDS if k.delta and not k.transmits and k.name in f.kinds)
    SPLITTING = tuple(MATERIAL_CODE[k.name] for k in KINDS if k.transmits and k.name in f.kinds)
    intersect = rays.intersect
    visible = rays.visible
    visible_mesh = rays.visible_mesh
    eval_bsdf = bsdf.eval_bsdf
    direct_delta_lights = lighting.direct_delta_lights

    @wp.func
    def light_centres(sd: SceneData, mat: MaterialAt, p: wp.vec3, n: wp.vec3, ns: wp.vec3, wo: wp.vec3) -> wp.vec3:
        # Whitted's shadow rays to area-light centres: each light acts as a point source with its
        # radiant intensity towards p (sphere: Le * pi r^2; one-sided quad: Le * A * cos; a mesh:
        # its one-sided flat part |N| cos plus its closed part (A - |N|) / 4, N = sum of area x
        # normal, exact for flat and for closed convex meshes).
        L = wp.vec3(0.0)
        for li in range(sd.lights.n_area):
            k = sd.lights.shape_kind[li]
            s = sd.lights.shape[li]
            c = wp.vec3(0.0)
            intensity = float(0.0)
            m = int(0)
            if k == SPHERE:
                c = sd.spheres.center[s]
                intensity = PI * sd.spheres.radius[s] * sd.spheres.radius[s]
                m = sd.spheres.material[s]
            elif k == QUAD:
                c = sd.quads.origin[s] + 0.5 * (sd.quads.u[s] + sd.quads.v[s])
                m = sd.quads.material[s]
            if wp.static(MESHES):
                if k == MESH:
                    c = sd.meshes.centroid[s]
                    m = sd.meshes.material[s]
            d = c - p
            dist = wp.length(d)
            wi = d / dist
            if k == QUAD:
                intensity = sd.quads.area[s] * wp.max(0.0, -wp.dot(sd.quads.normal[s], wi))
            if wp.static(MESHES):
                if k == MESH:
                    na = sd.meshes.normal_area[s]
                    intensity = (wp.max(0.0, -wp.dot(na, wi))
                                 + 0.25 * wp.max(0.0, sd.meshes.area[s] - wp.length(na)))
            if intensity > 0.0:
                fc = eval_bsdf(mat, ns, wo, wi)
                if wp.static(MESHES):
                    fc = fc * shading_consistent(n, ns, wo, wi)
                if fc[0] > 0.0 or fc[1] > 0.0 or fc[2] > 0.0:
                    o = offset_origin(p, n, wi, sd.eps)
                    seen = int(0)
                    if wp.static(MESHES):
                        if k == MESH:
                            seen = visible_mesh(sd, o, wi, wp.length(c - o), 0.0, s)
                        else:
                            seen = visible(sd, o, wi, wp.length(c - o), 0.0, k, s)
                    else:
                        seen = visible(sd, o, wi, wp.length(c - o), 0.0, k, s)
                    if seen == 1:
                        L += wp.cw_mul(fc, sd.materials.emission[m]) * (intensity / (dist * dist))
        return L

    # Called once per sample: inlined, so SceneData is not copied per call.
    @wp.func(inline=True)
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
                    if wp.static(ENV):      # seen, but lights no surface (as its area lights)
                        L += wp.cw_mul(beta, env_radiance(sd.environment, d))
                    else:
                        L += wp.cw_mul(beta, sd.background)
                    break
                wo = -d
                L += wp.cw_mul(beta, emitted(sd, h, wo))
                if sd.max_depth >= 0 and depth + 1 >= sd.max_depth:
                    break
                m = h.material
                kind = sd.materials.kind[m]
                if kind == EMITTER:
                    break
                mat = material_at(sd, m, h.uv)
                albedo = mat.albedo
                ns = h.n                # the shading normal (a mesh's interpolated one)
                if wp.static(MESHES):
                    ns = h.ns
                cos_o = wp.dot(ns, wo)
                nf = ns
                if cos_o < 0.0:
                    nf = -ns
                co = wp.abs(cos_o)
                ends = False
                _variant = wp.static(variant_tag(ENDS))  # noqa: F841 (static_tag.py)
                for i in range(wp.static(len(ENDS))):
                    if kind == wp.static(ENDS[i]):
                        ends = True
                if ends:
                    direct = wp.vec3(0.0)
                    if wp.static(AREA_CENTRES):
                        direct += light_centres(sd, mat, h.p, h.n, ns, wo)
                    if wp.static(DELTA_LIGHTS):
                        direct += direct_delta_lights(sd, mat, h.p, h.n, ns, wo, 0.0)
                    L += wp.cw_mul(beta, direct)
                    break
                wi = 2.0 * co * nf - wo
                _mirrors = wp.static(variant_tag(MIRRORS))  # noqa: F841 (static_tag.py)
                for i in range(wp.static(len(MIRRORS))):
                    if kind == wp.static(MIRRORS[i][0]):
                        s = wp.static(MIRRORS[i][1].sample)(mat, ns, wo, 0.0, wp.vec2(0.0))
                        wi = s.wi
                        beta = wp.cw_mul(beta, s.weight)
                if wp.static(SPLITS > 0):
                    splits = False
                    _split_variant = wp.static(variant_tag(SPLITTING))  # noqa: F841 (static_tag.py)
                    for i in range(wp.static(len(SPLITTING))):
                        if kind == wp.static(SPLITTING[i]):
                            splits = True
                    if splits:
                        it = interface(ns, wo, mat.ior)
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
                if wp.static(MESHES):
                    if shading_consistent(h.n, ns, wo, wi) == 0.0:
                        break           # reflected through the geometric surface: no leak
                o = offset_origin(h.p, h.n, wi, sd.eps)
                d = wi
                depth += 1
            # A path that used fewer splits than the code encodes is counted by the code whose
            # unused bits are zero only.
            if (code >> used) == 0:
                total += L
        return total

    return trace_whitted
