"""Normal and bump maps: Mitsuba 3's `normalmap` and `bumpmap` BSDF wrappers, as a per-hit
perturbation of the shading normal that wraps whichever kind the material is.

The facts carried over (Mitsuba 3.9: src/bsdfs/normalmap.cpp, bumpmap.cpp, normalmap_helpers.h,
render/mesh.cpp, interaction.h):
- The hit's tangent frame: dp_du, dp_dv of the triangle from its positions and texture coordinates
  (the linear map taking the uv edges to the position edges; the geometric normal's
  coordinate_system where the uv triangle is degenerate), s = dp_du made orthogonal to the shading
  normal ns (Gram-Schmidt), t = ns x s.
- normalmap: c = 2 rgb - 1 of the raw texture, in (s, t, ns); bumpmap: with the texture's gradient
  g = scale (df/du, df/dv), dp_du' = dp_du + ns (g_u - ns.dp_du), dp_dv' likewise,
  n = normalize(dp_du' x dp_dv') turned to the geometric normal's side, then read in (s, t, ns).
- `flip_invalid_normals` (default true): where the viewer wo is above ns but below c (or the
  other way round), c -> (-c_s, -c_t, c_n), the perturbed normal mirrored about ns.
- The nested BSDF is evaluated about the perturbed normal nm; eval and pdf are 0 where wi lies on
  different sides of ns and nm (and so is a sampled wi); eval and the sampled weight are multiplied
  by the shadowing term of Estevez et al. 2019 (`use_shadowing_function`, default true):
  2 / (1 + sqrt(1 + a2 tan^2 theta_i)), a2 = min(tan^2 theta_nm / 8, 1), both angles from ns.
The material at the hit keeps nm, a2 and the vector the perturbed tangent is made from (s for a
normal map, dp_du for a bump map: the anisotropic kind, ggx_anisotropic.py, makes it orthogonal to
nm). Compiled only into variants with a normal or bump map (Features.frame_maps): `mapped_bsdf` wraps the composed Bsdf (bsdf.py), `frame_at`
fills the material at a hit (the estimator API's `frame_at`). Not reciprocal, as Mitsuba's are not
(the flip reads wo, the shadowing term wi).
"""
import warp as wp

from drtlab.kernels.device_scene import MESH, SceneData
from drtlab.kernels.intersection.primitives import Hit
from drtlab.kernels.intersection.tangent import Tangents, mesh_tangents, tangent_s
from drtlab.kernels.materials.material_at import MaterialAt
from drtlab.kernels.materials.scatter import Scatter
from drtlab.kernels.materials.texture import (BITMAP, NEAREST, SLOT, material_texture, texel,
                                              texture_value)
from drtlab.kernels.scene_model.texture import LUMINANCE as TEXTURE_LUMINANCE

NORMAL, BUMP = SLOT["normal"], SLOT["bump"]
# Mitsuba's luminance (the linear sRGB Y row): a bump map's height from an RGB texel (bitmap.cpp's
# eval_1_grad reads the luminance of each of the four texels)
LUMINANCE = wp.constant(wp.vec3(*TEXTURE_LUMINANCE))


@wp.func
def flipped_local(c: wp.vec3, wo_local: wp.vec3) -> wp.vec3:
    """flip_invalid_normals: c (in s, t, n) mirrored about n where wo is not on c's side of the
    surface as it is on n's; then normalised."""
    r = c
    if wo_local[2] * wp.dot(wo_local, c) <= 0.0:
        r = wp.vec3(-c[0], -c[1], c[2])
    return wp.normalize(r)


@wp.func
def to_local(s: wp.vec3, ns: wp.vec3, w: wp.vec3) -> wp.vec3:
    return wp.vec3(wp.dot(w, s), wp.dot(w, wp.cross(ns, s)), wp.dot(w, ns))


@wp.func
def normal_map_local(rgb: wp.vec3, s: wp.vec3, ns: wp.vec3, wo: wp.vec3) -> wp.vec3:
    """The normal map's perturbed normal in (s, t, ns): 2 rgb - 1, flipped for wo, normalised."""
    return flipped_local(2.0 * rgb - wp.vec3(1.0), to_local(s, ns, wo))


@wp.func
def bump_map_local(grad: wp.vec2, tg: Tangents, ng: wp.vec3, s: wp.vec3, ns: wp.vec3,
                   wo: wp.vec3) -> wp.vec3:
    """The bump map's perturbed normal in (s, t, ns) from the scaled gradient (df/du, df/dv)."""
    du = tg.dpdu + ns * (grad[0] - wp.dot(ns, tg.dpdu))
    dv = tg.dpdv + ns * (grad[1] - wp.dot(ns, tg.dpdv))
    n = wp.normalize(wp.cross(du, dv))
    if wp.dot(ng, n) < 0.0:
        n = -n
    return flipped_local(to_local(s, ns, n), to_local(s, ns, wo))


@wp.func
def with_local_normal(mat: MaterialAt, local: wp.vec3, s: wp.vec3, ns: wp.vec3) -> MaterialAt:
    """mat about the perturbed normal `local` (in s, t, ns): its world direction and the shadowing
    term's a2 (from the local coordinates, so that an unperturbed normal gives exactly 0)."""
    r = mat
    r.mapped = 1
    r.nm = s * local[0] + wp.cross(ns, s) * local[1] + ns * local[2]
    z2 = local[2] * local[2]
    r.nm_alpha2 = wp.min(0.125 * wp.max(1.0 - z2, 0.0) / z2, 1.0)
    if local[0] == 0.0 and local[1] == 0.0:
        r.nm_alpha2 = 0.0
    return r


@wp.func
def shadowing(alpha2: float, ns: wp.vec3, wi: wp.vec3) -> float:
    """Estevez et al. 2019's shadowing term at wi (angles from the unperturbed ns)."""
    if alpha2 == 0.0:
        return 1.0
    c = wp.dot(ns, wi)
    c2 = c * c
    return 2.0 / (1.0 + wp.sqrt(1.0 + alpha2 * wp.max(1.0 - c2, 0.0) / c2))


@wp.func
def same_side(mat: MaterialAt, ns: wp.vec3, wi: wp.vec3) -> bool:
    return wp.dot(ns, wi) * wp.dot(mat.nm, wi) > 0.0


def mapped_bsdf(bsdf):
    """The Bsdf (bsdf.py) with every kind evaluated about a mapped material's perturbed normal."""
    inner_eval, inner_pdf, inner_sample = bsdf.eval_bsdf, bsdf.pdf_bsdf, bsdf.sample_bsdf

    @wp.func
    def eval_bsdf(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> wp.vec3:
        if mat.mapped == 0:
            return inner_eval(mat, n, wo, wi)
        if not same_side(mat, n, wi):
            return wp.vec3(0.0)
        return inner_eval(mat, mat.nm, wo, wi) * shadowing(mat.nm_alpha2, n, wi)

    @wp.func
    def pdf_bsdf(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> float:
        if mat.mapped == 0:
            return inner_pdf(mat, n, wo, wi)
        if not same_side(mat, n, wi):
            return 0.0
        return inner_pdf(mat, mat.nm, wo, wi)

    @wp.func
    def sample_bsdf(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, u_lobe: float, u: wp.vec2) -> Scatter:
        if mat.mapped == 0:
            return inner_sample(mat, n, wo, u_lobe, u)
        s = inner_sample(mat, mat.nm, wo, u_lobe, u)
        if s.valid == 1:
            if same_side(mat, n, s.wi):
                s.weight = s.weight * shadowing(mat.nm_alpha2, n, s.wi)
            else:
                s.valid = 0
        return s

    return type(bsdf)(eval_bsdf=eval_bsdf, pdf_bsdf=pdf_bsdf, sample_bsdf=sample_bsdf)


@wp.func
def texture_gradient(sd: SceneData, t: int, uv: wp.vec2) -> wp.vec2:
    """(df/du, df/dv) of texture t's luminance at uv, as bitmap.cpp's eval_1_grad: the bilinear
    interpolant's partials in texel units, through to_uv's transpose, times the resolution; 0 for a
    nearest-filtered bitmap and for a checkerboard (flat almost everywhere)."""
    mode = sd.materials.tex_mode[t]
    if mode[0] != wp.static(BITMAP) or mode[1] == wp.static(NEAREST):
        return wp.vec2(0.0)
    ru = sd.materials.tex_u[t]
    rv = sd.materials.tex_v[t]
    size = sd.materials.tex_size[t]
    w = size[0]
    h = size[1]
    first = mode[3]
    wrap = mode[2]
    px = (ru[0] * uv[0] + ru[1] * uv[1] + ru[2]) * float(w) - 0.5
    py = (rv[0] * uv[0] + rv[1] * uv[1] + rv[2]) * float(h) - 0.5
    fx = wp.floor(px)
    fy = wp.floor(py)
    x = int(fx)
    y = int(fy)
    w1x = px - fx
    w1y = py - fy
    f00 = wp.dot(LUMINANCE, texel(sd, first, w, h, wrap, x, y))
    f10 = wp.dot(LUMINANCE, texel(sd, first, w, h, wrap, x + 1, y))
    f01 = wp.dot(LUMINANCE, texel(sd, first, w, h, wrap, x, y + 1))
    f11 = wp.dot(LUMINANCE, texel(sd, first, w, h, wrap, x + 1, y + 1))
    dx = (1.0 - w1y) * (f10 - f00) + w1y * (f11 - f01)
    dy = (1.0 - w1x) * (f01 - f00) + w1x * (f11 - f10)
    return wp.vec2((ru[0] * dx + rv[0] * dy) * float(w), (ru[1] * dx + rv[1] * dy) * float(h))


def frame_at_for(maps: bool):
    """The estimator API's frame_at(sd, mat, h, wo) -> MaterialAt of a variant: the hit's normal or
    bump map applied, the tangent turned with the normal (an anisotropic kind reads it); the
    identity where the scene has no map. A map reads a mesh's texture coordinates and tangents: off
    meshes nothing is perturbed."""
    MAPS = maps

    @wp.func
    def frame_at(sd: SceneData, mat: MaterialAt, h: Hit, wo: wp.vec3) -> MaterialAt:
        r = mat
        if h.kind != MESH:
            return r
        tn = material_texture(sd, h.material, wp.static(NORMAL))
        tb = material_texture(sd, h.material, wp.static(BUMP))
        if tn < 0 and tb < 0:
            return r
        tg = mesh_tangents(sd, h)
        s = tangent_s(h.ns, tg.dpdu)
        local = wp.vec3(0.0, 0.0, 1.0)
        if tn >= 0:
            local = normal_map_local(texture_value(sd, tn, h.uv), s, h.ns, wo)
            r.tangent = s           # normalmap.cpp: the perturbed s is s made orthogonal to nm
        else:
            grad = sd.materials.bump_scale[h.material] * texture_gradient(sd, tb, h.uv)
            local = bump_map_local(grad, tg, h.n, s, h.ns, wo)
            r.tangent = tg.dpdu     # bumpmap.cpp: dp_du made orthogonal to nm
        return with_local_normal(r, local, s, h.ns)

    @wp.func(inline=True)
    def identity(sd: SceneData, mat: MaterialAt, h: Hit, wo: wp.vec3) -> MaterialAt:
        return mat

    return frame_at if MAPS else identity
