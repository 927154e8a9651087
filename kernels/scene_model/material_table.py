"""A scene file's [materials.*] tables, one validator: each table -> a `Material`
(kernels/scene_model/scene.py) of its kind (material_kinds.py), its textures by slot (texture.py),
a `params` kind's parameters (principled_params.py), masks, sides, normal and bump maps and an
anisotropic kind's alphas (SCENE_FORMAT.md). Every check raises one `InputError` naming the
offending value's dotted path.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from drtlab import fields
from drtlab.errors import InputError
from drtlab.fields import Table, boolean, scene_albedo, scene_colour, scene_number as number, show, string
from drtlab.kernels.scene_model.material_kinds import KIND_BY_NAME, MATERIAL_KINDS, ROUGHNESS_MIN
from drtlab.kernels.scene_model.principled_params import IOR_DEFAULT, PARAM_BY_NAME
from drtlab.kernels.scene_model.scene import Material
from drtlab.kernels.scene_model.texture import ATTRIBUTE_SLOTS, LUMINANCE, TEXTURE_SLOTS, parse_texture, slot_key


def parse_materials(value: Any) -> list[Material]:
    if not isinstance(value, dict):
        raise InputError("materials", f"must be a table of named material tables, got {show(value)}")
    for name in value:
        if not isinstance(name, str) or not name:
            raise InputError(f"materials.{name}", f"material names must be non-empty strings, got {show(name)}")
    return [_parse_material(name, body) for name, body in value.items()]


def _parse_material(name: str, value: Any) -> Material:
    path = f"materials.{name}"
    t = Table(value, path, f"material '{name}'")
    kind = string(t.get("kind", "diffuse", ""), t.field("kind"), MATERIAL_KINDS)
    spec = KIND_BY_NAME[kind]
    t.check_keys(spec.keys)
    m = Material(name=name, kind=kind)
    # An emission texture multiplies the emission (default then 1: the texture is the radiance).
    m.emission = scene_colour(t.get("emission", [1, 1, 1] if t.has("emission_texture") else [0, 0, 0], ""),
                        t.field("emission"))
    if t.has("emission_texture"):
        m.textures["emission"] = parse_texture(t.data["emission_texture"], t.field("emission_texture"))
    if spec.emitter:
        m.albedo = np.zeros(3)          # an emitter is black apart from what it emits
        if not m.emissive:
            raise InputError(t.field("emission"), "an emitter needs emission >= 0 with at least one "
                                                  f"channel > 0, got {show(m.emission.tolist())}")
        return m
    m.albedo = scene_albedo(t.get("albedo", [0.5, 0.5, 0.5], ""), t.field("albedo"))
    if spec.phong:
        m.exponent = fields.number(t.get("exponent", 100.0, ""), t.field("exponent"),
                            f">= 0 and at most {fields.PHONG_EXPONENT_MAX:.0f} (2^24: a narrower lobe "
                            "is below what float32 cosines resolve)",
                            lambda x: 0.0 <= x <= fields.PHONG_EXPONENT_MAX)
    if spec.microfacet:
        m.roughness = number(t.get("roughness", 0.1, ""), t.field("roughness"),
                             f"in [{ROUGHNESS_MIN:g}, 1] (the microfacet alpha)",
                             lambda x: ROUGHNESS_MIN <= x <= 1.0)
    if spec.anisotropic:
        for key in ("alpha_u", "alpha_v"):
            setattr(m, key, number(t.get(key, 0.1, ""), t.field(key),
                                   f"in [{ROUGHNESS_MIN:g}, 1] (the microfacet alpha along the tangent "
                                   "dp/du (alpha_u) or across it (alpha_v))",
                                   lambda x: ROUGHNESS_MIN <= x <= 1.0))
    if spec.transmits:
        m.ior = number(t.get("ior", 1.5, ""), t.field("ior"), "> 0", lambda x: x > 0.0)
    if spec.coat:       # a coat of index 1 reflects nothing; below 1 it is no coat at all
        m.ior = number(t.get("ior", 1.5, ""), t.field("ior"), "> 1 (the coat's index of refraction)",
                       lambda x: x > 1.0)
    if spec.params:
        m.ior, m.params = _params(t, spec)
    if spec.conductor:
        m.eta = scene_colour(t.get("eta", [0, 0, 0], ""), t.field("eta"))
        m.k = scene_colour(t.get("k", [1, 1, 1], ""), t.field("k"))
        norm = m.eta ** 2 + m.k ** 2
        if not np.all(norm <= fields.CONDUCTOR_NORM_MAX):
            raise InputError(t.field("k"), f"eta^2 + k^2 must be at most {fields.CONDUCTOR_NORM_MAX:.3g} "
                                           "in every channel (the Fresnel squares it in float32), got "
                                           f"{float(norm.max()):.3g}")
    if t.has("opacity") and t.has("opacity_texture"):
        raise InputError(t.field("opacity"), "give opacity or opacity_texture, not both")
    m.opacity = number(t.get("opacity", 1.0, ""), t.field("opacity"),
                       "in [0, 1] (the share of hits the surface scatters; the rest pass through)",
                       lambda x: 0.0 <= x <= 1.0)
    if t.has("one_sided"):
        m.one_sided = boolean(t.data["one_sided"], t.field("one_sided"))
    if t.has("albedo2"):
        m.albedo2 = scene_albedo(t.data["albedo2"], t.field("albedo2"))
        m.checker = _checker(t.get("checker", [8, 8], ""), t.field("checker"))
    elif t.has("checker"):
        raise InputError(t.field("checker"), "needs albedo2 (the second checker colour, each channel "
                                             "in [0, 1])")
    for slot in TEXTURE_SLOTS:
        key = slot_key(slot)
        if not t.has(key) or slot in m.textures:
            continue
        if slot == "albedo" and m.checker is not None:
            raise InputError(t.field(key), "a material has a checker (albedo2) or a texture, not both")
        m.textures[slot] = parse_texture(t.data[key], t.field(key))
        if m.textures[slot].kind == "mesh_attribute" and slot not in ATTRIBUTE_SLOTS:
            raise InputError(t.field(key), f"a mesh_attribute texture fills {', '.join(ATTRIBUTE_SLOTS)} only")
        if slot in ("alpha_u", "alpha_v"):
            _check_alpha_texture(m.textures[slot], t.field(key))
    if t.has("weight_texture") != t.has("blend_albedo") or (t.has("weight_texture") and m.checker):
        raise InputError(t.field("weight_texture"), "a blend needs weight_texture and blend_albedo (the "
                                                    "albedo at weight 1), and no checker")
    if len({x.kind == "mesh_attribute" for x in m.textures.values()}) > 1:
        raise InputError(t.field(slot_key(next(iter(m.textures)))), "a material's textures read either "
                         "the surface's uv or its mesh's attributes (mesh_attribute), not both")
    if t.has("blend_albedo"):       # the device's second albedo (MaterialData.albedo2)
        m.albedo2 = scene_albedo(t.data["blend_albedo"], t.field("blend_albedo"))
    _parse_frame_map(t, m)
    return m


def _params(t: Table, spec) -> tuple[float, dict[str, float]]:
    """(ior, parameters) of a `params` kind (principled_params.py): Mitsuba's defaults, its ranges."""
    matched = "" if spec.name == "principled_thin" else " and not 1 (a matched boundary has no half vector)"
    ior = number(t.get("ior", IOR_DEFAULT, ""), t.field("ior"), "> 0" + matched,
                 lambda x: x > 0.0 and (x != 1.0 or not matched))
    out = {}
    for name in spec.params:
        p = PARAM_BY_NAME[name]
        out[name] = number(t.get(name, p.default, ""), t.field(name), f"in [{p.lo:g}, {p.hi:g}]",
                           lambda x, p=p: p.lo <= x <= p.hi)
    return ior, out


def _parse_frame_map(t: Table, m: Material) -> None:
    """A normal or bump map (kernels/materials/shading_frame.py): one of the two, and a finite
    bump_scale only with a bump map."""
    if "normal" in m.textures and "bump" in m.textures:
        raise InputError(t.field("bump_texture"), "a material has a normal_texture or a bump_texture, "
                                                  "not both")
    if t.has("bump_scale"):
        if "bump" not in m.textures:
            raise InputError(t.field("bump_scale"), "needs a bump_texture (it scales the bump map's heights)")
        m.bump_scale = number(t.data["bump_scale"], t.field("bump_scale"))


def _check_alpha_texture(tex, field: str) -> None:
    """A roughness texture is read as one number (Mitsuba's eval_1: a checkerboard's colour, a
    bitmap's luminance), which must be an alpha the kind takes."""
    px = np.asarray(tex.pixels, dtype=np.float64)
    if tex.kind == "checkerboard" and np.any(px != px[..., :1]):
        raise InputError(field, f"a roughness checkerboard's colours must be numbers (grey), got "
                                f"{show(px.reshape(-1, 3).tolist())}")
    lum = px @ np.array(LUMINANCE)
    if not (ROUGHNESS_MIN <= lum.min() and lum.max() <= 1.0):
        raise InputError(field, f"must read as alphas in [{ROUGHNESS_MIN:g}, 1] (the microfacet "
                                f"alpha), got values from {lum.min():g} to {lum.max():g}")


def _checker(v: Any, field: str) -> tuple[int, int]:
    if (not isinstance(v, (list, tuple)) or len(v) != 2
            or not all(isinstance(x, int) and not isinstance(x, bool) and x >= 1 for x in v)):
        raise InputError(field, f"must be a list of 2 integers >= 1 (checks along u and v), got {show(v)}")
    return int(v[0]), int(v[1])
