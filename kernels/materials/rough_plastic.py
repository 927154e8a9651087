"""`beckmann_plastic`, `ggx_plastic` and their `_nonlinear` twins: Mitsuba 3's `roughplastic`
(src/bsdfs/roughplastic.cpp), a diffuse base (`albedo`, its `diffuse_reflectance`) under a rough
dielectric coat of relative index eta (`ior`, int_ior / ext_ior) and isotropic roughness alpha
(`roughness`), Beckmann or GGX facets; the coat reflects white (`specular_reflectance` 1).
With wo, wi on one side, wm their half vector, F the dielectric Fresnel reflectance at eta, D, G1
as in beckmann.py / ggx_separable.py (Mitsuba's), T the coat's transmittance table and R_int its
internal reflectance (rough_plastic_table.py, per material):
    f |cos_i| = F(wo.wm) D(wm) G1(wo) G1(wi) / (4 |cos_o|)                            (coat)
              + albedo / (1 - R_int) T(|cos_o|) T(|cos_i|) |cos_i| / (pi eta^2)       (base)
with `nonlinear` albedo / (1 - albedo R_int) instead. Lobe choice as Mitsuba's: with t = T(|cos_o|)
and w = 1 / (1 + mean(albedo)), P(coat) = (1 - t) w / ((1 - t) w + t (1 - w)); the coat lobe is
proposed as beckmann.py / ggx_separable.py propose theirs (Mitsuba's sample_visible only changes
the proposal), the base by a cosine lobe. Mitsuba's roughplastic is one-sided; drtlab's is
two-sided, as its `twosided` (the importer's rule).

A kind of the kind table that reads a per-material table (`MaterialKind.table`), on the one BSDF
interface (the package docstring): eval, sample and pdf read the flat MaterialData.table at the
material's row (MaterialAt.table, .row); `table_row` builds the row on the host.
"""
import warp as wp

from drtlab.estimators.domain_maps import INV_PI, facing, frame_to_world, square_to_cosine_hemisphere
from drtlab.kernels.materials import beckmann, ggx_separable
from drtlab.kernels.materials.dielectric import fresnel
from drtlab.kernels.materials.material_at import MaterialAt
from drtlab.kernels.materials.scatter import Scatter, proposal
from drtlab.kernels.materials import rough_plastic_table as _t
from drtlab.kernels.materials.rough_plastic_table import table_row  # noqa: F401 (the host half)

__all__ = ["eval", "sample", "pdf", "table_row"]

# Offsets in a material's row (rough_plastic_table.py).
RES = wp.constant(_t.RES)
R_INT = wp.constant(_t.R_INT)
WEIGHT = wp.constant(_t.WEIGHT)
GGX = wp.constant(_t.GGX)
NONLINEAR = wp.constant(_t.NONLINEAR)


@wp.func
def transmittance(table: wp.array(dtype=float), row: int, c: float) -> float:
    """T at cosine c in [0, 1]: Mitsuba's lerp_gather over the RES entries."""
    x = c * float(RES - 1)
    i = wp.min(int(x), RES - 2)
    t = x - float(i)
    a = table[row + i]
    return table[row + i + 1] * t + (a - a * t)


@wp.func
def coat_probability(table: wp.array(dtype=float), row: int, co: float) -> float:
    t = transmittance(table, row, co)
    w = table[row + WEIGHT]
    ps = (1.0 - t) * w
    return ps / (ps + t * (1.0 - w))


@wp.func
def eval(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> wp.vec3:
    albedo = mat.albedo
    shape = mat.shape
    ior = mat.ior
    table = mat.table
    row = mat.row
    cos_o = wp.dot(n, wo)
    cos_i = wp.dot(n, wi)
    if cos_o * cos_i <= 0.0:
        return wp.vec3(0.0)
    nf = facing(n, wo)
    co = wp.abs(cos_o)
    ci = wp.abs(cos_i)
    white = wp.vec3(1.0)
    spec = wp.vec3(0.0)
    if table[row + GGX] > 0.0:
        spec = ggx_separable.eval_facets(white, shape, nf, wo, wi)
    else:
        spec = beckmann.eval_facets(white, shape, nf, wo, wi)
    wm = wp.normalize(wo + wi)
    r_int = table[row + R_INT]
    d = albedo / (1.0 - r_int)
    if table[row + NONLINEAR] > 0.0:
        d = wp.vec3(albedo[0] / (1.0 - albedo[0] * r_int), albedo[1] / (1.0 - albedo[1] * r_int),
                    albedo[2] / (1.0 - albedo[2] * r_int))
    base = INV_PI / (ior * ior) * ci * transmittance(table, row, co) * transmittance(table, row, ci)
    return spec * fresnel(wp.dot(wo, wm), ior) + d * base


@wp.func
def sample(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, u_lobe: float, u: wp.vec2) -> Scatter:
    nf = facing(n, wo)
    if u_lobe < coat_probability(mat.table, mat.row, wp.abs(wp.dot(n, wo))):
        if mat.table[mat.row + GGX] > 0.0:
            return proposal(ggx_separable.sample_facets(mat.shape, nf, wo, u))
        return proposal(beckmann.sample_facets(mat.shape, nf, wo, u))
    return proposal(frame_to_world(square_to_cosine_hemisphere(u), nf))


@wp.func
def pdf(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> float:
    shape = mat.shape
    table = mat.table
    row = mat.row
    nf = facing(n, wo)
    co = wp.dot(nf, wo)
    ci = wp.dot(nf, wi)
    if co <= 0.0 or ci <= 0.0:
        return 0.0
    pc = coat_probability(table, row, co)
    coat = float(0.0)
    if table[row + GGX] > 0.0:
        coat = ggx_separable.pdf_facets(shape, nf, wo, wi)
    else:
        coat = beckmann.pdf_facets(shape, nf, wo, wi)
    return pc * coat + (1.0 - pc) * ci * INV_PI
