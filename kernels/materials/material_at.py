"""The material at a hit, as the BSDF functions read it (bsdf.py): one record instead of a parameter
per property, so a per-material property a new kind needs is a field here and in MaterialData
(device_scene.py), not an argument threaded through every caller (tracers, direct and environment
lighting, whitted, the chi-square adapter)."""
import functools

import warp as wp

from drtlab.kernels.device_scene import MESH, SceneData
from drtlab.kernels.intersection.primitives import Hit
from drtlab.kernels.materials.mesh_attribute import MESH_ATTRIBUTE, attribute_value
from drtlab.kernels.materials.surface import surface_albedo
from drtlab.kernels.materials.texture import SLOT, material_texture, texture_value


@wp.struct
class MaterialAt:
    kind: int                       # its code in the kind table (material_kinds.MATERIAL_CODE)
    albedo: wp.vec3                 # at the hit (a checker texture's colour there)
    shape: float                    # the lobe's one shape parameter (MaterialKind.shape): the
                                    # Phong exponent, the microfacet alpha or the albedo's mean
    ior: float
    eta: wp.vec3                    # a conductor kind's complex index eta + i k (conductor.py)
    k: wp.vec3
    table: wp.array(dtype=float)    # the flat per-material table (MaterialKind.table kinds) ...
    row: int                        # ... and this material's row offset in it


@wp.func
def material_at(sd: SceneData, m: int, uv: wp.vec2) -> MaterialAt:
    """Material m of the scene at surface coordinates uv."""
    r = MaterialAt()
    r.kind = sd.materials.kind[m]
    r.albedo = surface_albedo(sd, m, uv)
    r.shape = sd.materials.shape[m]
    r.ior = sd.materials.ior[m]
    r.eta = sd.materials.eta[m]
    r.k = sd.materials.k[m]
    r.table = sd.materials.table
    r.row = sd.materials.row[m]
    return r


def _make_textured(attributes: bool):
    """(sd, m, uv, face) -> MaterialAt where the scene has textures, each looked up once here for
    every BSDF call at the hit: a textured material's albedo is its "albedo" texture; a "weight"
    texture w blends it with albedo2 (Mitsuba's blendbsdf of two diffuse BSDFs: (1 - w) albedo +
    w albedo2, w clipped to [0, 1]; a scalar texture is its luminance, as Mitsuba's eval_1, and a
    mesh attribute's one channel). Mesh attributes need the hit's face (-1: none known, which
    reads black), compiled in only with `attributes`."""
    @wp.func
    def lookup(sd: SceneData, t: int, uv: wp.vec2, face: int) -> wp.vec3:
        if wp.static(attributes):
            if sd.materials.tex_mode[t][0] == wp.static(MESH_ATTRIBUTE):
                if face < 0:
                    return wp.vec3(0.0)
                return attribute_value(sd, t, face, uv)
        return texture_value(sd, t, uv)

    @wp.func
    def textured(sd: SceneData, m: int, uv: wp.vec2, face: int) -> MaterialAt:
        r = material_at(sd, m, uv)
        t = material_texture(sd, m, wp.static(SLOT["albedo"]))
        if t >= 0:
            r.albedo = lookup(sd, t, uv, face)
        t = material_texture(sd, m, wp.static(SLOT["weight"]))
        if t >= 0:
            v = lookup(sd, t, uv, face)
            w = v[0]
            if sd.materials.tex_mode[t][0] != wp.static(MESH_ATTRIBUTE):
                w = wp.dot(v, wp.vec3(0.212671, 0.715160, 0.072169))     # Mitsuba's luminance
            w = wp.clamp(w, 0.0, 1.0)
            r.albedo = r.albedo * (1.0 - w) + sd.materials.albedo2[m] * w
        return r

    return textured


@functools.cache
def material_at_for(textures: bool, attributes: bool = False) -> tuple:
    """(material_at(sd, m, uv), material_at_hit(sd, h)) of a variant: the textured ones only where
    the scene has textures, reading mesh attributes only where it has them (so that other scenes
    compile none of it). material_at_hit is the material at a hit; material_at, which knows no
    face, reads a mesh attribute as black."""
    if not textures:
        @wp.func
        def plain_at_hit(sd: SceneData, h: Hit) -> MaterialAt:
            return material_at(sd, h.material, h.uv)

        return material_at, plain_at_hit
    textured = _make_textured(attributes)

    @wp.func
    def textured_at(sd: SceneData, m: int, uv: wp.vec2) -> MaterialAt:
        return textured(sd, m, uv, -1)

    @wp.func
    def textured_at_hit(sd: SceneData, h: Hit) -> MaterialAt:
        face = int(-1)
        if wp.static(attributes):
            if h.kind == MESH:
                face = h.index
        return textured(sd, h.material, h.uv, face)

    return textured_at, textured_at_hit
