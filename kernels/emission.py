"""Textured area lights: Mitsuba 3's area emitter with a `radiance` texture (src/emitters/area.cpp),
whose radiance at a surface point is the texture at the point's uv. In drtlab a material's emission
times its `emission` texture slot (kernels/scene_model/texture.py), compiled only into variants of
scenes that have one (Features.emission_textures).

Two places read it: a hit on the emitter (`emitted_for`: the hit's uv, which the intersection
computes for textured materials) and a light sample's point (`make_sample_emission`: its uv
recomputed from the point as the intersection would have it: a quad's edge parameters, a mesh face's
interpolated texture coordinates, a sphere's Mitsuba uv in its own frame). Light sampling stays uniform
by area or solid angle (Mitsuba samples the texture: another unbiased estimator of the same image).
"""
import warp as wp

from drtlab.kernels.device_scene import MESH, QUAD, SPHERE, SceneData
from drtlab.kernels.intersection.primitives import Hit, quad_params_w, sphere_uv
from drtlab.kernels.materials.surface import emitted
from drtlab.kernels.materials.texture import SLOT, material_texture, texture_value

EMISSION = SLOT["emission"]


@wp.func
def emission_texture(sd: SceneData, m: int) -> int:
    return material_texture(sd, m, wp.static(EMISSION))


@wp.func
def emitted_textured(sd: SceneData, h: Hit, wo: wp.vec3) -> wp.vec3:
    """`emitted` (materials/surface.py) times the emission texture at the hit's uv."""
    e = emitted(sd, h, wo)
    t = emission_texture(sd, h.material)
    if t >= 0:
        e = wp.cw_mul(e, texture_value(sd, t, h.uv))
    return e


def emitted_for(f):
    """The `emitted(sd, h, wo)` of a variant: the textured one only where the scene has emission
    textures."""
    return emitted_textured if f.emission_textures else emitted


@wp.func
def barycentric(a: wp.vec3, b: wp.vec3, c: wp.vec3, y: wp.vec3) -> wp.vec2:
    """(b1, b2) with y = a + b1 (b - a) + b2 (c - a), y in the triangle's plane."""
    e1 = b - a
    e2 = c - a
    r = y - a
    d11 = wp.dot(e1, e1)
    d12 = wp.dot(e1, e2)
    d22 = wp.dot(e2, e2)
    r1 = wp.dot(r, e1)
    r2 = wp.dot(r, e2)
    det = d11 * d22 - d12 * d12
    return wp.vec2((d22 * r1 - d12 * r2) / det, (d11 * r2 - d12 * r1) / det)


def make_sample_emission(motion):
    """sample_emission(sd, kind, s, prim, y, dt, radiance) -> the radiance of a light sample at point
    y of shape s (of `kind`; on face `prim` of a mesh) times its emission texture there."""
    quad_origin, mesh_shift, sphere_center = motion.quad_origin, motion.mesh_shift, motion.sphere_center

    @wp.func
    def sample_emission(sd: SceneData, kind: int, s: int, prim: int, y: wp.vec3, dt: float,
                        radiance: wp.vec3) -> wp.vec3:
        m = int(0)
        if kind == QUAD:
            m = sd.quads.material[s]
        elif kind == MESH:
            m = sd.meshes.material[s]
        else:
            m = sd.spheres.material[s]
        t = emission_texture(sd, m)
        if t < 0:
            return radiance
        uv = wp.vec2(0.0)
        if kind == QUAD:
            q = sd.quads.geom[s]
            uv = quad_params_w(y - quad_origin(sd, s, dt), q.edge_u, q.edge_v, q.basis)
        elif kind == MESH:
            idx = sd.meshes.tri_index[prim]
            shift = mesh_shift(sd, s, dt)
            b = barycentric(sd.meshes.points[idx[0]] + shift, sd.meshes.points[idx[1]] + shift,
                            sd.meshes.points[idx[2]] + shift, y)
            uv = (sd.meshes.vert_uv[idx[0]] * (1.0 - b[0] - b[1]) + sd.meshes.vert_uv[idx[1]] * b[0]
                  + sd.meshes.vert_uv[idx[2]] * b[1])
        elif kind == SPHERE:
            n = wp.normalize(y - sphere_center(sd, s, dt))
            uv = sphere_uv(sd.spheres.to_local[s] * n)       # as a hit on it reads it
        return wp.cw_mul(radiance, texture_value(sd, t, uv))

    return sample_emission
