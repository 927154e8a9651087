"""Area-light sampling, built per kernel variant: one module per light kind behind one interface
(light_sample.py: `sphere_light.py`, `quad_light.py`, `mesh_light.py`), composed here in one loop per
function, times the strategy's light selection (kernels/light_selection.py).

`make_lights(features, strategy, motion=motion)` (motion from intersection/motion.py) returns
AreaLights, Warp functions callable on their own:
    pick_light(sd, x, u) -> light index;  light_pick_pmf(sd, x, li) -> its probability from x
    sample_light(sd, li, x, u, bounce, dt) -> LightSample (direction, distance, radiance,
        solid-angle pdf including the light choice) from x, a path vertex of bounce index `bounce`
    light_pdf(sd, li, x, y, ny, prim, bounce, dt) -> the density sample_light has of proposing
        point y (on face `prim` of a mesh light; ignored for other shapes) from x at that bounce
`strategy.solid_angle` samples the cone a sphere light subtends (area sampling when x is inside it),
the spherical rectangle of a rectangular quad light (box faces included) and, on a mesh light, the
spherical triangle of the face picked by area (estimators/spherical_maps.py), each uniform in solid
angle, where that solid angle lies in [SPHERICAL_MIN, SPHERICAL_MAX], x is not nearly in the light's
plane (SPHERICAL_MIN_ELEVATION) and, for a rectangle, where it pays per unit time: A cos_l / d^2 at
its centre >= SPHERICAL_PAYS and x is a path vertex of bounce index <= SPHERICAL_MAX_BOUNCE (0: the
camera ray's hit); area sampling elsewhere, and for quads that are not rectangles. Otherwise every
flat light is area-sampled. The strategy's light selection (`kernels/light_selection.py`: `uniform`,
`power`, or a plugin's) picks the light from the shading point.
The fault features.LIGHT_JACOBIAN in `features.faults` drops the cosine at the light.
`features.emission_textures` compiles in the emission texture at a sample's point (kernels/emission.py).
`features.meshes` compiles in emitting triangle meshes (mesh_light.py); the fault
features.MESH_PDF_HIGH_10PCT claims a density 10% too high. features.SPHERICAL_LINEAR compiles the
spherical maps' wrong variant, features.SPHERICAL_MIS_AREA a light_pdf that ignores them,
features.SPHERICAL_MIS_FIRST_VERTEX one that ignores SPHERICAL_MAX_BOUNCE.
"""
from typing import NamedTuple

import warp as wp

from drtlab.estimators.spherical_maps import make_spherical_maps
from drtlab.estimators.strategies import Strategy
from drtlab.kernels import mesh_light, quad_light, sphere_light
from drtlab.kernels.device_scene import SceneData
from drtlab.kernels.emission import make_sample_emission
from drtlab.kernels.features import (SPHERICAL_LINEAR, SPHERICAL_MIS_AREA, SPHERICAL_MIS_FIRST_VERTEX,
                                     Features)
from drtlab.kernels.intersection.motion import Motion
from drtlab.kernels.light_sample import (RECTANGLE_COS, SPHERICAL_MAX, SPHERICAL_MIN,  # noqa: F401
                                         SPHERICAL_MIN_ELEVATION, LightSample, SphericalRules)
from drtlab.kernels.light_selection import selection_of
from drtlab.kernels.static_tag import variant_tag

# Solid-angle sampling of a rectangle or triangle only where the solid angle Omega (sr) it subtends
# from x lies in [SPHERICAL_MIN, SPHERICAL_MAX] and x stands at least SPHERICAL_MIN_ELEVATION x (the
# distance to the shape's farthest corner) off its plane; area sampling elsewhere, decided by the
# same numbers in sample_light and light_pdf so that MIS sees the density actually used. Why:
# below SPHERICAL_MIN the maps' float32 angles (errors ~1e-7 rad each, against a sub-polygon of
# u0 Omega) misplace a relative ~1e-3 of the samples, and area sampling is as good there (the light
# is small and far: its cosines and distances vary little over it); pbrt-v4 uses 3e-4 for triangles
# too. Above SPHERICAL_MAX (within 1% of the hemisphere) Arvo's map divides by nearly zero. Seen
# nearly edge-on (elevation sine below 0.01) the maps recover a position from the cosine of an angle
# within ~1e-4 of 0 or pi, which float32 cannot resolve: the samples pile up on the far edge
# (tests/estimators/test_chi2_solid_angle.py measured 5% of them at elevation 2e-4).
# (The thresholds are light_sample.py's: SPHERICAL_MIN, SPHERICAL_MAX, SPHERICAL_MIN_ELEVATION.)
# A rectangle is sampled by solid angle only where, besides, A cos_l / d^2 at its centre (its solid
# angle while it is small, from one sqrt: no atan2) is at least SPHERICAL_PAYS sr. Below, area
# sampling's variance is nearly as low (cos_l / d^2 varies little over the light) and does not pay
# for the spherical rectangle's cost (solid angle costs 2.1x area's ns per sample where every pixel
# uses it, direct light of a square light over a plane, one CPU thread). Calibrated by
# experiments/bench/light_switch.py: per pixel, variance ratio area / solid angle over that cost
# ratio, binned by Omega, crosses 1 at ~4e-3 sr (0.75 at 1.8-4.1e-3, 1.12 at 4.1-6.9e-3; the
# variance ratio alone rises to ~15 at 0.3-0.5 sr and is still 4.3 at 3.6 sr). The spread of
# cos_l / d^2 over the light (farthest corner over nearest point) predicts it worse: not monotone.
# Points below it skip the spherical rectangle entirely. Triangles keep SPHERICAL_MIN alone.
SPHERICAL_PAYS = 4.0e-3
# ...and only from a path vertex of bounce index (tracers' depth: delta bounces count) at most
# SPHERICAL_MAX_BOUNCE, 0: the camera ray's hit. Later vertices sample by area: their light sample's
# variance is mostly swamped by the path's, so the map's cost buys little there. Measured by
# experiments/bench/light_bounce.py (one thread; efficiency = (var x ns) of importance-area over
# importance's, 96 x 72 pixels) on the lights study's Cornell box with a 1.4 x 1.4 light under
# path tracing: every vertex costs 1.64x area's ns per sample for a 1.35x lower variance
# (efficiency 0.82); bounces 0-1, 1.27x for 1.28x (1.00); bounce 0 only, 1.15x for 1.20x (1.04).
# The built-in Cornell box: 0.62 -> 0.86 (1.62x -> 1.17x the cost, variance equal either way).
# drt samples lights at its first hit only (soft-shadows: 1.6x either way). sample_light and
# light_pdf take the index of the vertex that samples (for light_pdf: the vertex that scattered
# the ray) so that MIS sees the density used there.
SPHERICAL_MAX_BOUNCE = 0
# The light kinds, each a module with make(features, strategy, motion, spherical) -> LightKind
# (light_sample.py); meshes only where features.meshes compiles them in.
KIND_MODULES = (sphere_light, quad_light)


class AreaLights(NamedTuple):
    pick_light: wp.Function         # (sd, x, u) -> light index
    light_pick_pmf: wp.Function     # (sd, x, li) -> the probability pick_light picks li from x
    sample_light: wp.Function       # (sd, li, x, u, bounce, dt) -> LightSample
    light_pdf: wp.Function          # (sd, li, x, y, ny, prim, bounce, dt) -> density of y


def light_kinds(f: Features, strategy: Strategy, *, motion: Motion) -> tuple:
    """(LightKind, ...) of the variant: every kind module's, built with the spherical rules as they
    are now (experiments/bench/light_switch.py and light_bounce.py set SPHERICAL_PAYS and
    SPHERICAL_MAX_BOUNCE before building)."""
    linear = SPHERICAL_LINEAR in f.faults
    rules = SphericalRules(make_spherical_maps(linear=linear), linear, SPHERICAL_PAYS, SPHERICAL_MAX_BOUNCE,
                           SPHERICAL_MIS_AREA in f.faults, SPHERICAL_MIS_FIRST_VERTEX in f.faults)
    modules = KIND_MODULES + ((mesh_light,) if f.meshes else ())
    return tuple(m.make(f, strategy, motion, rules) for m in modules)


def make_lights(f: Features, strategy: Strategy, *, motion: Motion) -> AreaLights:
    KINDS = light_kinds(f, strategy, motion=motion)
    EMISSION_TEXTURES = f.emission_textures
    sample_emission = make_sample_emission(motion)
    selection = selection_of(strategy)
    pick_light, light_pick_pmf = selection.pick, selection.pmf

    @wp.func
    def light_pdf(sd: SceneData, li: int, x: wp.vec3, y: wp.vec3, ny: wp.vec3, prim: int,
                  bounce: int, dt: float) -> float:
        """Solid-angle density (light choice included) of light sampling producing point y from x,
        a path vertex of bounce index `bounce`."""
        k = sd.lights.shape_kind[li]
        s = sd.lights.shape[li]
        pdf = float(0.0)
        _variant = wp.static(variant_tag(tuple(kd.tag for kd in KINDS)))  # noqa: F841 (static_tag.py)
        for i in range(wp.static(len(KINDS))):
            if k == wp.static(KINDS[i].code):
                pdf = wp.static(KINDS[i].pdf)(sd, s, x, y, ny, prim, bounce, dt)
        return pdf * light_pick_pmf(sd, x, li)

    @wp.func
    def sample_light(sd: SceneData, li: int, x: wp.vec3, u: wp.vec2, bounce: int,
                     dt: float) -> LightSample:
        k = sd.lights.shape_kind[li]
        s = sd.lights.shape[li]
        ls = LightSample()
        ls.valid = 0
        _variant = wp.static(variant_tag(tuple(kd.tag for kd in KINDS)))  # noqa: F841 (static_tag.py)
        for i in range(wp.static(len(KINDS))):
            if k == wp.static(KINDS[i].code):
                ls = wp.static(KINDS[i].sample)(sd, s, x, u, bounce, dt)
        if ls.valid == 1:
            ls.pdf = ls.pdf * light_pick_pmf(sd, x, li)
            if wp.static(EMISSION_TEXTURES):
                ls.radiance = sample_emission(sd, k, s, ls.prim, x + ls.wi * ls.dist, dt, ls.radiance)
        return ls

    return AreaLights(pick_light=pick_light, light_pick_pmf=light_pick_pmf,
                      sample_light=sample_light, light_pdf=light_pdf)
