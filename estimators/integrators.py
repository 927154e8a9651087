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
    direct   Mitsuba 3's `direct`: the emitters the camera sees and the direct light at its hit, by
             MIS of `emitter_samples` light samples and `bsdf_samples` BSDF samples ([scene] keys).
             Unbiased for that estimand (path tracing's with max_depth = 2, the background and the
             environment seen through BSDF samples).

Each is one module of kernels/integrators/ (`module`); a plugin's (drtlab.register_integrator) carries
its `make(api)` and DIMENSIONS instead, and the fingerprint of its source. `handles` names the light
transport effects (EFFECTS) it estimates without bias, the cases `drtlab check INTEGRATOR` tests
against the built-in `path`.
"""
from dataclasses import dataclass

# The effects an integrator may claim to handle (each a scene that isolates it in `drtlab check`).
EFFECTS = ("direct", "indirect", "specular", "glossy", "transmission", "environment",
           "point_lights", "lens", "motion", "meshes")


@dataclass(frozen=True)
class Integrator:
    name: str
    description: str
    biased: bool
    handles: tuple = ()
    module: str | None = None     # a built-in's module (kernels/integrators/NAME.py)
    make: object = None           # a plugin's factory: make(api) -> trace
    dimensions: tuple = ()        # a plugin's own sample decisions ((name, size), ...)
    fingerprint: str = ""         # a plugin's source hash: part of kernel and run keys

    @property
    def unbiased(self) -> bool:
        return not self.biased


def _built_in(name: str, description: str, biased: bool, handles: tuple) -> Integrator:
    return Integrator(name, description, biased, handles, module=f"drtlab.kernels.integrators.{name}")


INTEGRATORS = {i.name: i for i in (
    _built_in("whitted", "regular grid, perfect specular only, shadow rays to light centres", True,
              ("specular", "point_lights")),
    _built_in("drt", "Cook 1984 distribution ray tracing: direct light + distributed glossy/specular "
              "rays, no diffuse interreflection", False,
              ("direct", "specular", "glossy", "transmission", "environment", "point_lights", "lens",
               "motion", "meshes")),
    _built_in("path", "Kajiya 1986 path tracing with next-event estimation, unbiased", False, EFFECTS),
    _built_in("direct", "Mitsuba 3's direct illumination: emitter_samples light and bsdf_samples BSDF "
              "samples at the first hit, MIS", False,
              ("direct", "specular", "glossy", "point_lights", "lens", "motion", "meshes")),
)}
BUILT_IN_INTEGRATORS = tuple(INTEGRATORS)


def integrator_fingerprint(name: str | None) -> str:
    """A plugin integrator's fingerprint ("" for a built-in, an unknown name or None)."""
    entry = INTEGRATORS.get(name) if name else None
    return entry.fingerprint if entry is not None else ""
