"""Mitsuba 3's spot light (src/emitters/spot.cpp): a point light whose intensity falls off with the
angle theta from its axis, 1 inside the beam (theta <= beam_width), linearly in theta down to 0 at
the cutoff (theta >= cutoff_angle: none), both angles given in degrees:

    falloff(cos theta) = 0                                              cos theta <= cos(cutoff)
                       = 1                                              cos theta >= cos(beam)
                       = (cutoff - acos(cos theta)) / (cutoff - beam)   between (radians)

Its radiant intensity towards theta is `intensity` x falloff, times its projected `texture` where
it has one (kernels/projection.py). A point light is a spot with the cone POINT_CONE, whose
falloff is exactly 1 for every direction, so that a scene with both loops over one list.
"""
import numpy as np
import warp as wp

# (cos cutoff, cos beam, cutoff in radians, 1 / transition width): every cos theta >= -1 is in the beam.
POINT_CONE = (-2.0, -2.0, 0.0, 0.0)


def spot_cone(light) -> tuple[float, float, float, float]:
    """The falloff's constants of a PointLight (kernels/scene_model/scene.py) in float32 as Mitsuba's
    `update` computes them (degrees to radians, then the cosines and the inverse width)."""
    if not light.spot:
        return POINT_CONE
    f32 = np.float32
    cutoff = f32(light.cutoff_angle) * f32(np.pi / 180.0)
    beam = f32(light.beam_width) * f32(np.pi / 180.0)
    with np.errstate(divide="ignore"):      # beam == cutoff: no transition band (never evaluated)
        inv_width = f32(1.0) / (cutoff - beam)
    return float(np.cos(cutoff)), float(np.cos(beam)), float(cutoff), float(inv_width)


def spot_axis(light) -> np.ndarray:
    """A spot's or projector's unit axis (a point light's is unused: +z)."""
    if light.direction is None:
        return np.array([0.0, 0.0, 1.0])
    d = np.asarray(light.direction, dtype=np.float64)
    return d / np.linalg.norm(d)


@wp.func
def spot_falloff(cos_theta: float, cone: wp.vec4) -> float:
    """The share of a spot's intensity at cos theta from its axis (cone: spot_cone's four numbers)."""
    if cos_theta <= cone[0]:
        return 0.0
    if cos_theta >= cone[1]:
        return 1.0
    return (cone[2] - wp.acos(cos_theta)) * cone[3]
