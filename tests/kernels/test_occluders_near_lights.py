"""Geometry behind and beside the lights of a closed-form scene (issue 20): a shadow ray ends at its
light sample, so shapes beyond the light, or next to it off every segment from a visible point to
the light, change nothing. Until now no closed-form scene had any (one hard case caught shadow
rays counted to infinity, after minutes of other tests).

Scenes: tests/support/scene_util.py's Lambertian plane under a sphere light or a tilted one-sided
quad light, with background 0 (so an occluder off the light's solid angle hides nothing), plus
black (albedo 0: they reflect nothing) occluders of every kind the shadow rays test differently: a
sphere and a box above the light (every segment from the plane to the light stays below the light's
top), a sphere and a box beside it, and for the quad light a quad right behind its back. The test
checks that geometry itself: no camera quadrature ray meets an occluder, and no segment from a
visible plane point to a point of the light (its whole surface: area sampling picks far-side points
of a sphere light too) comes within MARGIN of one. The closed form is then exactly the one without
occluders.

Statistics (tests/support/stats_util.py): RUNS renders of fixed seeds -> 4 x 4 pixel regions -> Welch
t per region against the exact value -> chi-square over regions; the level is ALPHA = 0.01, Sidak-
corrected over this module's comparisons (M_TESTS). Negative control: a black occluder moved between
the light and the plane casts a shadow the closed form does not have; the same test must reject it.
"""
from __future__ import annotations

import numpy as np
import pytest

from drtlab.experiments.stats.chi2 import sidak

import scene_util as su
from closed_forms_util import ray_hits_parallelogram, segment_clears_sphere
from scene_pieces import camera_rays, quad, sphere
from stats_util import ALPHA, compare, render_estimate, tier

BLOCK = 4
RUNS = tier(8, 16)
SPP = tier(64, 256)
MARGIN = 0.05
SAMPLERS = ("uniform", "importance")        # area sampling (whole sphere) and solid angle + MIS
INTEGRATORS = ("drt", "path")
LIGHTS = {
    "sphere-light": dict(kind="sphere"),
    "quad-light": dict(kind="quad", size=0.8, quad_normal=(0.3, -1.0, 0.2)),
}
M_TESTS = len(LIGHTS) * len(SAMPLERS) * len(INTEGRATORS) + 1
ALPHA_TEST = sidak(ALPHA, M_TESTS)


def _box(lo, hi, material) -> dict:
    return {"kind": "box", "material": material, "min": list(map(float, lo)),
            "max": list(map(float, hi))}


def occluders(light: str) -> list[dict]:
    """Black shapes behind (above) and beside the light of scene_util.light_over_plane."""
    c = np.array([0.3, 1.6, -0.2])                  # light_over_plane's light_pos
    shapes = [sphere(c + [0.0, 1.15, 0.1], 0.4, "black", name="sphere-behind"),
              _box(c + [-0.9, 0.75, -0.5], c + [-0.2, 1.05, 0.3], "black"),          # behind
              sphere(c + [1.45, 0.2, -0.3], 0.3, "black", name="sphere-beside"),
              _box(c + [-1.7, -0.25, -0.4], c + [-1.15, 0.35, 0.2], "black")]        # beside
    if light == "quad-light":
        # Against the quad light's back (its unlit side faces up), a hair above it.
        shapes.append(quad(c + [-0.45, 0.35, -0.45], (0.9, 0.0, 0.0), (0.0, 0.0, 0.9), "black",
                           name="quad-behind"))
    return shapes


def occluded_scene(light: str, integrator: str, extra=()) -> su.ClosedForm:
    cf = su.light_over_plane(**LIGHTS[light], bg=0.0, integrator=integrator,
                             name=f"{light}-with-occluders")
    cf.scene["materials"]["black"] = {"kind": "diffuse", "albedo": [0.0, 0.0, 0.0]}
    cf.scene["shapes"] += occluders(light) + list(extra)
    return cf


# ---------------------------------------------------------------------------------------------------
# The geometry the closed form relies on
# ---------------------------------------------------------------------------------------------------

def _light_points(cf: su.ClosedForm, n: int = 40) -> np.ndarray:
    light = next(s for s in cf.scene["shapes"] if s.get("name") == "light")
    if light["kind"] == "sphere":
        u, v = np.meshgrid(np.linspace(-1, 1, n), np.linspace(0, 2 * np.pi, n, endpoint=False))
        r = np.sqrt(1 - u * u)
        dirs = np.stack([r * np.cos(v), r * np.sin(v), u], axis=-1).reshape(-1, 3)
        return np.asarray(light["center"]) + light["radius"] * dirs
    s, t = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
    o, eu, ev = (np.asarray(light[k]) for k in ("origin", "edge_u", "edge_v"))
    return (o + s.reshape(-1, 1) * eu + t.reshape(-1, 1) * ev)


def _box_faces(s: dict):
    lo, hi = np.asarray(s["min"]), np.asarray(s["max"])
    size = hi - lo
    for axis in range(3):
        u, v = [np.eye(3)[k] * size[k] for k in range(3) if k != axis]
        for base in (lo, lo + np.eye(3)[axis] * size[axis]):
            yield base, u, v


def _parallelograms(s: dict, grow: float):
    """A quad, or a box's six faces, grown by `grow` on every side (the margin)."""
    faces = _box_faces(s) if s["kind"] == "box" else \
        [(np.asarray(s["origin"]), np.asarray(s["edge_u"]), np.asarray(s["edge_v"]))]
    for o, u, v in faces:
        un, vn = u / np.linalg.norm(u), v / np.linalg.norm(v)
        yield o - grow * (un + vn), u + 2 * grow * un, v + 2 * grow * vn


def _segments_clear(p: np.ndarray, q: np.ndarray, s: dict) -> bool:
    if s["kind"] == "sphere":
        return segment_clears_sphere(p, q, np.asarray(s["center"]), s["radius"], MARGIN)
    o = np.repeat(p, len(q), axis=0)
    d = np.tile(q, (len(p), 1)) - o
    for p0, eu, ev in _parallelograms(s, MARGIN):
        n = np.cross(eu, ev)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = ((p0 - o) @ n) / (d @ n)
        if np.any(ray_hits_parallelogram(o, d, p0, eu, ev) & (t < 1.0)):
            return False
    return True


@pytest.mark.parametrize("light", list(LIGHTS))
def test_occluders_are_off_every_camera_ray_and_shadow_segment(light):
    cf = occluded_scene(light, "path")
    cam, (w, h) = cf.scene["camera"], cf.scene["scene"]["resolution"]
    o, d, _ = camera_rays(cam, w, h, n_pix=6)
    o, d = o.reshape(-1, 3), d.reshape(-1, 3)
    plane_t = -o[:, 1] / d[:, 1]
    visible = o + d * plane_t[:, None]
    lights = _light_points(cf)
    pick = np.random.default_rng(0).choice(len(visible), size=600, replace=False)
    for s in occluders(light):
        if s["kind"] == "sphere":
            oc = np.asarray(s["center"]) - o
            tc = np.sum(oc * d, axis=-1)
            disc = (s["radius"] + MARGIN) ** 2 - (np.sum(oc * oc, -1) - tc ** 2)
            entry = tc - np.sqrt(np.maximum(disc, 0.0))
            assert np.all((disc < 0) | (entry > plane_t)), f"the camera sees {s.get('name')}"
        else:
            for p0, eu, ev in _parallelograms(s, MARGIN):
                n = np.cross(eu, ev)
                t = ((p0 - o) @ n) / (d @ n)
                assert not np.any(ray_hits_parallelogram(o, d, p0, eu, ev) & (t < plane_t)), \
                    f"the camera sees a {s['kind']}"
        assert _segments_clear(visible[pick], lights, s), f"{s.get('name', s['kind'])} shadows the plane"


def test_negative_control_geometry_check_sees_a_shadowing_occluder():
    blocker = sphere((0.2, 0.9, -0.1), 0.25, "black", name="between")
    cf = occluded_scene("sphere-light", "path")
    cam, (w, h) = cf.scene["camera"], cf.scene["scene"]["resolution"]
    o, d, _ = camera_rays(cam, w, h, n_pix=2)
    o, d = o.reshape(-1, 3), d.reshape(-1, 3)
    visible = o + d * (-o[:, 1] / d[:, 1])[:, None]
    assert not _segments_clear(visible, _light_points(cf, 12), blocker)


# ---------------------------------------------------------------------------------------------------
# Renders against the closed form
# ---------------------------------------------------------------------------------------------------

def _check(cf: su.ClosedForm, sampler: str, integrator: str, key: tuple):
    est = render_estimate(cf.load(), sampler, integrator, SPP, RUNS, key, block=BLOCK)
    truth = cf.region_truth(BLOCK)
    assert est.nonfinite == 0 and est.negative == 0
    return compare(est, truth, ALPHA_TEST), est, truth


@pytest.mark.parametrize("integrator", INTEGRATORS)
@pytest.mark.parametrize("sampler", SAMPLERS)
@pytest.mark.parametrize("light", list(LIGHTS))
def test_occluders_behind_and_beside_the_light_change_nothing(light, sampler, integrator):
    cf = occluded_scene(light, integrator)
    c, est, truth = _check(cf, sampler, integrator, ("occluders", light, sampler, integrator))
    assert not c.rejected, (f"{cf.name} {sampler}/{integrator}: {c.summary()}; exact "
                            f"{np.round(truth.mean[:4], 5)}..., estimate {np.round(est.mean[:4], 5)}...")


def test_negative_control_an_occluder_between_is_rejected():
    blocker = sphere((0.2, 0.9, -0.1), 0.25, "black", name="between")
    cf = occluded_scene("sphere-light", "path", extra=[blocker])
    c, _, _ = _check(cf, "importance", "path", ("occluders", "control"))
    assert c.rejected, c.summary()
