"""`beckmann_conductor_anisotropic`: a rough metal of complex index `eta` + i `k` whose Beckmann
facets are rougher along one surface direction than across it: Mitsuba 3's `roughconductor` with
`distribution="beckmann"` and `alpha_u` != `alpha_v` (include/mitsuba/render/microfacet.h). A kind
of the kind table on the one BSDF interface (the package docstring); the isotropic kinds
(beckmann.py, beckmann_conductor.py) are untouched, so scenes without anisotropy compile none of it.

The lobe lives in the shading frame (s, t, n): s is `mat.tangent` (the hit's dp/du,
kernels/intersection/tangent.py) made orthogonal to n and unit (Mitsuba's Gram-Schmidt
`sh_frame.s`), t = n x s; a tangent that vanishes there falls back to Mitsuba's coordinate_system(n)
(Duff et al. 2017, as frame_to_world). alpha_u (`mat.shape`) is the roughness along s, alpha_v
(`mat.shape_v`) along t. With wo, wi on the side of nf (n turned to wo, as the isotropic kinds: the
lobe is the same on both sides) and m = (x, y, z) in that frame:
    D(m) = exp(-(x^2 / au^2 + y^2 / av^2) / z^2) / (pi au av z^4)      (0 where D z <= 1e-20)
    G1(v) = Walter's rational fit at a = z_v / sqrt(au^2 x_v^2 + av^2 y_v^2) (1 for a >= 1.6 or at
            normal incidence)
    f |cos_i| = albedo F(wo.wm) D(wm) G1(wo) G1(wi) / (4 |cos_o|)
Sampling draws wm from D(m) z (Mitsuba's `sample_visible = false` branch: phi from
tan phi = (av / au) tan(2 pi u.y) on u.y's quadrant, then tan^2 theta = -alpha(phi)^2 log(1 - u.x)
with 1 / alpha(phi)^2 = cos^2 phi / au^2 + sin^2 phi / av^2), reflects wo about it:
pdf = D(wm) z_m / (4 wo.wm). Mitsuba samples visible normals by default; the estimate is the same.
"""
import warp as wp

from drtlab.estimators.domain_maps import INV_PI, facing, frame_to_world, sincos_turns
from drtlab.kernels.materials.conductor import half_fresnel
from drtlab.kernels.materials.material_at import MaterialAt
from drtlab.kernels.materials.scatter import Scatter, proposal


@wp.func
def tangent_s(n: wp.vec3, tangent: wp.vec3) -> wp.vec3:
    """The shading frame's unit s: `tangent` made orthogonal to the unit normal n, or Mitsuba's
    coordinate_system(n) first axis where nothing of it is left."""
    s = tangent - n * wp.dot(n, tangent)
    ll = wp.length(s)
    if ll > 0.0:
        return s / ll
    return frame_to_world(wp.vec3(1.0, 0.0, 0.0), n)


@wp.func
def to_local(v: wp.vec3, s: wp.vec3, t: wp.vec3, nf: wp.vec3) -> wp.vec3:
    return wp.vec3(wp.dot(v, s), wp.dot(v, t), wp.dot(v, nf))


@wp.func
def aniso_d(au: float, av: float, m: wp.vec3) -> float:
    """Beckmann's D at the local facet normal m (unit)."""
    z2 = m[2] * m[2]
    if m[2] <= 0.0:
        return 0.0
    x = m[0] / au
    y = m[1] / av
    d = wp.exp(-(x * x + y * y) / z2) * INV_PI / (au * av * z2 * z2)
    if d * m[2] <= 1.0e-20:
        return 0.0
    return d


@wp.func
def aniso_g1(au: float, av: float, v: wp.vec3) -> float:
    """Smith's masking of local direction v (its z > 0) by facets of roughness (au, av)."""
    xa = au * v[0]
    ya = av * v[1]
    xy = xa * xa + ya * ya
    if xy <= 0.0:
        return 1.0
    a = v[2] / wp.sqrt(xy)
    if a >= 1.6:
        return 1.0
    return (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a)


@wp.func
def aniso_normal(au: float, av: float, u: wp.vec2) -> wp.vec3:
    """A local facet normal of density D(m) z (Mitsuba's non-visible Beckmann sampler)."""
    cos_phi = float(0.0)
    sin_phi = float(0.0)
    alpha2 = au * au
    if au == av:
        sc = sincos_turns(u[1])
        cos_phi = sc[0]
        sin_phi = sc[1]
    else:
        tmp = (av / au) * wp.tan(6.283185307179586 * u[1])
        cos_phi = 1.0 / wp.sqrt(tmp * tmp + 1.0)
        if wp.abs(u[1] - 0.5) - 0.25 < 0.0:       # phi in the second or third quadrant
            cos_phi = -cos_phi
        sin_phi = cos_phi * tmp
        cu = cos_phi / au
        sv = sin_phi / av
        alpha2 = 1.0 / (cu * cu + sv * sv)
    c = 1.0 / wp.sqrt(1.0 - alpha2 * wp.log(1.0 - u[0]))
    s = wp.sqrt(wp.max(1.0 - c * c, 0.0))
    return wp.vec3(cos_phi * s, sin_phi * s, c)


@wp.func
def _half(wo: wp.vec3, wi: wp.vec3) -> wp.vec3:
    h = wo + wi
    ll = wp.length(h)
    if ll <= 0.0:
        return wp.vec3(0.0)
    return h / ll


@wp.func
def eval_facets(albedo: wp.vec3, au: float, av: float, tangent: wp.vec3, n: wp.vec3, wo: wp.vec3,
                wi: wp.vec3) -> wp.vec3:
    """The facets' f |cos_i| without the Fresnel (the lobe of albedo `albedo`)."""
    cos_o = wp.dot(n, wo)
    cos_i = wp.dot(n, wi)
    if cos_o * cos_i <= 0.0:
        return wp.vec3(0.0)
    nf = n
    if cos_o < 0.0:
        nf = -n
    s = tangent_s(n, tangent)
    t = wp.cross(nf, s)
    lo = to_local(wo, s, t, nf)
    li = to_local(wi, s, t, nf)
    lm = to_local(_half(wo, wi), s, t, nf)
    d = aniso_d(au, av, lm)
    g = aniso_g1(au, av, lo) * aniso_g1(au, av, li)
    return albedo * (d * g / (4.0 * lo[2]))


@wp.func
def sample_facets(au: float, av: float, tangent: wp.vec3, n: wp.vec3, wo: wp.vec3, u: wp.vec2) -> wp.vec3:
    nf = facing(n, wo)
    s = tangent_s(n, tangent)
    t = wp.cross(nf, s)
    lm = aniso_normal(au, av, u)
    wm = s * lm[0] + t * lm[1] + nf * lm[2]
    om = wp.dot(wo, wm)
    if om <= 0.0:
        return wp.vec3(0.0)
    wi = 2.0 * om * wm - wo
    if wp.dot(nf, wi) <= 0.0:
        return wp.vec3(0.0)
    return wi


@wp.func
def pdf_facets(au: float, av: float, tangent: wp.vec3, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> float:
    nf = facing(n, wo)
    if wp.dot(nf, wi) <= 0.0 or wp.dot(nf, wo) <= 0.0:
        return 0.0
    wm = _half(wo, wi)
    om = wp.dot(wo, wm)
    if om <= 0.0:
        return 0.0
    s = tangent_s(n, tangent)
    lm = to_local(wm, s, wp.cross(nf, s), nf)
    return aniso_d(au, av, lm) * lm[2] / (4.0 * om)


@wp.func
def eval(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> wp.vec3:
    f = eval_facets(mat.albedo, mat.shape, mat.shape_v, mat.tangent, n, wo, wi)
    return wp.cw_mul(f, half_fresnel(mat.eta, mat.k, wo, wi))


@wp.func
def sample(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, u_lobe: float, u: wp.vec2) -> Scatter:
    return proposal(sample_facets(mat.shape, mat.shape_v, mat.tangent, n, wo, u))


@wp.func
def pdf(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> float:
    return pdf_facets(mat.shape, mat.shape_v, mat.tangent, n, wo, wi)
