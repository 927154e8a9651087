"""The Fresnel reflectance of a conductor, the factor the conductor kinds of the kind table
(`MaterialKind.conductor`: `conductor`, `beckmann_conductor`, `ggx_conductor`) put on their albedo.

Mitsuba 3's `fresnel_conductor` (fresnel.h; K. D. Moeller, Optics, 1988): unpolarised reflectance
at |cos| c of an interface from vacuum into a metal of complex index eta + i k, per RGB channel:
    t = eta^2 - k^2 - s^2, a^2 + b^2 = sqrt(t^2 + 4 eta^2 k^2), a = sqrt((a^2 + b^2 + t) / 2)
    r_s = (a^2 + b^2 + c^2 - 2 a c) / (a^2 + b^2 + c^2 + 2 a c)
    r_p = r_s ((a^2 + b^2) c^2 + s^4 - 2 a c s^2) / ((a^2 + b^2) c^2 + s^4 + 2 a c s^2)
    F = (r_s + r_p) / 2,     s^2 = 1 - c^2
Mitsuba's conductors have no exterior index: eta and k are the metal's against vacuum. 0 + 1i
reflects everything (its material "none"). The smooth `conductor` reflects about the normal (c the
cosine to it), the rough ones take c = wo.wm at the half vector (`half_fresnel`, which their modules
beckmann_conductor.py and ggx_conductor.py put on their facets' eval). This module is also the smooth
`conductor` kind, a delta kind on the one BSDF interface (the package docstring; mirror.py's).
"""
import warp as wp

from drtlab.estimators.domain_maps import mirror_dir
from drtlab.kernels.materials.material_at import MaterialAt
from drtlab.kernels.materials.mirror import eval, pdf  # noqa: F401 (a delta kind: no density)
from drtlab.kernels.materials.scatter import Scatter, delta_scatter


@wp.func
def fresnel_conductor1(c: float, eta: float, k: float) -> float:
    c2 = c * c
    s2 = 1.0 - c2
    t = eta * eta - k * k - s2
    ab = wp.sqrt(wp.max(t * t + 4.0 * eta * eta * k * k, 0.0))
    a = wp.sqrt(wp.max(0.5 * (ab + t), 0.0))
    t1 = ab + c2
    t2 = 2.0 * c * a
    rs = (t1 - t2) / (t1 + t2)
    t3 = ab * c2 + s2 * s2
    t4 = t2 * s2
    rp = rs * (t3 - t4) / (t3 + t4)
    return 0.5 * (rs + rp)


@wp.func
def fresnel_conductor(c: float, eta: wp.vec3, k: wp.vec3) -> wp.vec3:
    """F per channel at |cos| c (module doc)."""
    return wp.vec3(fresnel_conductor1(c, eta[0], k[0]), fresnel_conductor1(c, eta[1], k[1]),
                   fresnel_conductor1(c, eta[2], k[2]))


@wp.func
def half_fresnel(eta: wp.vec3, k: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> wp.vec3:
    """F at the half vector of a reflection wo -> wi (a rough conductor's facet)."""
    h = wo + wi
    ll = wp.length(h)
    c = float(0.0)
    if ll > 0.0:
        c = wp.abs(wp.dot(wo, h)) / ll
    return fresnel_conductor(c, eta, k)


@wp.func
def sample(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, u_lobe: float, u: wp.vec2) -> Scatter:
    """The smooth `conductor` kind's delta lobe: albedo times F at the normal."""
    return delta_scatter(mirror_dir(n, wo), wp.cw_mul(mat.albedo, fresnel_conductor(wp.abs(wp.dot(n, wo)), mat.eta,
                                                                                     mat.k)))
