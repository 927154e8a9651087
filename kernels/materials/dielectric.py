"""Smooth dielectric boundaries: Fresnel reflectance, refraction, the side a direction arrives from
(the glossy dielectric's two Phong lobes are glossy_dielectric.py).

This module is also the `dielectric` kind of the kind table, a delta kind on the one BSDF interface
(the package docstring; eval and pdf 0, as mirror.py's). Mirror reflection with weight F, else
refraction tinted by `albedo` (the 1/eta^2 of radiance); the lobe chosen by u_lobe with probability F
(1/2 under the uniform strategy, `sampling`; 1 under total internal reflection), the weight divided
by the choice's probability."""
import warp as wp

from drtlab.estimators.domain_maps import mirror_dir
from drtlab.kernels.materials.material_at import MaterialAt
from drtlab.kernels.materials.mirror import eval, pdf  # noqa: F401 (a delta kind: no density)
from drtlab.kernels.materials.scatter import Scatter, delta_scatter


@wp.struct
class Interface:
    """The side of a dielectric boundary a direction wo arrives from."""
    nf: wp.vec3         # normal on wo's side
    co: float           # |cos| of wo
    eta: float          # n_transmitted / n_incident
    F: float            # Fresnel reflectance (1 on total internal reflection)



@wp.func
def fresnel(cos_i: float, eta: float) -> float:
    # Unpolarised Fresnel reflectance; eta = n_transmitted / n_incident; 1 on total reflection.
    sin2_t = (1.0 - cos_i * cos_i) / (eta * eta)
    if sin2_t >= 1.0:
        return 1.0
    cos_t = wp.sqrt(1.0 - sin2_t)
    rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
    rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
    return 0.5 * (rs * rs + rp * rp)


@wp.func
def refract_dir(wo: wp.vec3, nf: wp.vec3, cos_o: float, eta: float) -> wp.vec3:
    sin2_t = (1.0 - cos_o * cos_o) / (eta * eta)
    cos_t = wp.sqrt(wp.max(0.0, 1.0 - sin2_t))
    return wp.normalize(-wo / eta + (cos_o / eta - cos_t) * nf)


@wp.func
def interface(n: wp.vec3, wo: wp.vec3, ior: float) -> Interface:
    # n is the outward normal: wo below it means the ray leaves the medium.
    it = Interface()
    cos_o = wp.dot(n, wo)
    it.nf = n
    it.eta = ior
    if cos_o < 0.0:
        it.nf = -n
        it.eta = 1.0 / ior
    it.co = wp.abs(cos_o)
    it.F = fresnel(it.co, it.eta)
    return it


def _make_sample(uniform: bool):
    """The kind's sample, its lobe chosen with probability F, or 1/2 when `uniform`."""
    UNIFORM = uniform

    @wp.func
    def sample(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, u_lobe: float, u: wp.vec2) -> Scatter:
        it = interface(n, wo, mat.ior)
        F = it.F
        p_reflect = F
        if wp.static(UNIFORM):
            p_reflect = 0.5
        if F >= 1.0:
            p_reflect = 1.0
        if u_lobe < p_reflect:
            return delta_scatter(mirror_dir(n, wo), wp.vec3(F / p_reflect))
        return delta_scatter(refract_dir(wo, it.nf, it.co, it.eta),
                             mat.albedo * ((1.0 - F) / ((1.0 - p_reflect) * it.eta * it.eta)))

    return sample


_SAMPLES = {False: _make_sample(False), True: _make_sample(True)}
sample = _SAMPLES[False]


def sampling(strategy) -> tuple:
    """(sample, pdf) under `strategy`: the lobe choice F, or 1/2 under the uniform strategy."""
    return _SAMPLES[not strategy.lobe], pdf


@wp.func
def scatter_at_normal(wo: wp.vec3, wm: wp.vec3, nf: wp.vec3, eta: float, u_lobe: float) -> wp.vec3:
    """A rough dielectric's lobe choice at microfacet normal wm (on nf's side; eta outside over
    inside as seen from wo): wo reflected about wm with probability F(wo.wm) (the lobe choice number
    u_lobe), else refracted through it; zero where wm faces away from wo or the direction lands on
    the other lobe's side, which the pdf would read as that lobe."""
    om = wp.dot(wo, wm)
    if om <= 0.0:
        return wp.vec3(0.0)
    if u_lobe < fresnel(om, eta):
        wi = 2.0 * om * wm - wo
        if wp.dot(nf, wi) <= 0.0:
            return wp.vec3(0.0)
        return wi
    wi = refract_dir(wo, wm, om, eta)
    if wp.dot(nf, wi) >= 0.0:
        return wp.vec3(0.0)
    return wi
