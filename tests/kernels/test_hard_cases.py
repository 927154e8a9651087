"""Hard cases (numerical stability): a parameterized matrix of small scenes with closed-form pixel
values (tests/support/scene_util.py) that must render finite, non-negative images converging to the truth.

Each case renders RUNS independent images (fixed seeds) with each listed sampler (path tracing) and is
compared with its closed form by the suite's one test (12 regions of 4 x 4 pixels, Welch t ->
chi-square), Sidak-corrected over every comparison in this module (M_TESTS) at family-wise
alpha = 0.01. Every case also asserts 0 non-finite and 0 negative pixel values. test_summary (the
last test) prints the worst relative error of every case and the total non-finite count (run with
-s to see it; it is also in the assertion message should anything fail).

The matrix:
  grazing camera rays (88.5-89.5 deg on the plane), grazing light (a sphere light on the horizon, a
  vertical quad light seen at <= 10 deg elevation); a rectangle light very close above the receivers
  (solid angles up to ~2 pi), one nearly in their plane (both sides of the solid-angle sampling
  thresholds of kernels/lights.py) and one standing over the view, hidden from half of it; glossy exponents 0, 1, 10^3, 10^6 (white
  furnace, modified-Phong albedo by quadrature); GGX alpha 0.001, 0.02, 1 (white furnace, both
  microfacet samplers, albedo by quadrature); IOR 1.0001, 1.5, 3: a slab before an emitter
  (Le (1 - F) / (1 + F)) and a glass cube in a furnace (= 1, total internal reflection at the side
  faces); sphere and quad lights of size 10^-4 ... 10^2 at equal power (Le ~ 1 / size^2); scene
  scales 10^-3 ... 10^4 (furnace and lit plane: self-intersection offsets must scale); rays through
  edges and corners (furnace looking into a corner, one face split in two quads; the glass cube's
  corner); a camera inside a sphere; a moving object with zero velocity (motion compiled in); a thin
  lens focused at the object and at infinity; the grazing cases again with the plane a triangle
  mesh (a graded 24 x 24 grid cut along random diagonals: many shared edges at grazing angles); an
  environment light (tests/kernels/test_environment.py has its closed forms): a tiny very bright sun
  (one texel of a 256 x 128 map, radiance 10^5 over a sky of 0.5: ~95% of the irradiance), the
  two-level sky seen by a grazing camera and on a plane tilted 89 degrees (grazing normal), and a
  black environment (exactly 0, test_black_environment).

Samplers: `importance` and `stratified` (uniform strategy) where the uniform strategy has a testable
variance. It is left out for GGX alpha < 0.5 and Phong exponents 10^3 and 10^6 (uniform hemisphere directions hit a lobe
of solid angle ~2 pi / n: the estimate is a handful of huge values) and replaced by
stratified+importance in the closed boxes (next-event estimation alone has infinite variance where
two emitting walls meet, see scene_util.furnace_box); SAMPLERS_NOTE says so in the summary.
Tiers: fast RUNS x SPP = 8 x 64, full 16 x 256 (same cases).
"""
from __future__ import annotations

import dataclasses
import functools
import math
import tempfile
from pathlib import Path

import numpy as np
import pytest

from drtlab.experiments.stats.chi2 import sidak
from drtlab.kernels.render import render

import scene_util as su
from mesh_util import graded_plane, mesh, unit, write_mesh
from stats_util import ALPHA, compare, render_estimate, tier

BLOCK = 4
RUNS = tier(8, 16)
SPP = tier(64, 256)
BOTH = ("importance", "stratified")
IMPORTANCE = ("importance",)
# GGX lobes: normals from the visible normals (importance) and from D cos (importance-ggxd).
GGX_SAMPLERS = ("importance", "independent+importance-ggxd")
# Closed diffuse boxes: NEE-only sampling (the uniform strategy) has infinite variance where two
# emitting walls meet (see scene_util.furnace_box); the stratified point set is tested with MIS.
MIS_BOTH = ("importance", "stratified+importance")
SAMPLERS_NOTE = ("not tested with the uniform strategy: Phong lobes of exponent >= 10^3 (a handful "
                 "of huge samples) and closed emitting boxes (infinite variance at the edges)")


def _grazing_camera():
    return su.light_over_plane("sphere", light_pos=(0.0, 1.0, 0.5), size=0.3, le=20.0, bg=0.1,
                               cam_pos=(0.0, 0.08, 3.0), look=(0.0, 0.0, 0.0), fov=2.0,
                               name="grazing-camera")


def _grazing_sphere_light():
    # Sphere resting just above the plane far to the side: light arrives ~88 deg from the normal.
    return su.light_over_plane("sphere", light_pos=(-6.0, 0.21, 0.0), size=0.2, le=2.0e4, bg=0.01,
                               cam_pos=(0.0, 3.0, 0.5), look=(0.0, 0.0, 0.0), fov=30.0,
                               name="grazing-sphere-light")


def _grazing_quad_light():
    # A vertical emitter facing +x standing 3 units to the side: elevation <= 10 deg at the receivers.
    return su.light_over_plane("quad", light_pos=(-3.0, 0.3, 0.0), size=0.5, le=200.0, bg=0.01,
                               quad_normal=(1.0, 0.0, 0.0), cam_pos=(0.0, 3.0, 0.5),
                               look=(0.0, 0.0, 0.0), fov=30.0, name="grazing-quad-light")


SKY = dict(kind="two_level", upper=[2.0, 2.0, 2.0], lower=[0.3, 0.3, 0.3])


def _environment_sun():
    from drtlab.kernels.scene_model.environment_map import texels
    h, w, sun, le = 128, 256, [1.0, 1.3, 0.4], 1.0e5
    row = int(texels(np.array([sun]), h, w)[0][0])
    env = dict(kind="two_level", upper=[0.5] * 3, lower=[0.1] * 3, resolution=[w, h],
               sun_direction=sun, sun_radiance=[le] * 3)
    return su.environment_over_plane(env, math.pi * 0.5 + le * su.texel_irradiance(h, w, row),
                                     name="environment-sun-texel")


def _light_size(kind: str, size: float):
    # Equal power: Le * area = const. The light's lowest point is 1.5 above the plane and the camera
    # (at height 1) stays below it, so big lights are farther away and dimmer at the view: the
    # point is stability.
    cam = dict(cam_pos=(0.0, 1.0, 1.6), look=(0.1, 0.0, 0.0), fov=40.0, bg=0.0)
    if kind == "sphere":
        return su.light_over_plane("sphere", light_pos=(0.3, 1.5 + size, -0.2), size=size,
                                   le=0.25 / size ** 2, name=f"sphere-light-r{size:g}", **cam)
    return su.light_over_plane("quad", light_pos=(0.3, 1.5, -0.2), size=size, le=1.0 / size ** 2,
                               quad_normal=(0.0, -1.0, 0.0), name=f"quad-light-a{size:g}", **cam)


_MESH_DIR = tempfile.TemporaryDirectory(prefix="drtlab-hard-mesh-")     # removed at exit


def _meshed(cf: su.ClosedForm) -> su.ClosedForm:
    """The same closed form with its plane (the scene's first shape) as a triangle mesh."""
    plane = cf.scene["shapes"][0]
    vertices, faces = graded_plane(plane)
    normal = unit(np.cross(plane["edge_u"], plane["edge_v"]))
    path = write_mesh(Path(_MESH_DIR.name) / f"{cf.name}.obj", vertices, faces,
                      np.tile(normal, (len(vertices), 1)))
    shapes = [mesh(plane["material"], file=path, name="plane")] + list(cf.scene["shapes"][1:])
    return dataclasses.replace(cf, name=cf.name + "-mesh", scene=dict(cf.scene, shapes=shapes))


def _rect_light_close():
    # A 2 x 2 light facing down 0.12 above the receivers the camera (at 0.1, below it) looks at: solid
    # angles up to ~2 pi, on both sides of kernels/lights.py's SPHERICAL_MAX.
    return su.light_over_plane("quad", light_pos=(0.0, 0.12, -0.3), size=2.0, le=2.0, bg=0.01,
                               cam_pos=(0.0, 0.1, 0.6), look=(0.0, 0.0, -0.3), fov=8.0,
                               name="rect-light-close")


def _rect_light_nearly_in_plane():
    # A 3 x 3 light facing down 0.055 above the plane, 3-5 units from the receivers: they lie nearly
    # in its plane (elevation sines 0.008-0.012, both sides of SPHERICAL_MIN_ELEVATION), most of
    # them above SPHERICAL_PAYS (so that the elevation threshold is what decides there).
    return su.light_over_plane("quad", light_pos=(-4.0, 0.055, 0.0), size=3.0, le=180.0, bg=0.01,
                               cam_pos=(0.0, 3.0, 0.5), look=(0.0, 0.0, 0.0), fov=30.0,
                               name="rect-light-nearly-in-plane")


def _rect_light_half_hidden():
    # A vertical light facing +x standing over the middle of the view: receivers at x < 0 are behind
    # it (hidden: no valid light sample, zero density for MIS), those near x = 0 see it edge-on.
    return su.light_over_plane("quad", light_pos=(0.0, 0.6, 0.0), size=0.5, le=50.0, bg=0.01,
                               quad_normal=(1.0, 0.0, 0.0), cam_pos=(0.0, 3.0, 0.5),
                               look=(0.0, 0.0, 0.0), fov=30.0, name="rect-light-half-hidden")


LENS_KW = dict(light_pos=(-0.7, 0.15, 0.0), size=0.05, le=400.0, bg=0.05, fov=12.0, checker=True)
# Distance from the camera (0, 2.2, 3) to the look-at point (0.1, 0, 0) on the plane.
OBJECT_DISTANCE = math.dist((0.0, 2.2, 3.0), (0.1, 0.0, 0.0))

CASES = {
    "grazing-camera": (_grazing_camera, BOTH),
    "grazing-sphere-light": (_grazing_sphere_light, BOTH),
    "grazing-quad-light": (_grazing_quad_light, BOTH),
    "rect-light-close": (_rect_light_close, BOTH),
    "rect-light-nearly-in-plane": (_rect_light_nearly_in_plane, BOTH),
    "rect-light-half-hidden": (_rect_light_half_hidden, BOTH),
    **{f"glossy-exponent-{e:g}": (lambda e=e: su.sphere_furnace("glossy", exponent=e, depth=3,
                                                               name=f"glossy-exponent-{e:g}"),
                                  BOTH if e < 100 else IMPORTANCE)
       for e in (0.0, 1.0, 1e3, 1e6)},
    # GGX conductors at roughness extremes (white furnace, albedo by quadrature: single scattering
    # loses up to ~70% at alpha = 1): visible-normal and D sampling; grazing at the silhouette.
    **{f"ggx-alpha-{a:g}": (lambda a=a: su.sphere_furnace("ggx", roughness=a, depth=3,
                                                         name=f"ggx-alpha-{a:g}"),
                            GGX_SAMPLERS + (("stratified",) if a >= 0.5 else ()))
       for a in (0.001, 0.02, 1.0)},
    **{f"slab-ior-{ior:g}": (lambda ior=ior: su.slab(ior), BOTH) for ior in (1.0001, 1.5, 3.0)},
    **{f"glass-cube-tir-ior-{ior:g}": (lambda ior=ior: su.cube_furnace(ior), BOTH)
       for ior in (1.0001, 1.5, 3.0)},
    **{f"sphere-light-size-{r:g}": (lambda r=r: _light_size("sphere", r), BOTH)
       for r in (1e-4, 1e-2, 1.0, 1e2)},
    **{f"quad-light-size-{a:g}": (lambda a=a: _light_size("quad", a), BOTH)
       for a in (1e-4, 1e-2, 1.0, 1e2)},
    **{f"furnace-scale-{s:g}": (lambda s=s: su.furnace_box(scale=s, depth=5,
                                                          name=f"furnace-scale-{s:g}"), MIS_BOTH)
       for s in (1e-3, 1.0, 1e4)},
    **{f"lit-plane-scale-{s:g}": (lambda s=s: su.light_over_plane("sphere", scale=s,
                                                                name=f"lit-plane-scale-{s:g}"), BOTH)
       for s in (1e-3, 1e4)},
    "furnace-corner-split-face": (lambda: su.furnace_box(look=(1.0, 1.0, 1.0), camera_pos=(0, 0, 0),
                                                         depth=4, split_face=True,
                                                         name="furnace-corner"), MIS_BOTH),
    "furnace-edge": (lambda: su.furnace_box(look=(1.0, 0.0, 1.0), camera_pos=(0.3, 0.0, 0.3),
                                            depth=4, split_face=True, name="furnace-edge"), MIS_BOTH),
    "camera-inside-sphere-direct": (lambda: su.sphere_interior(depth=2, name="inside-d2"), BOTH),
    "camera-inside-sphere-d6": (lambda: su.sphere_interior(depth=6, name="inside-d6"), BOTH),
    "zero-velocity-motion": (lambda: su.light_over_plane("sphere", zero_velocity_motion=True,
                                                         checker=True, bg=0.0,
                                                         name="zero-velocity"), BOTH),
    "thin-lens-focus-object": (lambda: su.light_over_plane("sphere", lens=(0.3, OBJECT_DISTANCE),
                                                           name="lens-focus-object", **LENS_KW),
                               BOTH),
    "mesh-grazing-camera": (lambda: _meshed(_grazing_camera()), BOTH),
    "mesh-grazing-quad-light": (lambda: _meshed(_grazing_quad_light()), BOTH),
    "thin-lens-focus-infinity": (lambda: su.light_over_plane("sphere", lens=(0.1, 1.0e7),
                                                             name="lens-focus-infinity", **LENS_KW),
                                 BOTH),
    "environment-sun-texel": (_environment_sun, IMPORTANCE),
    "environment-grazing-camera": (lambda: su.environment_over_plane(
        SKY, su.two_level_irradiance(2.0, 0.3, 0.0), camera=(0.08, 3.0), fov=2.0,
        name="environment-grazing-camera"), BOTH),
    "environment-grazing-normal": (lambda: su.environment_over_plane(
        SKY, su.two_level_irradiance(2.0, 0.3, 89.0), tilt_deg=89.0,
        name="environment-grazing-normal"), BOTH),
}

# Heavy tails: area sampling of the radius-100 sphere 1.5 above the receivers lands 0.7% of its
# samples on the visible cap, with weights up to ~10^4 x the mean; 16x spp makes it testable.
SPP_MULT = {("sphere-light-size-100", "stratified"): 16}

M_TESTS = sum(len(samplers) for _, samplers in CASES.values())
ALPHA_TEST = sidak(ALPHA, M_TESTS)
RESULTS: dict[str, dict] = {}


@functools.lru_cache(maxsize=None)
def closed_form(name: str) -> su.ClosedForm:
    return CASES[name][0]()


def params():
    return [pytest.param(name, sampler, id=f"{name}-{sampler}")
            for name, (_, samplers) in CASES.items() for sampler in samplers]


@pytest.mark.parametrize("name,sampler", params())
def test_hard_case(name, sampler):
    cf = closed_form(name)
    spp = SPP * SPP_MULT.get((name, sampler), 1)
    est = render_estimate(cf.load(), sampler, "path", spp, RUNS, ("hard", name, sampler),
                          block=BLOCK)
    truth = cf.region_truth(BLOCK)
    c = compare(est, truth, ALPHA_TEST)
    rel = c.worst_rel_err(truth.mean)
    RESULTS[f"{name}/{sampler}"] = dict(rel=rel, nonfinite=est.nonfinite, negative=est.negative,
                                        p=c.p, max_z=c.max_abs_z, min=est.min_value,
                                        max=est.max_value)
    msg = (f"{name}/{sampler}: {c.summary()}; worst relative error {rel:.3g}; pixel range "
           f"[{est.min_value:.3g}, {est.max_value:.3g}]")
    assert est.nonfinite == 0, f"{msg}: {est.nonfinite} non-finite pixel values"
    assert est.negative == 0, f"{msg}: {est.negative} negative pixel values"
    assert not c.rejected, msg


def test_black_environment():
    # Nothing to sample: the image sampler falls back to (about) uniform directions, the pick of
    # the environment by power is 0 beside an area light; every pixel must be exactly 0 without one.
    cf = su.environment_over_plane(dict(kind="constant", radiance=[0, 0, 0]), 0.0, camera=(0.08, 3.0),
                                   fov=2.0, name="black-environment")
    for sampler in BOTH + ("independent+env-cosine", "independent+env-uniform"):
        img = render(cf.load(), spp=16, sampler=sampler, integrator="path", progress=False)
        assert np.all(img == 0.0), sampler
    lit = su.light_over_plane("sphere", bg=0.0, name="black-environment-and-light")
    scene = dict(lit.scene, scene=dict(lit.scene["scene"]), environment=dict(kind="constant",
                                                                             radiance=[0, 0, 0]))
    del scene["scene"]["background"]
    img = render(su.ClosedForm("x", scene, lit.truth).load(), spp=16, sampler="importance",
                 integrator="path", progress=False)
    assert np.all(np.isfinite(img)) and img.min() >= 0.0 and img.max() > 0.0


def test_closed_forms_are_sane():
    # Truths themselves: finite, positive, and the parameter sweeps change what they should.
    for name in CASES:
        t = closed_form(name).truth
        assert np.all(np.isfinite(t)) and np.all(t > 0), name
    # Equal power: a 10^-4 sphere and a 10^-2 sphere at nearly the same place give nearly the same
    # irradiance (r^2 Le equal; the centre moves up by 0.01).
    a, b = closed_form("sphere-light-size-0.0001").truth, closed_form("sphere-light-size-0.01").truth
    assert np.allclose(a, b, rtol=0.02)
    # Scale invariance of both closed forms.
    assert np.allclose(su.light_over_plane("sphere", scale=1e-3).truth,
                       su.light_over_plane("sphere").truth, rtol=1e-9)
    # The slab transmits less at higher IOR; the focused lens differs from the one at infinity.
    assert su.slab(3.0).truth.mean() < su.slab(1.5).truth.mean() < su.slab(1.0001).truth.mean()
    # Zero velocity still runs the motion code (a mover below the plane switches it on), and the
    # lens cases compile the lens.
    from drtlab.kernels.features import features_of
    assert features_of(closed_form("zero-velocity-motion").load(), "path").motion
    assert features_of(closed_form("thin-lens-focus-infinity").load(), "path").lens
    near = closed_form("thin-lens-focus-object").truth
    far = closed_form("thin-lens-focus-infinity").truth
    assert np.max(np.abs(near - far) / far) > 0.05


def test_summary():
    """Print the worst relative error and the non-finite count over the matrix (needs the matrix to
    have run in this session; skipped when selected alone)."""
    if not RESULTS:
        pytest.skip("no hard case ran in this session")
    width = max(len(k) for k in RESULTS)
    lines = [f"{'case/sampler':{width}s}  worst-rel-err  max|z|       p  non-finite  negative"]
    for k, r in sorted(RESULTS.items(), key=lambda kv: -kv[1]["rel"]):
        lines.append(f"{k:{width}s}  {r['rel']:13.3g}  {r['max_z']:6.2f}  {r['p']:6.3g}  "
                     f"{r['nonfinite']:10d}  {r['negative']:8d}")
    worst = max(RESULTS.items(), key=lambda kv: kv[1]["rel"])
    nonfinite = sum(r["nonfinite"] for r in RESULTS.values())
    lines.append(f"worst relative error {worst[1]['rel']:.3g} ({worst[0]}); non-finite pixels "
                 f"{nonfinite}; cases {len(RESULTS)}/{M_TESTS} (Sidak alpha {ALPHA_TEST:.3g}, "
                 f"{RUNS} runs x {SPP} spp); {SAMPLERS_NOTE}")
    print("\nHard cases:\n" + "\n".join(lines))
    assert nonfinite == 0, "\n".join(lines)
