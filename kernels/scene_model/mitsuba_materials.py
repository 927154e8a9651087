"""Mitsuba 3 XML BSDFs (and a shape's area emitter) -> drtlab materials.

A mixin of the importer (kernels/scene_model/mitsuba_import.py), which gives it the property access (`get`,
`number`, `colour`, `string`, `done`, ...). One drtlab material per distinct (BSDF, emitter) pair.
"""
from __future__ import annotations

from drtlab.kernels.scene_model.material_kinds import ROUGHNESS_MIN
from drtlab.kernels.scene_model.mitsuba_conductor_ior import CONDUCTOR_IOR
from drtlab.kernels.scene_model.mitsuba_textures import TextureMapping
from drtlab.kernels.scene_model.mitsuba_xml import IOR_PRESETS, Obj

ANISOTROPIC_METAL = "beckmann_conductor_anisotropic"
BSDFS = ("diffuse", "twosided", "dielectric", "roughdielectric", "conductor", "roughconductor", "plastic",
         "roughplastic")


class MaterialMapping(TextureMapping):
    def material(self, shape: Obj, bsdf: Obj | None, emitter: Obj | None) -> str:
        """The drtlab material of a (BSDF, area emitter) pair: one per distinct pair, named after the
        BSDF's id (or the shape's path)."""
        radiance = None
        if emitter is not None:
            radiance = self.colour(emitter, "radiance", 1.0, emitter=True)
            if not any(x > 0 for x in radiance):
                # An emitter of nothing is a mistake in drtlab's files too (materials.*.emission).
                where = emitter.props["radiance"].path if "radiance" in emitter.props else emitter.path
                self.r.fail(where, f"an area emitter needs radiance >= 0 with at least one channel "
                                   f"> 0, got {radiance}; remove the emitter for a shape that does "
                                   "not emit")
            self.done(emitter)
        if bsdf is None:                 # Mitsuba's default: diffuse 0.5, black on an emitter
            spec = {"kind": "diffuse", "albedo": [0.0 if emitter is not None else 0.5] * 3}
            name = "default"
        else:
            spec, name = self.bsdf(bsdf), bsdf.id or shape.path.rsplit("/", 1)[-1].split("(")[0]
            self.check_textured_shape(shape, spec)
        if radiance is not None and any(radiance):
            if spec["kind"] == "diffuse" and not any(spec["albedo"]):
                spec = {"kind": "emitter"}       # black: it only emits
            spec["emission"] = radiance
        key = repr(sorted(spec.items()))
        if key not in self.material_of:
            unique, k = name, 1
            while unique in self.materials:
                k += 1
                unique = f"{name}-{k}"
            self.material_of[key] = unique
            self.materials[unique] = spec
        return self.material_of[key]

    def bsdf(self, o: Obj) -> dict:
        kind = self.kind(o, BSDFS)
        if kind == "twosided":
            nested = self.nested(o)
            if len(nested) != 1:
                self.r.fail(o.path, "twosided with one nested bsdf only (drtlab's surfaces are the "
                                    "same on both sides)")
            one_sided = ("diffuse", "conductor", "roughconductor", "plastic", "roughplastic")
            if nested[0].type not in one_sided:
                self.r.fail(nested[0].path, f"twosided around '{nested[0].type}' is not supported "
                                            f"({', '.join(one_sided)})")
            self.done(o)
            return self.bsdf(nested[0])
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
                spec.update(kind=ANISOTROPIC_METAL, **anisotropic)
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
        else:
            ior = [self.ior(o, name, default) for name, default in (("int_ior", "bk7"), ("ext_ior", "air"))]
            self.white_coat(o, "dielectric")
            spec = {"kind": "dielectric", "ior": ior[0] / ior[1],
                    "albedo": self.colour(o, "specular_transmittance", 1.0)}
            if kind == "roughdielectric":
                rough, alpha = self.roughness(o)
                glass = {"beckmann": "beckmann_dielectric", "ggx_separable": "ggx_dielectric_separable"}
                spec.update(kind=glass[rough], roughness=alpha)
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
        """A roughconductor's alpha_u (along dp/du) and alpha_v as numbers or float textures
        (`alpha_u`, `alpha_u_texture`, ...), or None where it is isotropic (no alpha_u / alpha_v, or
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
        if self.string(o, "distribution", "beckmann") != "beckmann":
            self.r.fail(o.props["distribution"].path, "anisotropic roughness is supported with the "
                                                      "beckmann distribution only")
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

