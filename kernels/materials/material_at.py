"""The material at a hit, as the BSDF functions read it (bsdf.py): one record instead of a parameter
per property, so a per-material property a new kind needs is a field here and in MaterialData
(device_scene.py), not an argument threaded through every caller (tracers, direct and environment
lighting, whitted, the chi-square adapter)."""
import warp as wp

from drtlab.kernels.device_scene import SceneData
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
    # Set only in variants with an anisotropic kind (MaterialKind.anisotropic; zero elsewhere):
    shape_v: float                  # the roughness across the tangent (Mitsuba's alpha_v; `shape` is
                                    # alpha_u, along it)
    tangent: wp.vec3                # the hit's dp/du (kernels/intersection/tangent.py), not unit


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


@wp.func
def material_at_textured(sd: SceneData, m: int, uv: wp.vec2) -> MaterialAt:
    """material_at where the scene has textures: a textured material's albedo is its texture at uv,
    looked up once here for every BSDF call at the hit."""
    r = material_at(sd, m, uv)
    t = material_texture(sd, m, wp.static(SLOT["albedo"]))
    if t >= 0:
        r.albedo = texture_value(sd, t, uv)
    return r


def material_at_for(textures: bool):
    """The material_at of a variant: the textured one only where the scene has textures (so that
    other scenes compile no texture code)."""
    return material_at_textured if textures else material_at
