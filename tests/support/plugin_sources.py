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
