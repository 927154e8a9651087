"""One path vertex's two steps, composed from the estimator API's own functions: the direct light
at a non-delta vertex and the scattering step that continues the path.

`with_vertex_steps(api)` returns the API with `direct_light` and `scatter` filled in. It runs after
`with_probes` (kernels/integrators/probes.py) and builds both from the functions the API hands out
then, so a negative control or probe that replaces sample_bsdf, next_event, get2d, ... acts inside
these steps too. Each draw is at its built-in named dimension (light_choice, light_position,
lobe_choice, direction), so an integrator written with them draws exactly path tracing's values.
"""
import warp as wp

from drtlab.kernels.device_scene import SceneData
from drtlab.kernels.intersection.primitives import Hit
from drtlab.kernels.materials import Scatter
from drtlab.kernels.materials.material_at import MaterialAt


def with_vertex_steps(api):
    f = api.features
    MESHES, NEE, DELTA_LIGHTS = f.meshes, api.next_events, f.delta_lights
    CHOICE_FROM, LOBE_CHOICE = api.choice_from, api.lobe_choice
    get1d, get2d = api.get1d, api.get2d
    LIGHT_CHOICE, LIGHT_POSITION = api.dim("light_choice"), api.dim("light_position")
    LOBE, DIRECTION = api.dim("lobe_choice"), api.dim("direction")
    next_event, direct_delta_lights = api.next_event, api.direct_delta_lights
    sample_bsdf, shading_consistent = api.sample_bsdf, api.shading_consistent

    # Takes the running sum L and adds to it term by term (the light sample, then the delta
    # lights): adding their sum instead would round differently from the built-ins' images.
    @wp.func(inline=True)
    def direct_light(sd: SceneData, L: wp.vec3, beta: wp.vec3, mat: MaterialAt, h: Hit, wo: wp.vec3,
                     ns: wp.vec3, seed: wp.uint32, pix: wp.uint32, idx: wp.uint32, spp: wp.uint32,
                     depth: int, dt: float) -> wp.vec3:
        out = L
        if wp.static(NEE):
            ul = float(0.0)
            if sd.lights.n_area >= wp.static(CHOICE_FROM):  # else one light is picked
                ul = get1d(seed, pix, idx, LIGHT_CHOICE(depth), spp)
            up = get2d(seed, pix, idx, LIGHT_POSITION(depth), spp)
            out += next_event(sd, beta, mat, h, wo, ul, up, depth, dt)
        if wp.static(DELTA_LIGHTS):
            out += wp.cw_mul(beta, direct_delta_lights(sd, mat, h.p, h.n, ns, wo, dt))
        return out

    # The lobe choice is drawn only where a kind of the variant reads it (each dimension is keyed
    # on its own, so skipping it leaves every other value as it was).
    @wp.func(inline=True)
    def scatter(mat: MaterialAt, h: Hit, wo: wp.vec3, ns: wp.vec3, seed: wp.uint32, pix: wp.uint32,
                idx: wp.uint32, spp: wp.uint32, depth: int) -> Scatter:
        u_lobe = float(0.0)
        if wp.static(LOBE_CHOICE):
            u_lobe = get1d(seed, pix, idx, LOBE(depth), spp)
        s = sample_bsdf(mat, ns, wo, u_lobe, get2d(seed, pix, idx, DIRECTION(depth), spp))
        if wp.static(MESHES):
            # wi leaving through the geometric surface the shading normal hides: the path ends
            if s.valid != 0:
                if shading_consistent(h.n, ns, wo, s.wi) == 0.0:
                    s.valid = 0
        return s

    return api._replace(direct_light=direct_light, scatter=scatter)
