"""Mitsuba 3 XML BSDFs (and a shape's area emitter) -> drtlab materials.

A mixin of the importer (kernels/scene_model/mitsuba_import.py), which gives it the property access (`get`,
`number`, `colour`, `string`, `done`, ...). One drtlab material per distinct (BSDF, emitter) pair.
"""
from __future__ import annotations

from drtlab.kernels.scene_model.material_kinds import ROUGHNESS_MIN
from drtlab.kernels.scene_model.mitsuba_conductor_ior import CONDUCTOR_IOR
from drtlab.kernels.scene_model.mitsuba_principled import PRINCIPLED_BSDFS, PrincipledMapping
from drtlab.kernels.scene_model.mitsuba_textures import TEXTURES, TextureMapping
from drtlab.kernels.scene_model.mitsuba_xml import IOR_PRESETS, Obj, Ref
from drtlab.kernels.scene_model.texture import slot_key

FRAME_MAPS = ("normalmap", "bumpmap")
# Mitsuba's roughconductor with alpha_u != alpha_v, by its distribution
ANISOTROPIC_METALS = {"beckmann": "beckmann_conductor_anisotropic", "ggx": "ggx_anisotropic"}
BSDFS = ("diffuse", "twosided", "dielectric", "roughdielectric", "conductor", "roughconductor", "plastic",
         "roughplastic", "mask", "blendbsdf", "normalmap", "bumpmap") + PRINCIPLED_BSDFS
# Mitsuba's BSDFs that are black from behind unless wrapped in `twosided`
ONE_SIDED = ("diffuse", "conductor", "roughconductor", "plastic", "roughplastic")


class MaterialMapping(TextureMapping, PrincipledMapping):
    def material(self, shape: Obj, bsdf: Obj | None, emitter: Obj | None) -> str:
        """The drtlab material of a (BSDF, area emitter) pair: one per distinct pair, named after the
        BSDF's id (or the shape's path)."""
        radiance = texture = None
        if emitter is not None:
            # A bitmap or checkerboard radiance: the emission texture, times an emission of 1.
            texture = self.texture_of(emitter, "radiance")
            radiance = [1.0] * 3 if texture is not None else self.colour(emitter, "radiance", 1.0, emitter=True)
            texture = self.albedo_texture(texture) if texture is not None else None
            if not any(x > 0 for x in radiance):
                # An emitter of nothing is a mistake in drtlab's files too (materials.*.emission).
                where = emitter.props["radiance"].path if "radiance" in emitter.props else emitter.path
                self.r.fail(where, f"an area emitter needs radiance >= 0 with at least one channel "
                                   f"> 0, got {radiance}; remove the emitter for a shape that does "
                                   "not emit")
            self.done(emitter)
        if bsdf is None:                 # Mitsuba's default: diffuse 0.5, black on an emitter
            spec = {"kind": "diffuse", "albedo": [0.0 if emitter is not None else 0.5] * 3, "one_sided": True}
            name = "default"
        else:
            spec, name = self.bsdf(bsdf), bsdf.id or shape.path.rsplit("/", 1)[-1].split("(")[0]
            self.check_textured_shape(shape, spec)
        if radiance is not None and any(radiance):
            if spec["kind"] == "diffuse" and not any(spec["albedo"]):
                spec = {"kind": "emitter"}       # black: it only emits
            spec["emission"] = radiance
            if texture is not None:
                spec["emission_texture"] = texture
                self.check_textured_shape(shape, spec)
        key = repr(sorted(spec.items()))
        if key not in self.material_of:
            unique, k = name, 1
            while unique in self.materials:
                k += 1
                unique = f"{name}-{k}"
            self.material_of[key] = unique
            self.materials[unique] = spec
        return self.material_of[key]

    def bsdf(self, o: Obj, two_sided: bool = False, masked: bool = False) -> dict:
        kind = self.kind(o, BSDFS)
        if kind in FRAME_MAPS:
            return self.frame_map(o)
        if kind == "twosided":
            nested = self.nested(o)
            if len(nested) != 1:
                self.r.fail(o.path, "twosided with one nested bsdf only (drtlab's surfaces are the "
                                    "same on both sides)")
            if nested[0].type not in ONE_SIDED:
                self.r.fail(nested[0].path, f"twosided around '{nested[0].type}' is not supported "
                                            f"({', '.join(ONE_SIDED)})")
            self.done(o)
            return self.bsdf(nested[0], two_sided=True, masked=masked)
        if kind == "mask":
            return self.mask(o, masked)
        if kind == "blendbsdf":
            return self.blend(o)
        named = {p.path for p in o.props.values()}       # read through `colour` where a value is meant
        for child in o.children:
            if child.path in named:
                continue
            child = self.deref(child)
            what = "textures are" if child.tag == "texture" else f"a nested <{child.tag}> is"
            self.r.fail(child.path, f"{what} not supported in a {kind} bsdf (drtlab's colours are "
                                    "constant)")
        if kind == "diffuse":
            texture = self.texture_of(o, "reflectance")
            spec = ({"kind": "diffuse", "albedo": [0.5] * 3, "albedo_texture": self.albedo_texture(texture)}
                    if texture is not None else
                    {"kind": "diffuse", "albedo": self.colour(o, "reflectance", 0.5)})
        elif kind in ("conductor", "roughconductor"):
            spec = {"kind": "mirror", "albedo": self.colour(o, "specular_reflectance", 1.0)}
            anisotropic = self.anisotropy(o) if kind == "roughconductor" else None
            if anisotropic is not None:
                spec.update(anisotropic)
            elif kind == "roughconductor":
                spec.update(zip(("kind", "roughness"), self.roughness(o)))
            eta, k = self.complex_ior(o)
            if anisotropic is not None:
                spec.update(eta=eta, k=k)
            elif (eta, k) != ([0.0] * 3, [1.0] * 3):    # else Mitsuba's "none": F = 1, the kinds above
                metal = {"mirror": "conductor", "beckmann": "beckmann_conductor", "ggx_separable": "ggx_conductor"}
                spec.update(kind=metal[spec["kind"]], eta=eta, k=k)
        elif kind in ("plastic", "roughplastic"):
            spec = self.plastic(o)
        elif kind in PRINCIPLED_BSDFS:
            spec = self.principled(o)
        else:
            ior = [self.ior(o, name, default) for name, default in (("int_ior", "bk7"), ("ext_ior", "air"))]
            self.white_coat(o, "dielectric")
            spec = {"kind": "dielectric", "ior": ior[0] / ior[1],
                    "albedo": self.colour(o, "specular_transmittance", 1.0)}
            if kind == "roughdielectric":
                rough, alpha = self.roughness(o)
                glass = {"beckmann": "beckmann_dielectric", "ggx_separable": "ggx_dielectric_separable"}
                spec.update(kind=glass[rough], roughness=alpha)
        if kind in ONE_SIDED and not two_sided:
            spec["one_sided"] = True
        self.done(o)
        return spec

    def mask(self, o: Obj, masked: bool) -> dict:
        """Mitsuba's `mask` (src/bsdfs/mask.cpp): its one nested BSDF with the material's
        `opacity` (a float in [0, 1], default 0.5) or `opacity_texture` (a bitmap or checkerboard,
        read as its luminance)."""
        if masked:
            self.r.fail(o.path, "a mask inside a mask is not supported")
        texture = self.texture_of(o, "opacity")
        bsdfs = [c for c in self.nested(o) if c.tag == "bsdf"]
        if len(bsdfs) != 1:
            self.r.fail(o.path, f"a mask needs exactly one nested bsdf, got {len(bsdfs)}")
        spec = self.bsdf(bsdfs[0], masked=True)
        if texture is not None:
            spec["opacity_texture"] = self.albedo_texture(texture)
        else:
            spec["opacity"] = float(self.number(o, "opacity", 0.5, lambda x: 0.0 <= x <= 1.0, "in [0, 1]"))
        self.done(o)
        return spec

    def blend(self, o: Obj) -> dict:
        """Mitsuba's blendbsdf, (1 - w) bsdf_0 + w bsdf_1 with w = clip(weight, 0, 1), of two diffuse
        BSDFs of constant reflectance: linear in the reflectance, so a diffuse of the blended one (a
        constant weight folded in here, a texture's as weight_texture and blend_albedo)."""
        children = [c for c in self.nested(o) if c.tag == "bsdf"]
        if len(children) != 2:
            self.r.fail(o.path, f"a blendbsdf needs two nested bsdfs, got {len(children)}")
        specs = [self.bsdf(c) for c in children]
        sides = {bool(s.get("one_sided")) for s in specs}
        if (any(set(s) - {"one_sided"} != {"kind", "albedo"} or s["kind"] != "diffuse" for s in specs)
                or len(sides) > 1):
            self.r.fail(o.path, f"a blendbsdf of {children[0].type} and {children[1].type} is not "
                                "supported (drtlab blends two diffuse bsdfs of constant reflectance, "
                                "both one-sided or both two-sided)")
        r0, r1 = specs[0]["albedo"], specs[1]["albedo"]
        texture = self.texture_of(o, "weight")
        if texture is not None:
            spec = {"kind": "diffuse", "albedo": r0, "weight_texture": self.albedo_texture(texture),
                    "blend_albedo": r1}
        else:
            w = self.number(o, "weight", None)
            if w is None:
                self.r.fail(o.path, "a blendbsdf needs a weight (a float or a texture)")
            w = min(max(float(w), 0.0), 1.0)
            spec = {"kind": "diffuse", "albedo": [(1.0 - w) * a + w * b for a, b in zip(r0, r1)]}
        if sides == {True}:
            spec["one_sided"] = True
        self.done(o)
        return spec

    def white_coat(self, o: Obj, what: str) -> None:
        if self.colour(o, "specular_reflectance", 1.0) != [1.0] * 3:
            self.r.fail(o.props["specular_reflectance"].path, f"must be 1 (drtlab's {what} reflects "
                                                              "white)")

    def plastic(self, o: Obj) -> dict:
        """Mitsuba's `plastic`: `smooth_plastic` (or its `nonlinear` twin), eta = int_ior / ext_ior > 1
        (the kind's coat), a white coat; `roughplastic`: `beckmann_plastic` or `ggx_plastic` (and
        their `_nonlinear` twins) of its alpha."""
        eta = self.ior(o, "int_ior", "polypropylene") / self.ior(o, "ext_ior", "air")
        if eta <= 1.0:
            self.r.fail((o.props.get("int_ior") or o).path, f"int_ior / ext_ior must be > 1 (a coat "
                        f"denser than outside), got {eta:g}")
        self.white_coat(o, "plastic coat")
        nonlinear = self.get(o, "nonlinear", ("boolean",), False)
        spec = {"kind": "smooth_plastic", "albedo": self.colour(o, "diffuse_reflectance", 0.5), "ior": eta}
        if o.type == "roughplastic":
            rough, alpha = self.roughness(o)
            spec.update(kind={"beckmann": "beckmann_plastic", "ggx_separable": "ggx_plastic"}[rough],
                        roughness=alpha)
        if nonlinear:
            spec["kind"] += "_nonlinear"
        return spec

    def complex_ior(self, o: Obj) -> tuple[list[float], list[float]]:
        """(eta, k) of a conductor as Mitsuba 3 reads them: `eta`/`k` (defaults 0 and 1: reflects
        all), or a named `material`, whose RGB values its RGB variants use (mitsuba_conductor_ior)."""
        names = ("none",) + tuple(CONDUCTOR_IOR)
        material = self.string(o, "material", "none", names)
        if material != "none":
            for name in ("eta", "k"):
                if name in o.props:
                    self.r.fail(o.props[name].path, f"give either material ({material!r}) or eta and k, "
                                                    "not both (as Mitsuba 3)")
            return [list(v) for v in CONDUCTOR_IOR[material]]
        out = []
        for name, default in (("eta", 0.0), ("k", 1.0)):
            v = self.colour(o, name, default, unbounded=True)
            if min(v) < 0:
                self.r.fail(o.props[name].path, f"must be >= 0 in every channel, got {v}")
            out.append(v)
        return out[0], out[1]

    def roughness(self, o: Obj) -> tuple[str, float]:
        """(drtlab kind, isotropic alpha) of a rough conductor: `beckmann`, `ggx_separable` (Mitsuba's
        separable Smith masking; drtlab's `ggx` masks with the height-correlated form)."""
        kinds = {"beckmann": "beckmann", "ggx": "ggx_separable"}
        distribution = self.string(o, "distribution", "beckmann")
        if distribution not in kinds:
            self.r.fail(o.props["distribution"].path, f"{distribution!r} is not supported (supported: "
                        f"{', '.join(kinds)})")
        self.ignore(o, "sample_visible")            # the proposal only: the same estimate
        alpha = [self.number(o, k, None, lambda x: x > 0, "> 0") for k in ("alpha", "alpha_u", "alpha_v")]
        if alpha[1] is not None or alpha[2] is not None:
            if alpha[0] is not None or alpha[1] != alpha[2]:
                self.r.fail(o.path, "anisotropic roughness is not supported: give alpha, or alpha_u "
                                    "equal to alpha_v")
            return kinds[distribution], alpha[1]
        return kinds[distribution], 0.1 if alpha[0] is None else alpha[0]

    def anisotropy(self, o: Obj) -> dict | None:
        """A roughconductor's anisotropic kind (by its distribution) and alpha_u (along dp/du) and
        alpha_v as numbers or float textures (`alpha_u`, `alpha_u_texture`, ...), or None where it
        is isotropic (no alpha_u / alpha_v, or
        two equal numbers: `roughness` reads it)."""
        if "alpha_u" not in o.props and "alpha_v" not in o.props:
            return None
        if "alpha" in o.props or "alpha_u" not in o.props or "alpha_v" not in o.props:
            self.r.fail(o.path, "give alpha, or both alpha_u and alpha_v (as Mitsuba 3)")
        out = {}
        for name in ("alpha_u", "alpha_v"):
            texture = self.texture_of(o, name)
            if texture is not None:
                out[f"{name}_texture"] = self.albedo_texture(texture)
            else:
                out[name] = self.number(o, name, None, lambda x: ROUGHNESS_MIN <= x <= 1,
                                        f"in [{ROUGHNESS_MIN:g}, 1] (drtlab's microfacet alpha)")
        if out.get("alpha_u", -1) == out.get("alpha_v", -2):
            return None
        out["kind"] = ANISOTROPIC_METALS[self.string(o, "distribution", "beckmann", tuple(ANISOTROPIC_METALS))]
        self.ignore(o, "sample_visible")            # the proposal only: the same estimate
        return out

    def ior(self, o: Obj, name: str, default: str) -> float:
        p = o.props.get(name)
        if p is not None and p.tag == "string" or p is None:
            preset = self.string(o, name, default)
            if preset.lower() not in IOR_PRESETS:
                self.r.fail(p.path, f"unknown index of refraction {preset!r} (a number or one of "
                                    f"{', '.join(IOR_PRESETS)})")
            return IOR_PRESETS[preset.lower()]
        return self.number(o, name, None, lambda x: x > 0, "> 0")


    def frame_map(self, o: Obj) -> dict:
        """Mitsuba's `normalmap` (its `normalmap` texture, raw RGB) or `bumpmap` (its one texture,
        `scale` default 1) around one nested BSDF: the nested material with a normal_texture or a
        bump_texture (kernels/materials/shading_frame.py)."""
        for name in ("flip_invalid_normals", "use_shadowing_function"):     # both default true
            if not self.get(o, name, ("boolean",), True):
                self.r.fail(o.props[name].path, f"false is not supported (drtlab's {o.type} always "
                                                "does what Mitsuba's default does)")
        textures = [p for p in o.props.values() if p.tag == "texture" or (
            p.tag == "ref" and self.deref(Ref(p.value, p.path)).tag == "texture")]
        bsdfs = [c for c in map(self.deref, o.children) if c.tag == "bsdf"]
        if len(bsdfs) != 1:
            self.r.fail(o.path, f"{o.type} needs exactly one nested bsdf, got {len(bsdfs)}")
        if o.type == "normalmap":
            if "normalmap" not in o.props:
                self.r.fail(o.path, "normalmap needs a texture named 'normalmap' (its raw RGB normals)")
            textures = [o.props["normalmap"]]
        elif len(textures) != 1:
            self.r.fail(o.path, f"bumpmap needs exactly one texture (its heights), got {len(textures)}")
        scale = self.number(o, "scale", 1.0) if o.type == "bumpmap" else None
        p = textures[0]
        t = self.deref(Ref(p.value, p.path)) if p.tag == "ref" else p.value
        o.used.update(n for n, q in o.props.items() if q is p)
        if t.type == "rawconstant":
            value = self.get(t, "value", ("vector", "point", "float", "rgb"), None)
            if value is None:
                self.r.fail(t.path, "a rawconstant texture needs a value")
            self.done(t)
            table = {"kind": "constant", "value": [float(v) for v in value] if isinstance(value, list)
                     else float(value)}
        elif t.type in TEXTURES:
            self.ignore(t, "format")            # the stored precision: drtlab reads float32 texels
            table = self.albedo_texture(t)
        else:
            self.r.fail(t.path, f"<texture type='{t.type}'> is not supported in a {o.type} "
                                f"(supported: rawconstant, {', '.join(TEXTURES)})")
        self.nested(o)
        nested = bsdfs[0]
        if nested.type in FRAME_MAPS:
            self.r.fail(nested.path, f"a {nested.type} inside a {o.type} is not supported (one map)")
        spec = self.bsdf(nested)
        if spec["kind"] != "diffuse" and not spec["kind"].startswith(("ggx", "beckmann")):
            self.r.fail(nested.path, f"a {o.type} around '{nested.type}' is not supported (diffuse, "
                                     "roughconductor, roughplastic, roughdielectric)")
        if o.type == "normalmap":
            spec[slot_key("normal")] = table
        else:
            spec[slot_key("bump")] = table
            spec["bump_scale"] = float(scale)
        self.done(o)
        return spec
