"""The material at a hit as the integrators read it, per variant. `material_at(sd, m, uv)` is
material_at.py's, and in a variant with an anisotropic kind (Features.anisotropic) also the
roughness across the tangent (`shape_v`, Mitsuba's alpha_v) and a material's "alpha_u" and "alpha_v"
texture slots (float textures, texture.texture_float: Mitsuba's eval_1), read once per hit.
`material_at_hit(sd, h)` adds what only the hit knows: the surface's tangent dp/du
(kernels/intersection/tangent.py), which orients an anisotropic lobe (without it the lobe takes an
arbitrary tangent). Other variants compile none of it: material_at_hit is material_at at the hit.
"""
import warp as wp

from drtlab.kernels.device_scene import SceneData
from drtlab.kernels.intersection.primitives import Hit
from drtlab.kernels.intersection.tangent import hit_tangent
from drtlab.kernels.materials.material_at import MaterialAt, material_at_for
from drtlab.kernels.materials.texture import SLOT, material_texture, texture_float


def make_material_at(textures: bool, anisotropic: bool) -> tuple:
    """(material_at(sd, m, uv), material_at_hit(sd, h)) of a variant (module doc)."""
    base = material_at_for(textures)
    TEXTURES, ANISOTROPIC = textures, anisotropic

    @wp.func
    def material_at_anisotropic(sd: SceneData, m: int, uv: wp.vec2) -> MaterialAt:
        r = base(sd, m, uv)
        r.shape_v = sd.materials.shape_v[m]
        if wp.static(TEXTURES):
            tu = material_texture(sd, m, wp.static(SLOT["alpha_u"]))
            if tu >= 0:
                r.shape = texture_float(sd, tu, uv)
            tv = material_texture(sd, m, wp.static(SLOT["alpha_v"]))
            if tv >= 0:
                r.shape_v = texture_float(sd, tv, uv)
        return r

    material_at = material_at_anisotropic if anisotropic else base

    @wp.func
    def material_at_hit(sd: SceneData, h: Hit) -> MaterialAt:
        r = material_at(sd, h.material, h.uv)
        if wp.static(ANISOTROPIC):
            r.tangent = hit_tangent(sd, h)
        return r

    return material_at, material_at_hit
