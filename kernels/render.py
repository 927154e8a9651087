"""Render entry points: scene upload, kernel-variant cache and the tiled thread-pool launcher.

Determinism: a pixel's value is the float64 sum of its samples in index order, split into passes
whose boundaries depend only on spp; tiles cover disjoint pixels. Thread count and tile size decide
only who computes a pixel, never what it sums to.
"""
from __future__ import annotations

import math
import os
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace

import numpy as np

from drtlab.estimators.registry import SamplerSpec, parse_integrator, parse_sampler
from drtlab import fields
from drtlab.errors import InputError
from drtlab.kernels.colour import luminance
from drtlab.kernels.warp_runtime import warp as _wp
from drtlab.kernels.scene import Scene

# Samples per pixel per launch: bounds a launch's duration (progress, responsiveness) and fixes the
# float64 summation order independently of threads and tiles.
PASS_SAMPLES = 64
DEFAULT_TILE = 16
DEVICES = ("cpu", "cuda")

_lock = threading.Lock()
_kernels: dict = {}


@dataclass
class RenderStats:
    image: np.ndarray            # (H, W, 3) float64 linear radiance
    render_seconds: float
    compile_seconds: float
    spp: int
    width: int
    height: int
    sampler: str
    integrator: str
    seed: int
    variant: str
    threads: int
    device: str

    @property
    def samples_per_second(self) -> float:
        return self.width * self.height * self.spp / max(self.render_seconds, 1e-12)


def features_of(scene: Scene, integrator: str):
    from drtlab.kernels.tracer import Features
    kinds = frozenset(scene.materials[s.material].kind for s in scene.shapes)
    return Features(
        integrator=integrator,
        lens=scene.camera.has_lens and integrator != "whitted",
        motion=scene.has_motion and integrator != "whitted",
        spheres=any(s.kind == "sphere" for s in scene.shapes),
        quads=any(s.kind == "quad" for s in scene.shapes),
        kinds=kinds,
        checker=any(scene.materials[s.material].checker is not None for s in scene.shapes),
        area_lights=bool(scene.emitter_shapes()),
        point_lights=bool(scene.point_lights),
        dir_lights=bool(scene.directional_lights),
        roulette=scene.russian_roulette and integrator == "path",
        background=bool(np.any(np.asarray(scene.background) > 0)),
    )


def get_kernel(features, spec: SamplerSpec, device: str):
    """The compiled kernel for (features, sampler); compiled once per process, cached on disk."""
    wp = _wp()
    if features.integrator == "whitted":
        # Whitted reads no sampler: one variant serves every sampler name.
        spec = parse_sampler("uniform")
    key = (features, spec.pointset.name, spec.strategy.name, device)
    with _lock:
        entry = _kernels.get(key)
        if entry is None:
            from drtlab.kernels.tracer import build_kernel
            kernel = build_kernel(features, spec.pointset, spec.strategy)
            t0 = time.perf_counter()
            wp.load_module(kernel.module, device=device)
            entry = (kernel, time.perf_counter() - t0)
            _kernels[key] = entry
            return entry
    return entry[0], 0.0


def _f3(v) -> tuple:
    return tuple(float(x) for x in np.asarray(v, dtype=np.float64).reshape(3))


def _scene_extent(scene: Scene) -> float:
    pts = [scene.camera.position]
    for s in scene.shapes:
        if s.kind == "sphere":
            pts += [s.center - s.radius, s.center + s.radius]
        else:
            pts += [s.origin, s.origin + s.edge_u + s.edge_v, s.origin + s.edge_u,
                    s.origin + s.edge_v]
    pts = np.array(pts, dtype=np.float64)
    return float(np.linalg.norm(pts.max(axis=0) - pts.min(axis=0))) or 1.0


def upload(scene: Scene, device: str):
    """Pack a Scene into the kernel's SceneData struct (arrays on `device`)."""
    wp = _wp()
    from drtlab.kernels.scene import MATERIAL_KINDS
    from drtlab.kernels.tracer import WHITTED_SPLITS, SceneData

    def arr(values, dtype, empty_shape):
        a = np.asarray(values, dtype=np.float32 if dtype not in (int,) else np.int32)
        if a.size == 0:
            a = np.zeros(empty_shape, dtype=a.dtype)
        return wp.array(a, dtype=dtype, device=device)

    spheres = [s for s in scene.shapes if s.kind == "sphere"]
    quads = [s for s in scene.shapes if s.kind == "quad"]
    sphere_index = {id(s): i for i, s in enumerate(spheres)}
    quad_index = {id(s): i for i, s in enumerate(quads)}
    lights = scene.emitter_shapes()
    light_of = {id(scene.shapes[i]): li for li, i in enumerate(lights)}
    power = []
    for i in lights:
        s = scene.shapes[i]
        e = scene.materials[s.material].emission
        lum = luminance(e)
        power.append(max(lum, 1e-12) * s.area() * math.pi)
    pmf = np.array(power) / np.sum(power) if power else np.zeros(0)
    cdf = np.cumsum(pmf) if power else np.zeros(0)

    sd = SceneData()
    sd.sph_center = arr([s.center for s in spheres], wp.vec3, (1, 3))
    sd.sph_radius = arr([s.radius for s in spheres], float, (1,))
    sd.sph_velocity = arr([s.velocity for s in spheres], wp.vec3, (1, 3))
    sd.sph_material = arr([s.material for s in spheres], int, (1,))
    sd.sph_light = arr([light_of.get(id(s), -1) for s in spheres], int, (1,))
    sd.n_spheres = len(spheres)
    sd.quad_origin = arr([s.origin for s in quads], wp.vec3, (1, 3))
    sd.quad_u = arr([s.edge_u for s in quads], wp.vec3, (1, 3))
    sd.quad_v = arr([s.edge_v for s in quads], wp.vec3, (1, 3))
    normals = [np.cross(s.edge_u, s.edge_v) for s in quads]
    sd.quad_normal = arr([n / np.linalg.norm(n) for n in normals], wp.vec3, (1, 3))
    sd.quad_area = arr([np.linalg.norm(n) for n in normals], float, (1,))
    sd.quad_velocity = arr([s.velocity for s in quads], wp.vec3, (1, 3))
    sd.quad_material = arr([s.material for s in quads], int, (1,))
    sd.quad_light = arr([light_of.get(id(s), -1) for s in quads], int, (1,))
    sd.n_quads = len(quads)
    mats = scene.materials
    sd.mat_kind = arr([MATERIAL_KINDS.index(m.kind) for m in mats], int, (1,))
    sd.mat_albedo = arr([m.albedo for m in mats], wp.vec3, (1, 3))
    sd.mat_albedo2 = arr([m.albedo2 if m.albedo2 is not None else m.albedo for m in mats],
                         wp.vec3, (1, 3))
    sd.mat_checker = arr([m.checker if m.checker is not None else (0, 0) for m in mats],
                         wp.vec2, (1, 2))
    sd.mat_exponent = arr([m.exponent for m in mats], float, (1,))
    sd.mat_ior = arr([m.ior for m in mats], float, (1,))
    sd.mat_emission = arr([m.emission for m in mats], wp.vec3, (1, 3))
    kinds, shape_idx = [], []
    for i in lights:
        s = scene.shapes[i]
        kinds.append(0 if s.kind == "sphere" else 1)
        shape_idx.append(sphere_index[id(s)] if s.kind == "sphere" else quad_index[id(s)])
    sd.light_shape_kind = arr(kinds, int, (1,))
    sd.light_shape = arr(shape_idx, int, (1,))
    sd.light_pmf = arr(pmf, float, (1,))
    sd.light_cdf = arr(cdf, float, (1,))
    sd.n_lights = len(lights)
    sd.pl_position = arr([l.position for l in scene.point_lights], wp.vec3, (1, 3))
    sd.pl_intensity = arr([l.intensity for l in scene.point_lights], wp.vec3, (1, 3))
    sd.n_point_lights = len(scene.point_lights)
    sd.dl_direction = arr([l.direction for l in scene.directional_lights], wp.vec3, (1, 3))
    sd.dl_irradiance = arr([l.irradiance for l in scene.directional_lights], wp.vec3, (1, 3))
    sd.n_dir_lights = len(scene.directional_lights)
    sd.background = wp.vec3(*_f3(scene.background))
    sd.eps = float(1e-6 * _scene_extent(scene))

    cam = scene.camera
    pos = np.asarray(cam.position, dtype=np.float64)
    fwd = np.asarray(cam.look_at, dtype=np.float64) - pos
    fwd /= np.linalg.norm(fwd)
    right = np.cross(fwd, np.asarray(cam.up, dtype=np.float64))
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    sd.cam_position = wp.vec3(*_f3(pos))
    sd.cam_right = wp.vec3(*_f3(right))
    sd.cam_up = wp.vec3(*_f3(up))
    sd.cam_forward = wp.vec3(*_f3(fwd))
    half_h = math.tan(math.radians(cam.vfov_deg) / 2)
    sd.half_height = float(half_h)
    sd.half_width = float(half_h * scene.width / scene.height)
    sd.aperture = float(cam.aperture_radius)
    sd.focus_distance = float(cam.focus_distance if cam.focus_distance > 0 else 1.0)
    sd.shutter_open = float(cam.shutter[0])
    sd.shutter_close = float(cam.shutter[1])
    sd.width = int(scene.width)
    sd.height = int(scene.height)
    sd.max_depth = int(scene.max_depth)
    sd.rr_depth = int(scene.rr_depth)
    sd.whitted_codes = 1 << WHITTED_SPLITS if any(
        scene.materials[s.material].kind in ("dielectric", "glossy_dielectric") for s in scene.shapes) else 1
    return sd


def _resolve_scene(scene, res) -> Scene:
    if not isinstance(scene, Scene):
        from drtlab.kernels.scene_file import load_scene
        scene = load_scene(scene)
    if res is not None:
        w, h = fields.resolution(res, "res", aspect=scene.height / scene.width)
        scene = replace(scene, width=w, height=h)
    return scene


def render_with_stats(scene, spp=None, sampler="stratified", integrator=None, seed=0, res=None,
                      threads=None, tile=None, device="cpu", progress=None,
                      faults=()) -> RenderStats:
    """Render `scene` (a Scene, a built-in name or a .toml path); see `render`.

    `faults` (names from scene_data.FAULTS) compiles a deliberately wrong estimator: tests use it as
    the negative control that a statistical test must reject. Never set it for real renders.
    """
    spec = parse_sampler(sampler)
    scene = _resolve_scene(scene, res)
    integ = parse_integrator(integrator if integrator is not None else scene.integrator).name
    spp = fields.integer_in(scene.spp if spp is None else spp, "spp", 1, 2**31 - 1)
    seed = fields.integer_in(seed, "seed", 0, 2**32 - 1)
    threads = fields.integer_in((os.cpu_count() or 1) if threads is None else threads, "threads", 1, 1024)
    tile = fields.integer_in(DEFAULT_TILE if tile is None else tile, "tile", 1, 1 << 16)
    if device not in DEVICES:
        raise InputError("device", f"must be one of {', '.join(DEVICES)}, got {device!r}")
    if device == "cuda" and not _wp().is_cuda_available():
        raise InputError("device", "cuda requested but no CUDA device is available; use cpu")
    if scene.max_depth == -1 and not (scene.russian_roulette and integ == "path"):
        raise InputError("scene.max_depth", "-1 (unbounded) needs integrator path with "
                         "russian_roulette = true; use a depth >= 1")

    wp = _wp()
    features = features_of(scene, integ)
    if faults:
        from drtlab.kernels.device_scene import FAULTS
        unknown = sorted(set(faults) - set(FAULTS))
        if unknown:
            raise InputError("faults", f"unknown {unknown}; allowed: {', '.join(FAULTS)}")
        features = replace(features, faults=frozenset(faults))
    kernel, compile_s = get_kernel(features, spec, device)
    sd = upload(scene, device)
    W, H = scene.width, scene.height
    accum = wp.zeros(W * H, dtype=wp.vec3d, device=device)
    if device == "cpu":
        tiles = [(x, y, min(tile, W - x), min(tile, H - y))
                 for y in range(0, H, tile) for x in range(0, W, tile)]
    else:
        tiles = [(0, 0, W, H)]
    passes = [(i, min(PASS_SAMPLES, spp - i)) for i in range(0, spp, PASS_SAMPLES)]
    if progress is None:
        progress = W * H * spp > 4_000_000
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(total=len(passes) * len(tiles), desc=f"render {scene.name}", unit="tile",
                   leave=False)

    def launch(t, index0, count):
        x0, y0, tw, th = t
        wp.launch(kernel, dim=tw * th, device=device,
                  inputs=[sd, wp.uint32(seed), index0, count, spp, x0, y0, tw, th, accum])

    t0 = time.perf_counter()
    pool = ThreadPoolExecutor(max_workers=threads) if device == "cpu" and threads > 1 else None
    try:
        for index0, count in passes:
            if pool is None:
                for t in tiles:
                    launch(t, index0, count)
                    if bar:
                        bar.update(1)
            else:
                for fut in [pool.submit(launch, t, index0, count) for t in tiles]:
                    fut.result()
                    if bar:
                        bar.update(1)
        wp.synchronize_device(device)
    finally:
        if pool is not None:
            pool.shutdown()
        if bar is not None:
            bar.close()
    elapsed = time.perf_counter() - t0
    image = accum.numpy().reshape(H, W, 3) / float(spp)
    return RenderStats(image=image, render_seconds=elapsed, compile_seconds=compile_s, spp=spp,
                       width=W, height=H, sampler=spec.name, integrator=integ, seed=seed,
                       variant=features.key(), threads=threads, device=device)


def render(scene, spp=None, sampler="stratified", integrator=None, seed=0, res=None,
           threads=None, tile=None, device="cpu", progress=None, faults=()) -> np.ndarray:
    """Render and return (H, W, 3) float64 linear radiance, the per-pixel mean of `spp` samples.

    The same arguments give a bit-identical image whatever `threads`, `tile` or the process.
    """
    return render_with_stats(scene, spp=spp, sampler=sampler, integrator=integrator, seed=seed,
                             res=res, threads=threads, tile=tile, device=device,
                             progress=progress, faults=faults).image
