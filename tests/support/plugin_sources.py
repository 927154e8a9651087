"""Plugin sources the tests write to files: the negative controls of the plugin checks."""

# A light selection whose pmf claims 10% more than its pick gives light 0 (the power pick's).
OFF_BY_10 = '''
import warp as wp
import drtlab
from drtlab.kernels.device_scene import SceneData
from drtlab.kernels.light_selection import power_pick


@wp.func
def wrong_pmf(sd: SceneData, x: wp.vec3, li: int) -> float:
    p = sd.lights.pmf[li]
    if li == 0:
        p = p * 1.1
    return p


drtlab.register_light_selection(drtlab.LightSelection("off-by-10", "power, pmf 10% high on light 0",
                                                      power_pick, wrong_pmf))
'''

# A cosine lobe sampler for the diffuse kind whose pdf claims 10% more than it samples.
COSINE_OFF_BY_10 = '''
import warp as wp
import drtlab
from drtlab.estimators.domain_maps import INV_PI, frame_to_world, square_to_cosine_hemisphere
from drtlab.kernels.materials.material_at import MaterialAt
from drtlab.kernels.materials.scatter import Scatter, proposal


@wp.func
def cosine_sample(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, u_lobe: float, u: wp.vec2) -> Scatter:
    return proposal(frame_to_world(square_to_cosine_hemisphere(u), wp.sign(wp.dot(n, wo)) * n))


@wp.func
def cosine_pdf(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> float:
    return wp.max(wp.sign(wp.dot(n, wo)) * wp.dot(n, wi), 0.0) * INV_PI * 1.1


drtlab.register_lobe_sampler(drtlab.LobeSampler("cosine-off", "cosine, pdf 10% high", "diffuse",
                                                cosine_sample, cosine_pdf))
'''
