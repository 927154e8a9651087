"""Whitted's pieces per kernel variant, for the estimator API (the integrator itself is
kernels/integrators/whitted.py): shadow rays to light centres, which kinds end a ray, mirror
chains, which kinds split.

`make_whitted_parts(features, rays=rays, bsdf=bsdf)` (from make_intersect and make_bsdf) returns
WhittedParts. Its area lights light a surface by light_centres(sd, mat, p, n, ns, wo): each seen
as a point source at its centre (a mesh light: at its area-weighted centroid; n geometric, ns
shading normal, as in kernels/direct.py).
"""
from typing import NamedTuple

import warp as wp

from drtlab.estimators.domain_maps import PI
from drtlab.kernels.device_scene import MESH, QUAD, SPHERE, SceneData
from drtlab.kernels.features import Features
from drtlab.kernels.intersection.scene_rays import SceneRays
from drtlab.kernels.intersection.primitives import offset_origin, shading_consistent
from drtlab.kernels.materials import Bsdf, Scatter
from drtlab.kernels.materials.kinds import model_module
from drtlab.kernels.materials.material_at import MaterialAt
from drtlab.kernels.scene_model.material_kinds import KINDS, MATERIAL_CODE
from drtlab.kernels.static_tag import variant_tag


class WhittedParts(NamedTuple):
    light_centres: wp.Function      # (sd, mat, p, n, ns, wo) -> direct light of the area lights' centres
    ends_path: wp.Function          # (kind) -> a non-delta reflecting kind: light it and end the ray
    specular_reflect: wp.Function   # (mat, kind, ns, wo) -> Scatter: the mirror direction and weight
    splits: wp.Function             # (kind) -> a transmitting kind: split into reflection and refraction


def make_whitted_parts(f: Features, *, rays: SceneRays, bsdf: Bsdf) -> WhittedParts:
    MESHES = f.meshes
    # From the kind table's flags: a reflecting non-delta kind (diffuse, glossy, plastic, ggx, ...)
    # ends the ray with its direct light; a reflecting delta kind (mirror, conductor) continues it
    # by its module's sample; a transmitting one splits as a smooth dielectric.
    ENDS = tuple(MATERIAL_CODE[k.name] for k in KINDS
                 if not (k.delta or k.transmits or k.emitter) and k.name in f.kinds)
    MIRRORS = tuple((MATERIAL_CODE[k.name], model_module(k))
                    for k in KINDS if k.delta and not k.transmits and k.name in f.kinds)
    SPLITTING = tuple(MATERIAL_CODE[k.name] for k in KINDS if k.transmits and k.name in f.kinds)
    visible = rays.visible
    visible_mesh = rays.visible_mesh
    eval_bsdf = bsdf.eval_bsdf

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

    @wp.func
    def ends_path(kind: int) -> bool:
        # A reflecting non-delta kind: Whitted takes its direct light and ends the ray there.
        ends = False
        _variant = wp.static(variant_tag(ENDS))  # noqa: F841 (static_tag.py)
        for i in range(wp.static(len(ENDS))):
            if kind == wp.static(ENDS[i]):
                ends = True
        return ends

    @wp.func
    def specular_reflect(mat: MaterialAt, kind: int, ns: wp.vec3, wo: wp.vec3) -> Scatter:
        # The mirror direction about the shading normal on wo's side, weight 1; a reflecting delta
        # kind's own (its module's delta sample: a conductor's Fresnel, say) where the kind is one.
        cos_o = wp.dot(ns, wo)
        nf = ns
        if cos_o < 0.0:
            nf = -ns
        s = Scatter()
        s.wi = 2.0 * wp.abs(cos_o) * nf - wo
        s.weight = wp.vec3(1.0)
        s.pdf = 0.0
        s.delta = 1
        s.valid = 1
        _mirrors = wp.static(variant_tag(MIRRORS))  # noqa: F841 (static_tag.py)
        for i in range(wp.static(len(MIRRORS))):
            if kind == wp.static(MIRRORS[i][0]):
                m = wp.static(MIRRORS[i][1].sample)(mat, ns, wo, 0.0, wp.vec2(0.0))
                s.wi = m.wi
                s.weight = m.weight
        return s

    @wp.func
    def splits(kind: int) -> bool:
        # A transmitting kind: Whitted splits the ray into its reflection and refraction.
        split = False
        _split_variant = wp.static(variant_tag(SPLITTING))  # noqa: F841 (static_tag.py)
        for i in range(wp.static(len(SPLITTING))):
            if kind == wp.static(SPLITTING[i]):
                split = True
        return split

    return WhittedParts(light_centres=light_centres, ends_path=ends_path,
                        specular_reflect=specular_reflect, splits=splits)
