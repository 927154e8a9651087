"""Mitsuba 3 XML `principled` and `principledthin` BSDFs -> drtlab's `principled` and
`principled_thin` (kernels/scene_model/principled_params.py). A mixin of the importer
(kernels/scene_model/mitsuba_import.py), which gives it the property access (`number`, `colour`,
`texture_of`, `albedo_texture`, ...).

Mitsuba's rules carried over: `base_color` is the albedo, every float parameter may be a texture
(read as its eval_1); principled's index is `eta` or `specular` (eta = 2 / (1 - sqrt(0.08
specular)) - 1), not both, and where spec_trans is given and not 0 an eta of 1 becomes 1.001 and a
specular of 0 becomes 1e-3 (principled.cpp); principledthin's `eta` defaults to 1.5.
"""
from __future__ import annotations

from drtlab.kernels.scene_model.mitsuba_xml import Obj
from drtlab.kernels.scene_model.principled_params import (IOR_DEFAULT, PARAM_BY_NAME, PRINCIPLED,
                                                          PRINCIPLED_THIN, eta_of_specular)

PRINCIPLED_BSDFS = ("principled", "principledthin")


class PrincipledMapping:
    def principled(self, o: Obj) -> dict:
        thin = o.type == "principledthin"
        spec = {"kind": "principled_thin" if thin else "principled"}
        texture = self.texture_of(o, "base_color")
        if texture is not None:
            spec.update(albedo=[0.5] * 3, albedo_texture=self.albedo_texture(texture))
        else:
            spec["albedo"] = self.colour(o, "base_color", 0.5)
        for name in PRINCIPLED_THIN if thin else PRINCIPLED:
            p = PARAM_BY_NAME[name]
            texture = self.texture_of(o, name) if p.texturable else None
            if texture is not None:
                spec[f"{name}_texture"] = self.albedo_texture(texture)
                continue
            v = self.number(o, name, None, lambda x, p=p: p.lo <= x <= p.hi, f"in [{p.lo:g}, {p.hi:g}]")
            if v is not None:
                spec[name] = float(v)
        spec["ior"] = self.thin_eta(o) if thin else self.principled_eta(o)
        return spec

    def thin_eta(self, o: Obj) -> float:
        return float(self.number(o, "eta", IOR_DEFAULT, lambda x: x > 0, "> 0"))

    def principled_eta(self, o: Obj) -> float:
        # Mitsuba's get_flag: given, and not a float 0 (a texture counts as given).
        p = o.props.get("spec_trans")
        transmits = p is not None and (p.tag != "float" or float(self.get(o, "spec_trans", ("float",))) != 0.0)
        if "eta" in o.props and "specular" in o.props:
            self.r.fail(o.props["specular"].path, "give either eta or specular, not both (as Mitsuba 3)")
        if "eta" in o.props:
            eta = float(self.number(o, "eta", None, lambda x: x > 0, "> 0"))
            return 1.001 if transmits and eta == 1.0 else eta
        # eta is finite for 0.08 specular < 1
        specular = float(self.number(o, "specular", 0.5, lambda x: 0 <= x < 12.5, "in [0, 12.5)"))
        if specular == 0.0:
            # specular 0 is eta 1: Mitsuba's 1e-3 where light crosses, else a boundary that reflects nothing
            specular = 1e-3 if transmits else 0.0
        eta = eta_of_specular(specular)
        # drtlab's principled has no matched boundary (ior 1): 1.001 reflects at most 2.5e-7 more
        return eta if eta != 1.0 else 1.001
