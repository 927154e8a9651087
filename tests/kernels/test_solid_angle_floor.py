"""Unbiasedness of solid-angle rectangle sampling on both sides of its fallback thresholds, against
a closed form (kernels/lights.py: SPHERICAL_PAYS, SPHERICAL_MIN_ELEVATION; for a rectangle the
switch SPHERICAL_PAYS is reached before the precision floor SPHERICAL_MIN).

Scene: a Lambertian plane (albedo rho) seen from above (path, max_depth 2: direct light only) under
two one-sided rectangle lights facing down, both outside the view and unshadowed: a small one
0.15 above the plane (pixels near it see it with A cos_l / d^2 above SPHERICAL_PAYS, far ones
below) and a large one 0.05 above it (near pixels see it above SPHERICAL_MIN_ELEVATION, far ones
below, most of both above SPHERICAL_PAYS). Every pixel is rho / pi x sum_i E_i, E_i by Lambert's polygon
formula averaged over the pixel (closed_forms_util), shared with no renderer code. Rendered with
`importance` (solid angle, MIS: the fallback's pdf must reach the MIS weights of BSDF hits),
`light` (solid angle, next-event estimation only) and `importance-area` (area, MIS).

The same plane seen through a mirror (MIRROR_CAM: the camera below a horizontal mirror whose image of
it is CAM, so every pixel is RHO_MIRROR x the direct image flipped left-right; path, max_depth 3):
its points are then path vertices of bounce index 1, past SPHERICAL_MAX_BOUNCE, where `importance`
samples the lights by area and the MIS weight of a BSDF hit must use the area density too, although
the same points seen directly (bounce 0) use solid angle.

Statistics (stats_util): RUNS renders, BLOCK x BLOCK regions, Welch t per region against the exact
value -> chi-square; ALPHA = 0.01, Sidak over the M_TESTS clean comparisons. Negative control
(same level, must be rejected): the renders with features.SPHERICAL_LINEAR (the spherical
rectangle's second coordinate linear, density still claimed 1 / Omega) and, through the mirror,
features.SPHERICAL_MIS_FIRST_VERTEX (light_pdf claiming a first vertex's density at every vertex).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from drtlab.experiments.stats import chi2 as C
from drtlab.kernels.features import SPHERICAL_LINEAR, SPHERICAL_MIS_FIRST_VERTEX
from drtlab.kernels.lights import (SPHERICAL_MAX, SPHERICAL_MAX_BOUNCE, SPHERICAL_MIN,
                                   SPHERICAL_MIN_ELEVATION, SPHERICAL_PAYS)
from drtlab.kernels.scene_model.scene_file import scene_from_dict

import closed_forms_util as cu
from stats_util import ALPHA, compare, render_estimate

RES = (16, 16)
BLOCK = 2
RUNS = 12
SPP = 64
RHO = 0.6
SAMPLERS = ("importance", "independent+light", "independent+importance-area")
M_TESTS = len(SAMPLERS) + 1        # + `importance` through the mirror
ALPHA_TEST = C.sidak(ALPHA, M_TESTS)
CAM = {"position": [0.0, 3.0, 0.0], "look_at": [0.0, 0.0, 0.0], "up": [0.0, 0.0, -1.0], "fov": 60.0}
# Its image in the mirror y = MIRROR_Y is CAM (right = forward x up flips: columns reversed).
MIRROR_Y = 2.5
MIRROR_CAM = {"position": [0.0, 2.0, 0.0], "look_at": [0.0, 3.0, 0.0], "up": [0.0, 0.0, -1.0],
              "fov": 60.0}
RHO_MIRROR = 0.9
# (centre, size (x, z), height, Le)
LIGHTS = [((2.1, 0.0), (0.4, 0.4), 0.15, 20.0), ((-3.3, 0.0), (3.0, 3.0), 0.05, 3.0)]


def corners(light):
    (cx, cz), (sx, sz), h, _ = light
    q0 = np.array([cx - sx / 2, h, cz - sz / 2])
    eu, ev = np.array([sx, 0.0, 0.0]), np.array([0.0, 0.0, sz])     # eu x ev = -y: emits down
    return q0, eu, ev


def scene(mirror=False):
    mats = {"plane": {"kind": "diffuse", "albedo": [RHO] * 3}}
    shapes = [{"kind": "quad", "material": "plane", "origin": [-20.0, 0.0, 20.0],
               "edge_u": [40.0, 0.0, 0.0], "edge_v": [0.0, 0.0, -40.0]}]
    if mirror:      # facing down (edge_u x edge_v = -y), above the lights: it sees only their backs
        mats["mirror"] = {"kind": "mirror", "albedo": [RHO_MIRROR] * 3}
        shapes.append({"kind": "quad", "material": "mirror", "origin": [-4.0, MIRROR_Y, -4.0],
                       "edge_u": [8.0, 0.0, 0.0], "edge_v": [0.0, 0.0, 8.0]})
    for i, light in enumerate(LIGHTS):
        mats[f"light{i}"] = {"kind": "emitter", "emission": [light[3]] * 3}
        q0, eu, ev = corners(light)
        shapes.append({"kind": "quad", "material": f"light{i}", "origin": q0.tolist(),
                       "edge_u": eu.tolist(), "edge_v": ev.tolist()})
    if mirror:
        return scene_from_dict(cu.scene_dict("rectangle lights near a plane, through a mirror",
                                             MIRROR_CAM, mats, shapes, RES, max_depth=3),
                               name="solid-angle-floor-mirror")
    return scene_from_dict(cu.scene_dict("rectangle lights near a plane", CAM, mats, shapes, RES,
                                         max_depth=2), name="solid-angle-floor")


def plane_points():
    o, d, w = cu.pinhole_rays(CAM, *RES)
    t = -o[1] / d[..., 1]
    assert np.all(t > 0)
    return o + d * t[..., None], w


def solid_angle_and_elevation(x, light):
    """(Omega, elevation sine over the farthest corner) of `light` from points x, float64."""
    q0, eu, ev = corners(light)
    vs = [q0 - x, q0 + eu - x, q0 + eu + ev - x, q0 + ev - x]

    def tri(a, b, c):
        la, lb, lc = (np.linalg.norm(v, axis=-1) for v in (a, b, c))
        dot = lambda p, q: np.sum(p * q, axis=-1)
        return 2 * np.arctan2(np.abs(dot(a, np.cross(b, c))),
                              la * lb * lc + dot(a, b) * lc + dot(a, c) * lb + dot(b, c) * la)
    omega = tri(vs[0], vs[1], vs[2]) + tri(vs[0], vs[2], vs[3])
    reach = np.max([np.linalg.norm(v, axis=-1) for v in vs], axis=0)
    return omega, (light[2] - x[..., 1]) / reach


def pays_measure(x, light):
    """A cos_l / d^2 at the light's centre from points x (kernels/lights.py's rect_pays)."""
    q0, eu, ev = corners(light)
    c = q0 + 0.5 * (eu + ev) - x
    return np.abs(c @ np.cross(eu, ev)) / np.linalg.norm(c, axis=-1) ** 3


def exact_image():
    x, w = plane_points()
    n = np.array([0.0, 1.0, 0.0])
    o, d, _ = cu.pinhole_rays(CAM, *RES)
    E = 0.0
    for light in LIGHTS:
        q0, eu, ev = corners(light)
        assert not cu.ray_hits_parallelogram(o, d, q0, eu, ev).any()
        E = E + cu.polygon_irradiance(x, n, [q0, q0 + eu, q0 + eu + ev, q0 + ev], light[3])
    return 3.0 * RHO / math.pi * np.sum(E * w, axis=-1)


def test_pixels_lie_on_both_sides_of_each_threshold():
    x, _ = plane_points()
    om0, el0 = solid_angle_and_elevation(x, LIGHTS[0])
    om1, el1 = solid_angle_and_elevation(x, LIGHTS[1])
    pays0, pays1 = pays_measure(x, LIGHTS[0]), pays_measure(x, LIGHTS[1])
    assert np.all(el0 > SPHERICAL_MIN_ELEVATION) and np.all((om0 > SPHERICAL_MIN) & (om0 < SPHERICAL_MAX))
    assert np.mean(pays0 > SPHERICAL_PAYS) > 0.2 and np.mean(pays0 < SPHERICAL_PAYS) > 0.2
    assert np.all((om1 > SPHERICAL_MIN) & (om1 < SPHERICAL_MAX))
    above = pays1 > SPHERICAL_PAYS      # the elevation threshold decides only where the switch says yes
    assert np.mean(above & (el1 > SPHERICAL_MIN_ELEVATION)) > 0.2
    assert np.mean(above & (el1 < SPHERICAL_MIN_ELEVATION)) > 0.2


@pytest.mark.parametrize("sampler", SAMPLERS)
def test_rectangle_lights_near_a_plane(sampler):
    exact = cu.exact_regions(exact_image(), BLOCK)
    est = render_estimate(scene(), sampler, "path", SPP, RUNS, ("solid-angle-floor", sampler),
                          block=BLOCK)
    assert est.nonfinite == 0 and est.negative == 0
    c = compare(est, exact, ALPHA_TEST)
    print(f"\n{sampler}: {c.summary()}")
    assert not c.rejected, c.summary()


def test_negative_control_linear_map_is_rejected():
    exact = cu.exact_regions(exact_image(), BLOCK)
    est = render_estimate(scene(), "independent+light", "path", SPP, RUNS, ("solid-angle-floor", "fault"),
                          block=BLOCK, faults=(SPHERICAL_LINEAR,))
    c = compare(est, exact, ALPHA_TEST)
    print(f"\nnegative control (spherical_linear): {c.summary()}")
    assert c.rejected, c.summary()


def mirror_image():
    return RHO_MIRROR * exact_image()[:, ::-1]


def test_rectangle_lights_near_a_plane_at_the_second_vertex():
    assert SPHERICAL_MAX_BOUNCE < 1     # else the plane's vertices sample as at bounce 0 (above)
    exact = cu.exact_regions(mirror_image(), BLOCK)
    est = render_estimate(scene(mirror=True), "importance", "path", SPP, RUNS,
                          ("solid-angle-floor", "mirror"), block=BLOCK)
    assert est.nonfinite == 0 and est.negative == 0
    c = compare(est, exact, ALPHA_TEST)
    print(f"\nimportance through a mirror: {c.summary()}")
    assert not c.rejected, c.summary()


def test_negative_control_first_vertex_density_at_the_second_is_rejected():
    exact = cu.exact_regions(mirror_image(), BLOCK)
    est = render_estimate(scene(mirror=True), "importance", "path", SPP, RUNS,
                          ("solid-angle-floor", "mirror-fault"), block=BLOCK,
                          faults=(SPHERICAL_MIS_FIRST_VERTEX,))
    c = compare(est, exact, ALPHA_TEST)
    print(f"\nnegative control (spherical_mis_first_vertex): {c.summary()}")
    assert c.rejected, c.summary()
