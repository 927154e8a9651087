"""The environment light on the device: its tables (device_scene.EnvironmentData, filled by
`environment_data`)
and its Warp functions, built per strategy by `make_environment(strategy)` -> Environment:
    env_pick(env) -> the probability that next-event estimation samples the environment rather
        than an area light (by power or uniformly over lights, as the strategy picks lights)
    env_radiance(env, d) -> the radiance a ray leaving the scene along d sees (its texel, or
        bilinear as Mitsuba 3's envmap; in the map's frame when it is rotated)
    env_sample(env, n, u) -> EnvSample: a direction by the strategy's `environment` sampler, its
        radiance and solid-angle pdf (without the pick)
    env_pdf(env, n, d) -> env_sample's solid-angle density of d (without the pick)
n is the shading normal turned towards the outgoing direction (the cosine sampler's axis).
The samplers (LightSampling.environment, estimators/strategies.py): "uniform" over the sphere,
"cosine" about n (zero density below it: MIS's BSDF samples cover transmission), "image": the
PiecewiseConstant2D tables of kernels/scene_model/environment_map.py, rows then columns by binary search over
their cdfs. The model, the lat-long convention and the tables' facts are in environment_map.py.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
import warp as wp

from drtlab.estimators.domain_maps import (INV_2PI, INV_4PI, INV_PI, PI, frame_to_world,
                                           square_to_cosine_hemisphere, square_to_uniform_sphere)
from drtlab.estimators.strategies import Strategy
from drtlab.kernels.device_scene import EnvironmentData
from drtlab.kernels.light_selection import selection_of
from drtlab.kernels.scene_model.environment_map import EnvironmentMap, sampling_tables

# d omega = 2 pi^2 sin(theta) du dv over the lat-long square.
LATLONG_JACOBIAN = wp.constant(2.0 * math.pi * math.pi)


@wp.struct
class EnvSample:
    wi: wp.vec3
    radiance: wp.vec3
    pdf: float                                 # solid angle, without the pick
    valid: int


def environment_data(env: EnvironmentMap | None, area_powers: np.ndarray, radius: float,
                     arr) -> EnvironmentData:
    """The device tables of `env` (placeholders without one). The pick by power weighs the
    environment as pbrt does, by the power it sends through the scene's bounding disc:
    pi r^2 * integral of luminance over the sphere, against each area light's pi A luminance."""
    e = EnvironmentData()
    n_area = len(area_powers)
    e.rotated = e.bilinear = 0
    e.to_world = e.to_local = wp.mat33(np.eye(3, dtype=np.float32))
    if env is None:
        e.radiance = arr([], wp.vec3, (1, 3))
        for name in ("texel_pdf", "marginal", "conditional"):
            setattr(e, name, arr([], float, (1,)))
        e.width = e.height = 0
        e.pick_power = e.pick_uniform = 0.0
        return e
    t = sampling_tables(env.image, lookup=env.lookup)
    e.bilinear = int(env.lookup == "bilinear")
    if env.to_world is not None:
        e.rotated = 1
        e.to_world = wp.mat33(env.to_world.astype(np.float32))
        e.to_local = wp.mat33(env.to_world.T.astype(np.float32))
    e.radiance = arr(env.image.reshape(-1, 3), wp.vec3, (1, 3))
    e.texel_pdf = arr(t.texel_pdf.ravel(), float, (1,))
    e.marginal = arr(t.marginal, float, (1,))
    e.conditional = arr(t.conditional.ravel(), float, (1,))
    e.width, e.height = env.width, env.height
    p_env = math.pi * radius * radius * env.luminance_integral()
    total = p_env + float(np.sum(area_powers))
    e.pick_power = float(p_env / total) if n_area and total > 0.0 else 1.0
    e.pick_uniform = 1.0 / (n_area + 1)
    return e


class Environment(NamedTuple):
    env_pick: wp.Function
    env_radiance: wp.Function
    env_sample: wp.Function
    env_pdf: wp.Function


@wp.func
def texel_index(env: EnvironmentData, d: wp.vec3) -> int:
    theta = wp.acos(wp.clamp(d[1], -1.0, 1.0))
    phi = wp.atan2(d[2], d[0])
    if phi < 0.0:
        phi += 2.0 * PI
    row = wp.min(int(theta * INV_PI * float(env.height)), env.height - 1)
    col = wp.min(int(phi * INV_2PI * float(env.width)), env.width - 1)
    return row * env.width + col


@wp.func
def local(env: EnvironmentData, d: wp.vec3) -> wp.vec3:
    if env.rotated == 1:
        return env.to_local * d
    return d


@wp.func
def bilinear(env: EnvironmentData, d: wp.vec3) -> wp.vec3:
    """Mitsuba 3's envmap lookup of a map-frame direction (environment_map.py): columns at their
    centres and periodic, rows at v = r / (H - 1)."""
    w = env.width
    u = wp.atan2(d[2], d[0]) * INV_2PI
    u = u - wp.floor(u)
    x = u * float(w) - 0.5
    xf = wp.floor(x)
    fx = x - xf
    c0 = int(xf)
    if c0 < 0:
        c0 += w
    c1 = c0 + 1
    if c1 >= w:
        c1 -= w
    y = wp.acos(wp.clamp(d[1], -1.0, 1.0)) * INV_PI * float(env.height - 1)
    r0 = wp.min(int(y), env.height - 2)
    fy = y - float(r0)
    top = env.radiance[r0 * w + c0] * (1.0 - fx) + env.radiance[r0 * w + c1] * fx
    r1 = (r0 + 1) * w
    bottom = env.radiance[r1 + c0] * (1.0 - fx) + env.radiance[r1 + c1] * fx
    return top * (1.0 - fy) + bottom * fy


@wp.func
def env_radiance(env: EnvironmentData, d: wp.vec3) -> wp.vec3:
    if env.rotated == 1 or env.bilinear == 1:
        dl = local(env, d)
        if env.bilinear == 1:
            return bilinear(env, dl)
        return env.radiance[texel_index(env, dl)]
    return env.radiance[texel_index(env, d)]


@wp.func
def image_pdf(env: EnvironmentData, world: wp.vec3) -> float:
    d = local(env, world)
    # From the horizontal components: 1 - y^2 loses all precision near the poles in float32.
    sin_t = wp.sqrt(d[0] * d[0] + d[2] * d[2])
    if sin_t <= 0.0:
        return 0.0
    return env.texel_pdf[texel_index(env, d)] / (LATLONG_JACOBIAN * sin_t)


@wp.func
def search_cdf(cdf: wp.array(dtype=float), start: int, n: int, u: float) -> int:
    """The last bin i in [0, n) with cdf[start + i] <= u: never a bin of zero probability, since
    cdf[start + i + 1] > u (or i = n - 1, and cdf[start + n] = 1 > u)."""
    lo = int(0)
    hi = n - 1
    while lo < hi:
        mid = (lo + hi + 1) / 2
        if cdf[start + mid] <= u:
            lo = mid
        else:
            hi = mid - 1
    return lo


@wp.func
def sample_image(env: EnvironmentData, u: wp.vec2) -> wp.vec3:
    """A direction by PiecewiseConstant2D: a row by u[1], a column in it by u[0], uniform within
    the texel's (u, v) rectangle."""
    h = env.height
    w = env.width
    r = search_cdf(env.marginal, 0, h, u[1])
    m0 = env.marginal[r]
    dv = wp.clamp((u[1] - m0) / (env.marginal[r + 1] - m0), 0.0, 1.0)
    start = r * (w + 1)
    c = search_cdf(env.conditional, start, w, u[0])
    c0 = env.conditional[start + c]
    du = wp.clamp((u[0] - c0) / (env.conditional[start + c + 1] - c0), 0.0, 1.0)
    theta = (float(r) + dv) / float(h) * PI
    phi = (float(c) + du) / float(w) * 2.0 * PI
    s = wp.sin(theta)
    d = wp.vec3(s * wp.cos(phi), wp.cos(theta), s * wp.sin(phi))
    if env.rotated == 1:
        return env.to_world * d
    return d


def make_environment(strategy: Strategy) -> Environment:
    SAMPLER = strategy.environment_sampler
    POWER_PICK = selection_of(strategy).environment_share == "power"

    @wp.func
    def env_pick(env: EnvironmentData) -> float:
        if wp.static(POWER_PICK):
            return env.pick_power
        return env.pick_uniform

    @wp.func
    def env_pdf(env: EnvironmentData, n: wp.vec3, d: wp.vec3) -> float:
        if wp.static(SAMPLER == "uniform"):
            return INV_4PI
        if wp.static(SAMPLER == "cosine"):
            return wp.max(0.0, wp.dot(n, d)) * INV_PI
        return image_pdf(env, d)

    @wp.func
    def env_sample(env: EnvironmentData, n: wp.vec3, u: wp.vec2) -> EnvSample:
        es = EnvSample()
        wi = wp.vec3(0.0)
        if wp.static(SAMPLER == "uniform"):
            wi = square_to_uniform_sphere(u)
        elif wp.static(SAMPLER == "cosine"):
            wi = frame_to_world(square_to_cosine_hemisphere(u), n)
        else:
            wi = sample_image(env, u)
        # The density of the direction as evaluated (MIS evaluates the same at an escape).
        es.pdf = env_pdf(env, n, wi)
        es.wi = wi
        es.valid = int(es.pdf > 0.0)
        if es.valid == 1:
            es.radiance = env_radiance(env, wi)
        return es

    return Environment(env_pick=env_pick, env_radiance=env_radiance, env_sample=env_sample,
                       env_pdf=env_pdf)
