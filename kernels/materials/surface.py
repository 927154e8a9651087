"""What a hit's material shows besides its BSDF: the (checkered) albedo and the emission."""
import warp as wp

from drtlab.kernels.device_scene import SceneData
from drtlab.kernels.intersection.primitives import Hit


@wp.func
def checkered(sd: SceneData, m: int) -> int:
    """1 when material m is a checker texture (it reads the hit's uv)."""
    if sd.materials.checker[m][0] > 0.0:
        return 1
    return 0


@wp.func
def surface_albedo(sd: SceneData, m: int, uv: wp.vec2) -> wp.vec3:
    """Albedo at a surface point; checkered materials alternate albedo and albedo2. A runtime
    switch, not a compiled-out feature: one load and a branch per hit, and scenes with and without
    checker textures share a kernel variant."""
    a = sd.materials.albedo[m]
    if checkered(sd, m) == 1:
        c = sd.materials.checker[m]
        iu = int(wp.floor(uv[0] * c[0]))
        iv = int(wp.floor(uv[1] * c[1]))
        if (iu + iv) % 2 != 0:
            a = sd.materials.albedo2[m]
    return a


@wp.func
def emitted(sd: SceneData, h: Hit, wo: wp.vec3) -> wp.vec3:
    # Emitters radiate on the side their normal faces (spheres outward, quads edge_u x edge_v).
    if wp.dot(h.n, wo) > 0.0:
        return sd.materials.emission[h.material]
    return wp.vec3(0.0)
