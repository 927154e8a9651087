"""A light-selection heuristic: pick an area light in proportion to its power over the squared
distance from the shading point (pbrt-v4's BVH light sampler in its simplest, flat form), and the
strategy `importance-nearest`: `importance` (BSDF lobes, solid-angle lights, MIS) with this choice.

Use it as any sampler's strategy: `--sampler stratified+importance-nearest`. The pmf is exactly what
pick does (both normalise the same weights at x), so MIS stays unbiased; every light keeps a weight
above zero wherever it is (the distance is floored at 1e-3 of the light's own offset), so no light
is lost. On a scene with one light it is the power pick."""
import warp as wp

import drtlab
from drtlab.kernels.device_scene import SceneData


@wp.func
def _weight(sd: SceneData, x: wp.vec3, li: int) -> float:
    d = sd.lights.center[li] - x
    return sd.lights.pmf[li] / wp.max(wp.dot(d, d), 1.0e-6)


@wp.func
def nearest_pick(sd: SceneData, x: wp.vec3, u: float) -> int:
    total = float(0.0)
    for li in range(sd.lights.n_area):
        total += _weight(sd, x, li)
    target = u * total
    acc = float(0.0)
    for li in range(sd.lights.n_area - 1):
        acc += _weight(sd, x, li)
        if target < acc:
            return li
    return sd.lights.n_area - 1


@wp.func
def nearest_pmf(sd: SceneData, x: wp.vec3, li: int) -> float:
    total = float(0.0)
    for k in range(sd.lights.n_area):
        total += _weight(sd, x, k)
    return _weight(sd, x, li) / total


drtlab.register_light_selection(drtlab.LightSelection(
    "nearest", "power over squared distance from the shading point", nearest_pick, nearest_pmf))
drtlab.register_strategy("importance-nearest", "as importance, lights picked by power / distance^2",
                         like="importance", light_selection="nearest")
