"""The material at a hit as the built-in integrators read it: `material_at` (material_at.py) at the
hit's material and uv, plus what only the hit knows. In a variant with an anisotropic kind
(Features.anisotropic) that is the surface's tangent dp/du (kernels/intersection/tangent.py), which
orients the lobe, and the roughness across it (`shape_v`, Mitsuba's alpha_v); a material's
"alpha_u" and "alpha_v" texture slots (float textures, texture.texture_float: Mitsuba's eval_1) are
read here once per hit. Other variants compile none of it: material_at_hit is material_at.
"""
import warp as wp

from drtlab.kernels.device_scene import SceneData
from drtlab.kernels.intersection.primitives import Hit
from drtlab.kernels.intersection.tangent import hit_tangent
from drtlab.kernels.materials.material_at import MaterialAt, material_at_for
from drtlab.kernels.materials.texture import SLOT, material_texture, texture_float


def make_material_at_hit(textures: bool, anisotropic: bool):
    """material_at_hit(sd, h) -> MaterialAt of a variant (module doc)."""
    material_at = material_at_for(textures)
    TEXTURES, ANISOTROPIC = textures, anisotropic

    @wp.func
    def material_at_hit(sd: SceneData, h: Hit) -> MaterialAt:
        r = material_at(sd, h.material, h.uv)
        if wp.static(ANISOTROPIC):
            m = h.material
            r.shape_v = sd.materials.shape_v[m]
            r.tangent = hit_tangent(sd, h)
            if wp.static(TEXTURES):
                tu = material_texture(sd, m, wp.static(SLOT["alpha_u"]))
                if tu >= 0:
                    r.shape = texture_float(sd, tu, h.uv)
                tv = material_texture(sd, m, wp.static(SLOT["alpha_v"]))
                if tv >= 0:
                    r.shape_v = texture_float(sd, tv, h.uv)
        return r

    return material_at_hit
