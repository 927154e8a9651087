"""The material at a hit, as the BSDF functions read it (bsdf.py): one record instead of a parameter
per property, so a per-material property a new kind needs is a field here and in MaterialData
(device_scene.py), not an argument threaded through every caller (tracers, direct and environment
lighting, whitted, the chi-square adapter)."""
import functools

import warp as wp

from drtlab.kernels.device_scene import MESH, SceneData
from drtlab.kernels.intersection.primitives import Hit
from drtlab.kernels.intersection.tangent import hit_tangent, tangent_s
from drtlab.kernels.materials.mesh_attribute import MESH_ATTRIBUTE, attribute_value
from drtlab.kernels.materials.surface import surface_albedo
from drtlab.kernels.materials.texture import SLOT, luminance, material_texture, texture_scalar, texture_value
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
    # A normal or bump map's perturbation at the hit (shading_frame.py; mapped 0: none): the
    # perturbed normal and its shadowing term's a2
    mapped: int
    nm: wp.vec3
    nm_alpha2: float
    # Set only in variants with an anisotropic kind (MaterialKind.anisotropic; zero elsewhere):
    shape_v: float                  # the roughness across the tangent (Mitsuba's alpha_v; `shape` is
                                    # alpha_u, along it)
    tangent: wp.vec3                # the hit's dp/du (kernels/intersection/tangent.py), not unit; a
                                    # normal or bump map turns it with the normal (shading_frame.py)


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
                w = luminance(v)
            w = wp.clamp(w, 0.0, 1.0)
            r.albedo = r.albedo * (1.0 - w) + sd.materials.albedo2[m] * w
        return r

    return textured


@wp.func
def untextured(sd: SceneData, m: int, uv: wp.vec2, face: int) -> MaterialAt:
    return material_at(sd, m, uv)


def _make_masked(inner, textures: bool):
    """`inner` where the scene has masks or one-sided materials (mask.py): the material's opacity
    (an opacity texture's eval_1 at uv, clipped to [0, 1], as Mitsuba's mask) and sides."""
    @wp.func
    def masked(sd: SceneData, m: int, uv: wp.vec2, face: int) -> MaterialAt:
        r = inner(sd, m, uv, face)
        r.opacity = sd.materials.opacity[m]
        r.one_sided = sd.materials.one_sided[m]
        if wp.static(textures):
            t = material_texture(sd, m, wp.static(SLOT["opacity"]))
            if t >= 0:
                r.opacity = wp.clamp(texture_scalar(sd, t, uv), 0.0, 1.0)
        return r

    return masked


# (slot column, place in the vector) of every texturable parameter
_TEXTURED = tuple((SLOT[p.name], i) for i, p in enumerate(PARAMS) if p.texturable and p.name in SLOT)


def _make_parameterised(inner, textures: bool, codes: tuple):
    """`inner` where a kind with parameters (MaterialKind.params) is present: MaterialAt.param from
    the material's row, its textured parameters at uv."""
    CODES = codes
    TEXTURES = textures

    @wp.func
    def material_at_params(sd: SceneData, m: int, uv: wp.vec2, face: int) -> MaterialAt:
        r = inner(sd, m, uv, face)
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


def _make_anisotropic(inner, textures: bool):
    """`inner` where an anisotropic kind is present (MaterialKind.anisotropic): alpha_v, and the
    "alpha_u" and "alpha_v" texture slots read as Mitsuba's eval_1 at uv."""
    @wp.func
    def anisotropic(sd: SceneData, m: int, uv: wp.vec2, face: int) -> MaterialAt:
        r = inner(sd, m, uv, face)
        r.shape_v = sd.materials.shape_v[m]
        if wp.static(textures):
            tu = material_texture(sd, m, wp.static(SLOT["alpha_u"]))
            if tu >= 0:
                r.shape = texture_scalar(sd, tu, uv)
            tv = material_texture(sd, m, wp.static(SLOT["alpha_v"]))
            if tv >= 0:
                r.shape_v = texture_scalar(sd, tv, uv)
        return r

    return anisotropic


@wp.func
def plain_at_hit(sd: SceneData, h: Hit) -> MaterialAt:
    return material_at(sd, h.material, h.uv)


@functools.cache
def material_at_for(textures: bool, masks: bool = False, kinds: frozenset = frozenset(),
                    attributes: bool = False) -> tuple:
    """(material_at(sd, m, uv), material_at_hit(sd, h)) of a variant: the textured ones only where
    the scene has textures (mesh attributes only where it has them), reading opacity and sides only
    where it has masks or one-sided materials, filling MaterialAt.param only where a kind with
    parameters is present, and alpha_v and the hit's tangent only where an anisotropic kind is (so
    that other scenes compile none of it). material_at_hit is the material at a hit; material_at,
    which knows no face, reads a mesh attribute as black and leaves the tangent 0."""
    codes = tuple(MATERIAL_CODE[k.name] for k in KINDS if k.params and k.name in kinds)
    aniso = any(k.anisotropic and k.name in kinds for k in KINDS)
    if not (textures or masks or codes or aniso):
        return material_at, plain_at_hit
    at = _make_textured(attributes) if textures else untextured
    if masks:
        at = _make_masked(at, bool(textures))
    if codes:
        at = _make_parameterised(at, bool(textures), codes)
    if aniso:
        at = _make_anisotropic(at, bool(textures))
    ATTRIBUTES, ANISO = attributes, aniso

    @wp.func
    def composed_at(sd: SceneData, m: int, uv: wp.vec2) -> MaterialAt:
        return at(sd, m, uv, -1)

    @wp.func
    def composed_at_hit(sd: SceneData, h: Hit) -> MaterialAt:
        face = int(-1)
        if wp.static(ATTRIBUTES):
            if h.kind == MESH:
                face = h.index
        r = at(sd, h.material, h.uv, face)
        if wp.static(ANISO):
            # s of the shading frame, as a normal map's frame holds it too (an identity map then
            # changes no bit)
            r.tangent = tangent_s(h.ns, hit_tangent(sd, h))
        return r

    return composed_at, composed_at_hit
