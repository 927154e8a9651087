"""Point lights that project (the model: kernels/scene_model/light_projection.py): a spot's texture
(Mitsuba 3's src/emitters/spot.cpp) and the projector (src/emitters/projector.cpp). Compiled only into
variants of scenes that have one (Features.projections).

In the light's frame (x, y, z: its `up`-oriented look_at frame, z the axis) a direction d from the
light has the texture coordinates

    uv = (1/2 + f_u x / z, 1/2 + f_v y / z)

a spot's f_u = f_v = 1 / (2 tan(cutoff)), a projector's f_u = -1 / (2 tan(fov_x / 2)) and
f_v = aspect f_u (its perspective_projection: the image's u runs against x, v against y, and v spans
the image's height at width / height = aspect). A spot's texture multiplies its intensity x falloff.
A projector's intensity towards d (unit, z = cos theta from the axis) is

    I(d) = pi scale E(uv) / cos^3 theta      inside the frustum (uv in [0, 1]^2, z > 0), else 0

Mitsuba's `pi scale E / (z_local^2 cos theta)` with z_local = dist cos theta, over the 1 / dist^2
every point light has: a plane facing the projector at distance h gets the irradiance
I cos / dist^2 = pi scale E / h^2, a white diffuse one there the radiance scale E / h^2.
"""
import numpy as np
import warp as wp

from drtlab.estimators.domain_maps import PI
from drtlab.kernels.device_scene import SceneData
from drtlab.kernels.materials.texture import texture_value
from drtlab.kernels.scene_model.light_projection import light_frame, texture_aspect

NO_PROJECTION = (0.0, 0.0, 0.0, -1.0)


def projection_row(light, tex: int) -> tuple:
    """(right, up, (f_u, f_v, projector 1/0, texture index or -1)) of a PointLight whose texture (if
    any) is texture `tex` of the scene's pool."""
    if not light.projects:
        return np.zeros(3), np.zeros(3), NO_PROJECTION
    frame = light_frame(light.direction, light.up)
    if light.projector:
        f_u = -0.5 / np.tan(np.radians(0.5 * light.fov_x))
        factors = (f_u, f_u * texture_aspect(light), 1.0)
    else:
        f = 0.5 / np.tan(np.radians(light.cutoff_angle))
        factors = (f, f, 0.0)
    return frame[:, 0], frame[:, 1], (*factors, float(tex if light.texture is not None else -1))


@wp.func
def projected(sd: SceneData, i: int, d: wp.vec3) -> wp.vec3:
    """The factor of point light i's intensity towards the unit direction d (from the light)."""
    pr = sd.lights.point_proj[i]
    if pr[2] == 0.0 and pr[3] < 0.0:
        return wp.vec3(1.0)
    z = wp.dot(d, sd.lights.point_axis[i])
    if z <= 0.0:
        return wp.vec3(0.0)
    uv = wp.vec2(0.5 + pr[0] * wp.dot(d, sd.lights.point_right[i]) / z,
                 0.5 + pr[1] * wp.dot(d, sd.lights.point_up[i]) / z)
    value = wp.vec3(1.0)
    if pr[2] > 0.0:
        if uv[0] < 0.0 or uv[0] > 1.0 or uv[1] < 0.0 or uv[1] > 1.0:
            return wp.vec3(0.0)
        value = wp.vec3(PI / (z * z * z))
    if pr[3] >= 0.0:
        value = wp.cw_mul(value, texture_value(sd, int(pr[3]), uv))
    return value
