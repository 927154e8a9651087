"""`ggx_anisotropic`: a rough metal with anisotropic GGX microfacets and separable Smith masking,
Mitsuba 3's `roughconductor` with `distribution="ggx"` and `alpha_u` != `alpha_v` (src/bsdfs/
roughconductor.cpp, include/mitsuba/render/microfacet.h): alpha_u along the shading frame's tangent
s, alpha_v along t = n x s. In that frame, with wm = normalize(wo + wi),
    D(m)   = 1 / (pi au av ((m_x/au)^2 + (m_y/av)^2 + m_z^2)^2)
    G1(v)  = 1 / (1 + Lambda(v)), Lambda = (sqrt(1 + (au^2 v_x^2 + av^2 v_y^2) / v_z^2) - 1) / 2,
             and 0 where v.wm and v_z differ in sign
    f |cos_i| = albedo F(wo.wm) D(wm) G1(wo) G1(wi) / (4 cos_o)      (reflection only)
sampled by visible normals (Dupuy & Benyoub 2023's spherical caps on the stretched hemisphere: the
density G1(wo) D(m) max(0, wo.m) / cos_o of Heitz 2018), as Mitsuba samples it.

A kind of the kind table on the one BSDF interface (the package docstring); mat.shape is alpha_u,
mat.shape_v alpha_v and mat.tangent the tangent the frame is built from (both filled at the hit by
material_at_hit; a map's frame_at turns the tangent); s = the tangent made orthogonal to the normal
the kind is given, which is a normal map's perturbed one where there is a map. Two-sided like
drtlab's other conductors (the normal turned to wo's side). Without a tangent (0) the frame is any
about n; without alpha_v
(shape_v = 0) the lobe is isotropic of alpha_u.
"""
import warp as wp

from drtlab.estimators.domain_maps import INV_PI, facing, frame_to_world
from drtlab.kernels.materials.conductor import half_fresnel
from drtlab.kernels.materials.material_at import MaterialAt
from drtlab.kernels.materials.scatter import Scatter, proposal


@wp.func
def frame_of(mat: MaterialAt, nf: wp.vec3) -> wp.mat33:
    """Rows s, t, nf: the tangent frame alpha_u and alpha_v are measured in."""
    s = mat.tangent - nf * wp.dot(nf, mat.tangent)
    ls = wp.length(s)
    if ls > 1.0e-20:
        s = s / ls
    else:
        s = frame_to_world(wp.vec3(1.0, 0.0, 0.0), nf)
    return wp.matrix_from_rows(s, wp.cross(nf, s), nf)


@wp.func
def alpha_v(mat: MaterialAt) -> float:
    if mat.shape_v > 0.0:
        return mat.shape_v
    return mat.shape


@wp.func
def aniso_d(au: float, av: float, m: wp.vec3) -> float:
    a = m[0] / au
    b = m[1] / av
    d = a * a + b * b + m[2] * m[2]
    return INV_PI / (au * av * d * d)


@wp.func
def aniso_g1(au: float, av: float, v: wp.vec3, m: wp.vec3) -> float:
    if wp.dot(v, m) * v[2] <= 0.0:
        return 0.0
    z2 = v[2] * v[2]
    x = (au * au * v[0] * v[0] + av * av * v[1] * v[1]) / z2
    return 1.0 / (1.0 + 0.5 * x / (1.0 + wp.sqrt(1.0 + x)))


@wp.func
def eval(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> wp.vec3:
    nf = facing(n, wo)
    f = frame_of(mat, nf)
    ol = f * wo
    il = f * wi
    if ol[2] <= 0.0 or il[2] <= 0.0:
        return wp.vec3(0.0)
    m = wp.normalize(ol + il)
    au = mat.shape
    av = alpha_v(mat)
    g = aniso_g1(au, av, ol, m) * aniso_g1(au, av, il, m)
    return wp.cw_mul(mat.albedo, half_fresnel(mat.eta, mat.k, wo, wi)) * (
        0.25 * aniso_d(au, av, m) * g / ol[2])


@wp.func
def sample(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, u_lobe: float, u: wp.vec2) -> Scatter:
    nf = facing(n, wo)
    f = frame_of(mat, nf)
    ol = f * wo
    if ol[2] <= 0.0:
        return proposal(wp.vec3(0.0))
    au = mat.shape
    av = alpha_v(mat)
    wh = wp.normalize(wp.vec3(au * ol[0], av * ol[1], ol[2]))
    phi = 6.283185307179586 * u[0]
    z = (1.0 - u[1]) * (1.0 + wh[2]) - wh[2]
    st = wp.sqrt(wp.clamp(1.0 - z * z, 0.0, 1.0))
    h = wp.vec3(st * wp.cos(phi), st * wp.sin(phi), z) + wh
    m = wp.normalize(wp.vec3(au * h[0], av * h[1], h[2]))
    il = 2.0 * wp.dot(ol, m) * m - ol
    if il[2] <= 0.0:
        return proposal(wp.vec3(0.0))
    return proposal(wp.transpose(f) * il)


@wp.func
def pdf(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> float:
    nf = facing(n, wo)
    f = frame_of(mat, nf)
    ol = f * wo
    il = f * wi
    if ol[2] <= 0.0 or il[2] <= 0.0:
        return 0.0
    m = wp.normalize(ol + il)
    au = mat.shape
    av = alpha_v(mat)
    # G1(wo) D(m) (wo.m) / cos_o, times |dm/dwi| = 1 / (4 wo.m)
    return aniso_g1(au, av, ol, m) * aniso_d(au, av, m) * 0.25 / ol[2]
