"""Integrators as estimators: what is being estimated, and whether the estimate is unbiased.

    whitted  regular sub-pixel grid, pinhole at the lens centre, shutter-open time, perfect mirror and
             Fresnel-split refraction only, shadow rays to light centres. Deterministic and biased:
             the baseline distribution ray tracing improves on.
    drt      Cook 1984: each sample chains pixel, lens, time, light area and one distributed
             reflection/refraction ray per bounce. Paths continue through glossy, specular and
             transmissive surfaces; at a diffuse surface direct light is gathered and the path ends
             (no diffuse interreflection). Plastic (diffuse base, glossy coat) counts as glossy: the
             path continues through both its lobes. Unbiased for that estimand.
    path     Kajiya 1986 path tracing with next-event estimation: unbiased for the full rendering
             equation (up to max_depth, Mitsuba 3's convention), optional Russian roulette.
"""
from dataclasses import dataclass


@dataclass(frozen=True)
class Integrator:
    name: str
    description: str
    biased: bool


INTEGRATORS = {i.name: i for i in (
    Integrator("whitted", "regular grid, perfect specular only, shadow rays to light centres", True),
    Integrator("drt", "Cook 1984 distribution ray tracing: direct light + distributed glossy/specular "
               "rays, no diffuse interreflection", False),
    Integrator("path", "Kajiya 1986 path tracing with next-event estimation, unbiased", False),
)}
