"""The material at a hit, as the BSDF functions read it (bsdf.py): one record instead of a parameter
per property, so a per-material property a new kind needs is a field here and in MaterialData
(device_scene.py), not an argument threaded through every caller (tracers, direct and environment
lighting, whitted, the chi-square adapter)."""
import functools

import warp as wp

from drtlab.kernels.device_scene import SceneData
from drtlab.kernels.materials.surface import surface_albedo
from drtlab.kernels.materials.texture import SLOT, material_texture, texture_scalar, texture_value
from drtlab.kernels.scene_model.material_kinds import KINDS, MATERIAL_CODE
from drtlab.kernels.scene_model.principled_params import PARAM_COUNT, PARAMS
from drtlab.kernels.static_tag import variant_tag

ParamVector = wp.types.vector(length=PARAM_COUNT, dtype=float)


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
    opacity: float                  # a mask's share of hits that scatter (mask.py) ...
    one_sided: int                  # ... and 1: black from behind; both read in their variants only
    param: ParamVector              # a `params` kind's parameters at the hit (principled_params.py):
                                    # its row, textured ones looked up at uv (material_at_for)


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
    r.opacity = 1.0
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


@wp.func
def material_at_masked(sd: SceneData, m: int, uv: wp.vec2) -> MaterialAt:
    """material_at where the scene has masks or one-sided materials (mask.py)."""
    r = material_at(sd, m, uv)
    r.opacity = sd.materials.opacity[m]
    r.one_sided = sd.materials.one_sided[m]
    return r


@wp.func
def material_at_textured_masked(sd: SceneData, m: int, uv: wp.vec2) -> MaterialAt:
    """... and textures: an opacity texture's luminance at uv, clipped to [0, 1] (Mitsuba's mask)."""
    r = material_at_textured(sd, m, uv)
    r.opacity = sd.materials.opacity[m]
    r.one_sided = sd.materials.one_sided[m]
    t = material_texture(sd, m, wp.static(SLOT["opacity"]))
    if t >= 0:
        r.opacity = wp.clamp(texture_scalar(sd, t, uv), 0.0, 1.0)
    return r


def material_at_for(textures: bool, masks: bool = False, kinds: frozenset = frozenset()):
    """The material_at of a variant: the textured one only where the scene has textures, the one
    reading opacity and sides only where it has masks or one-sided materials, and one that fills
    MaterialAt.param only where a kind with parameters (MaterialKind.params) is present (so that
    other scenes compile none of it)."""
    if masks:
        base = material_at_textured_masked if textures else material_at_masked
    else:
        base = material_at_textured if textures else material_at
    codes = tuple(MATERIAL_CODE[k.name] for k in KINDS if k.params and k.name in kinds)
    if not codes:
        return base
    return _make_parameterised(base, bool(textures), codes)


# (slot column, place in the vector) of every texturable parameter
_TEXTURED = tuple((SLOT[p.name], i) for i, p in enumerate(PARAMS) if p.texturable and p.name in SLOT)


@functools.lru_cache(maxsize=None)
def _make_parameterised(base, textures: bool, codes: tuple):
    CODES = codes
    TEXTURES = textures

    @wp.func
    def material_at_params(sd: SceneData, m: int, uv: wp.vec2) -> MaterialAt:
        r = base(sd, m, uv)
        _variant = wp.static(variant_tag((CODES, _TEXTURED)))  # noqa: F841 (static_tag.py)
        for c in range(wp.static(len(CODES))):
            if r.kind == wp.static(CODES[c]):
                for i in range(wp.static(PARAM_COUNT)):
                    r.param[i] = r.table[r.row + i]
                if wp.static(TEXTURES):
                    for j in range(wp.static(len(_TEXTURED))):
                        t = material_texture(sd, m, wp.static(_TEXTURED[j][0]))
                        if t >= 0:
                            r.param[wp.static(_TEXTURED[j][1])] = texture_scalar(sd, t, uv)
        return r

    return material_at_params
