"""Render entry points: the tiled thread-pool launcher (its kernels: kernels/variants.py).

Determinism: a pixel's value is the float64 sum of its samples in index order, split into passes
whose boundaries depend only on spp; tiles cover disjoint pixels. Thread count and tile size decide
only who computes a pixel, never what it sums to.
"""
from __future__ import annotations

import os
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace

import numpy as np

from drtlab.estimators.registry import DEFAULT_SAMPLER, SamplerSpec, parse_integrator, parse_sampler
from drtlab import fields
from drtlab.errors import InputError
from drtlab.kernels.scene_upload import upload, uses_vector_quads
from drtlab.kernels.variants import get_gather, get_kernel, variant_key
from drtlab.kernels.features import (FAULTS, FILTER_FAULTS, MASK_FAULTS, MESH_FAULTS, REPEATS,
                                     SPHERICAL_FAULTS, VARIANCE_FAULTS, Features, features_of, grown_margin)
from drtlab.kernels.filters import BOX
from drtlab.kernels.launch_pool import launch_pool
from drtlab.kernels.scene_model.scene import Scene
from drtlab.warp_runtime import warp as _wp

# Samples per pixel per launch: bounds a launch's duration (progress, responsiveness) and fixes the
# float64 summation order independently of threads and tiles.
PASS_SAMPLES = 64
DEFAULT_TILE = 16
DEVICES = ("cpu", "cuda")

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
    # (H, W, 3) unbiased per-pixel variance of one sample (render(..., variance=True)), else None.
    # Its standard error of the mean, sqrt(variance / spp), is exact for independent point sets and
    # an upper bound for stratified ones (strata remove variance that the sample variance counts).
    variance: np.ndarray | None = None

    @property
    def stderr(self) -> np.ndarray | None:
        """(H, W, 3) standard error of each pixel's mean, from `variance`."""
        return None if self.variance is None else np.sqrt(self.variance / self.spp)

    @property
    def samples_per_second(self) -> float:
        return self.width * self.height * self.spp / max(self.render_seconds, 1e-12)


def render_features(scene: Scene, integrator: str, spec: SamplerSpec,
                    device: str = "cpu") -> Features:
    """The features of rendering `scene` with `integrator` and the sampler `spec` on `device`: the
    scene's, plus the pixel filter's estimator (splatting only for a filter other than the box, for
    which both estimators are today's pixel) and, on the CPU, the vector quad test."""
    f = features_of(scene, integrator)
    if f.filter != BOX and f.whitted:
        raise InputError("camera.filter", f"'{f.filter}' needs a stochastic integrator (drt or path): "
                                          "whitted samples a fixed sub-pixel grid of the box pixel")
    return replace(f, splat=spec.splat and f.filter != BOX,
                   quad_simd=uses_vector_quads(scene, device))


def compile_variants(jobs, threads: int | None = None, device: str = "cpu") -> dict:
    """Compile (or load from Warp's cache) the kernel variants of `jobs`, (scene, sampler, integrator)
    triples, on `threads` threads at once: a cold experiment's compiles are most of its first minute,
    and one compile keeps one core busy. Returns {"variants", "compiled", "wall_seconds",
    "compile_seconds" (their sum), "threads"}."""
    threads = fields.integer_in((os.cpu_count() or 1) if threads is None else threads, "threads", 1, 1024)
    keys = {}
    for scene, sampler, integrator in jobs:
        spec, scene, integ = _resolve_job(scene, sampler, integrator, None)
        f = render_features(scene, integ, spec, device)
        keys.setdefault(variant_key(f.code_key(), spec, device), (f, spec))
    t0 = time.perf_counter()

    def compile_one(fs):
        gather = get_gather(fs[0], device)[1] if fs[0].splat else 0.0
        return get_kernel(fs[0], fs[1], device)[1] + gather

    with ThreadPoolExecutor(max_workers=threads, thread_name_prefix="drtlab-compile") as pool:
        seconds = list(pool.map(compile_one, keys.values()))
    return {"variants": len(keys), "compiled": sum(1 for x in seconds if x > 0.2),
            "wall_seconds": time.perf_counter() - t0, "compile_seconds": sum(seconds),
            "threads": threads}


# Buffers per pixel: the float64 sums (24 bytes, 48 with moments) on the device, and on the host the
# copy, the mean image and the caller's float32 EXR (about 24 + 24 + 12 bytes more).
_BYTES_PER_PIXEL = 24 + 24 + 24 + 12
MAX_PIXELS = 2**28      # a Warp launch's thread count and array shape stay far below int32 limits


def check_image_size(width: int, height: int, moments: bool = False, field: str = "res",
                     repetitions: int = 1, splat_samples: int = 0, margin: int = 0,
                     reach: int | None = None) -> None:
    """Refuse, before compiling or rendering, an image (or a batch of `repetitions` images) whose
    buffers cannot fit in this machine (splatting also keeps `splat_samples` samples of every pixel
    of the image grown by `margin`: radiance and 2 (2 reach + 1) profile values, float32, `reach`
    the filter's margin, `margin` unless the filter is cut at the film's edge)."""
    reach = margin if reach is None else reach
    pixels = width * height * repetitions
    need = pixels * (_BYTES_PER_PIXEL + (48 if moments else 0))
    if splat_samples:
        need += (width + 2 * margin) * (height + 2 * margin) * repetitions * (4 * (3 + 4 * reach + 2) * splat_samples + 8)
    try:
        memory = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        memory = 1 << 40
    if pixels > MAX_PIXELS or need > 0.5 * memory:
        what = f"{width}x{height}" + (f" x {repetitions} repetitions" if repetitions > 1 else "")
        raise InputError(field, f"{what} is {pixels:,} pixels and needs about "
                                f"{need / 2**30:.1f} GiB of image buffers; the limits are "
                                f"{MAX_PIXELS:,} pixels and half of this machine's "
                                f"{memory / 2**30:.1f} GiB of memory")


def resolve_scene(scene, res) -> Scene:
    if not isinstance(scene, Scene):
        from drtlab.kernels.scene_model.scene_file import load_scene
        scene = load_scene(scene)
    if res is not None:
        w, h = fields.resolution(res, "res", aspect=scene.height / scene.width)
        scene = replace(scene, width=w, height=h)
    return scene


def _resolve_job(scene, sampler, integrator: str | None, res) -> tuple:
    """(sampler spec, Scene at `res`, integrator name) of a render's arguments; `sampler` is a name
    or a SamplerSpec (a tool's own point set, outside the registry: `drtlab sources`' pickfreeze)."""
    spec = sampler if isinstance(sampler, SamplerSpec) else parse_sampler(sampler)
    scene = resolve_scene(scene, res)
    return spec, scene, parse_integrator(integrator if integrator is not None else scene.integrator).name


@dataclass
class BatchStats:
    """Repetitions of one render, one per seed: `images[r]` is bit-identical to the image of
    `render(..., seed=seeds[r])`."""
    images: np.ndarray           # (R, H, W, 3) float64 linear radiance
    render_seconds: float        # wall time of the launches (all repetitions together)
    cpu_seconds: float           # CPU time of this process during them (all threads)
    compile_seconds: float
    spp: int
    width: int
    height: int
    sampler: str
    integrator: str
    seeds: tuple
    variant: str
    threads: int
    device: str
    variances: np.ndarray | None = None     # (R, H, W, 3) per-sample variance, with variance=True

    @property
    def samples_per_second(self) -> float:
        return len(self.seeds) * self.width * self.height * self.spp / max(self.render_seconds, 1e-12)


def _check_seed(seed, field: str = "seed") -> int:
    return fields.integer_in(seed, field, 0, fields.MAX_SEED)


def render_with_stats(scene, spp=None, sampler=DEFAULT_SAMPLER, integrator=None, seed=0, res=None,
                      threads=None, tile=None, device="cpu", progress=None,
                      faults=(), variance=False, watch=None) -> RenderStats:
    """Render `scene` (a Scene, a built-in name or a .toml path); see `render`.

    `faults` (names from features.FAULTS, MESH_FAULTS, SPHERICAL_FAULTS, VARIANCE_FAULTS or MASK_FAULTS) compiles a
    deliberately wrong estimator: tests use it as the negative control that a statistical test must
    reject; names from features.REPEATS compile
    the profile's probes (`profile_kernels components`). Never set it for real renders.
    `variance` also sums the samples' squares (same samples, same mean image) for `stats.variance`.
    `watch(fraction, seconds)`, if given, is called after every launch with the fraction of the
    launches done and the seconds since the first (what a caller needs to foresee the whole).
    """
    seed = _check_seed(seed)
    b = render_batch_with_stats(scene, [seed], spp=spp, sampler=sampler, integrator=integrator,
                                res=res, threads=threads, tile=tile, device=device,
                                progress=progress, faults=faults, variance=variance, watch=watch)
    return RenderStats(image=b.images[0], render_seconds=b.render_seconds,
                       compile_seconds=b.compile_seconds, spp=b.spp, width=b.width, height=b.height,
                       sampler=b.sampler, integrator=b.integrator, seed=seed, variant=b.variant,
                       threads=b.threads, device=b.device,
                       variance=None if b.variances is None else b.variances[0])


def render_batch_with_stats(scene, seeds, spp=None, sampler=DEFAULT_SAMPLER, integrator=None, res=None,
                            threads=None, tile=None, device="cpu", progress=None, faults=(),
                            variance=False, watch=None) -> BatchStats:
    """Render one repetition of `scene` per seed of `seeds`, all in the same launches (a launch
    covers every repetition of a tile: short renders stop paying per-call overhead, and a GPU is
    filled by one launch). Repetition r is bit-identical to `render(..., seed=seeds[r])` whatever
    the batch, `threads` and `tile`."""
    spec, scene, integ = _resolve_job(scene, sampler, integrator, res)
    spp = fields.integer_in(scene.spp if spp is None else spp, "spp", 1, fields.MAX_COUNT)
    if isinstance(seeds, (str, bytes)) or not hasattr(seeds, "__len__") or len(seeds) == 0:
        raise InputError("seeds", f"must be a non-empty list of integers in [0, {fields.MAX_SEED}], got {seeds!r}")
    seeds = tuple(_check_seed(s, "seeds") for s in seeds)
    threads = fields.integer_in((os.cpu_count() or 1) if threads is None else threads, "threads", 1, 1024)
    tile = fields.integer_in(DEFAULT_TILE if tile is None else tile, "tile", 1, 1 << 16)
    if device not in DEVICES:
        raise InputError("device", f"must be one of {', '.join(DEVICES)}, got {device!r}")
    if device == "cuda" and not _wp().is_cuda_available():
        raise InputError("device", "cuda requested but no CUDA device is available; use cpu")
    features = render_features(scene, integ, spec, device)
    if variance and features.splat:
        raise InputError("variance", "is not defined for the splatting estimator (a pixel is a ratio "
                                     "over its neighbours' samples); use the +fis estimator")
    if scene.max_depth == -1 and not features.roulette:
        raise InputError("scene.max_depth", "-1 (unbounded) needs integrator path with "
                         "russian_roulette = true; use a depth >= 1")

    wp = _wp()
    if faults:
        allowed = FAULTS + MESH_FAULTS + FILTER_FAULTS + SPHERICAL_FAULTS + VARIANCE_FAULTS + MASK_FAULTS + REPEATS
        unknown = sorted(set(faults) - set(allowed))
        if unknown:
            raise InputError("faults", f"unknown {unknown}; allowed: {', '.join(allowed)}")
        features = replace(features, faults=frozenset(faults))
    if variance:
        features = replace(features, moments=True)
    R, W, H = len(seeds), scene.width, scene.height
    # Splatting traces the image grown by the filter's margin and keeps a pass's samples.
    m = grown_margin(features)
    K = 2 * features.filter_def.margin + 1 if features.splat else 1
    pass_samples = min(PASS_SAMPLES, spp) if features.splat else 0
    check_image_size(W, H, moments=bool(variance), repetitions=R, splat_samples=pass_samples,
                     margin=m, reach=(K - 1) // 2)
    kernel, compile_s = get_kernel(features, spec, device)
    gather = None
    if features.splat:
        gather, gather_s = get_gather(features, device)
        compile_s += gather_s
    sd = upload(scene, device)
    from drtlab.kernels.render_kernel import PixelSums
    sums = PixelSums()
    sums.seeds = wp.array(np.asarray(seeds, dtype=np.uint32), dtype=wp.uint32, device=device)
    sums.total = wp.zeros(R * W * H, dtype=wp.vec3d, device=device)
    sums.squares = wp.zeros(R * W * H if variance else 1, dtype=wp.vec3d, device=device)
    grown = R * (W + 2 * m) * (H + 2 * m) * pass_samples if features.splat else 1
    sums.splat_f = wp.zeros(grown * 2 * K if features.splat else 1, dtype=float, device=device)
    sums.splat_L = wp.zeros(grown, dtype=wp.vec3, device=device)
    sums.weight = wp.zeros(R * W * H if features.splat else 1, dtype=wp.float64, device=device)
    tiles = _tiles(W + 2 * m, H + 2 * m, tile, device)
    gather_tiles = _tiles(W, H, tile, device) if features.splat else []
    passes = [(i, min(PASS_SAMPLES, spp - i)) for i in range(0, spp, PASS_SAMPLES)]
    bar = _progress_bar(R * W * H * spp > 4_000_000 if progress is None else progress,
                        len(passes) * len(tiles), scene.name)

    def launch(t, index0, count):
        x0, y0, tw, th = t
        wp.launch(kernel, dim=R * tw * th, device=device,
                  inputs=[sd, index0, count, spp, x0, y0, tw, th, sums])

    def launch_gather(t, count):
        x0, y0, tw, th = t
        wp.launch(gather, dim=R * tw * th, device=device, inputs=[sd, count, x0, y0, tw, th, sums])

    launches, done = len(passes) * len(tiles), 0

    def tile_done():
        nonlocal done
        done += 1
        if bar:
            bar.update(1)
        if watch is not None:
            watch(done / launches, time.perf_counter() - t0)

    t0, c0 = time.perf_counter(), time.process_time()
    pool = launch_pool(threads) if device == "cpu" and threads > 1 else None
    try:
        for index0, count in passes:
            if pool is None:
                for t in tiles:
                    launch(t, index0, count)
                    tile_done()
                for t in gather_tiles:      # after every tile of the pass: it reads their samples
                    launch_gather(t, count)
            else:
                for fut in [pool.submit(launch, t, index0, count) for t in tiles]:
                    fut.result()
                    tile_done()
                for fut in [pool.submit(launch_gather, t, count) for t in gather_tiles]:
                    fut.result()
        wp.synchronize_device(device)
    finally:
        if bar is not None:
            bar.close()
    elapsed, cpu = time.perf_counter() - t0, time.process_time() - c0
    total = sums.total.numpy().reshape(R, H, W, 3)        # a view of the sums (CPU), not a copy
    var = _sample_variance(total, sums.squares.numpy().reshape(R, H, W, 3), spp) if variance else None
    if features.splat:
        images = splat_ratio(total, sums.weight.numpy().reshape(R, H, W, 1))
    else:
        # Divided in place: a batch's images are the buffer's size again, which a 1-spp batch would
        # pay as an allocation and a pass over memory per call (on CUDA numpy() is a copy already).
        images = np.divide(total, float(spp), out=total if device == "cpu" else None)
    return BatchStats(images=images, render_seconds=elapsed, cpu_seconds=cpu, compile_seconds=compile_s,
                      spp=spp, width=W, height=H, sampler=spec.name, integrator=integ, seeds=seeds,
                      variant=features.key(), threads=threads, device=device, variances=var)


def splat_ratio(total: np.ndarray, weight: np.ndarray) -> np.ndarray:
    """sum f L / sum f per pixel; 0 where the filter weights sum to <= 0 (only a negative-lobed
    filter at very low spp can get there: the pixel is then undefined, and black is the choice)."""
    ok = weight > 0.0
    return np.where(ok, total / np.where(ok, weight, 1.0), 0.0)


def _progress_bar(show: bool, launches: int, name: str):
    """A tqdm bar over the launches, or None."""
    if not show:
        return None
    from tqdm import tqdm
    return tqdm(total=launches, desc=f"render {name}", unit="tile", leave=False)


def _tiles(width: int, height: int, tile: int, device: str) -> list[tuple]:
    """(x0, y0, w, h) of each tile: square tiles on the CPU's thread pool, one launch on a GPU."""
    if device != "cpu":
        return [(0, 0, width, height)]
    return [(x, y, min(tile, width - x), min(tile, height - y))
            for y in range(0, height, tile) for x in range(0, width, tile)]


def _sample_variance(total: np.ndarray, squares: np.ndarray, spp: int) -> np.ndarray:
    """Unbiased per-pixel variance of one sample from the sums of the samples and of their squares."""
    if spp < 2:
        return np.full_like(total, np.nan)
    return np.maximum(squares - total * (total / float(spp)), 0.0) / (spp - 1)


def render(scene, spp=None, sampler=DEFAULT_SAMPLER, integrator=None, seed=0, res=None,
           threads=None, tile=None, device="cpu", progress=None, faults=()) -> np.ndarray:
    """Render and return (H, W, 3) float64 linear radiance, the per-pixel mean of `spp` samples.

    The same arguments give a bit-identical image whatever `threads`, `tile` or the process.
    """
    return render_with_stats(scene, spp=spp, sampler=sampler, integrator=integrator, seed=seed,
                             res=res, threads=threads, tile=tile, device=device,
                             progress=progress, faults=faults).image


def render_batch(scene, seeds, spp=None, sampler=DEFAULT_SAMPLER, integrator=None, res=None,
                 threads=None, tile=None, device="cpu", progress=None) -> np.ndarray:
    """(R, H, W, 3) float64: one render per seed of `seeds`, rendered together; image r is
    bit-identical to `render(scene, spp=spp, sampler=sampler, seed=seeds[r], ...)`."""
    return render_batch_with_stats(scene, seeds, spp=spp, sampler=sampler, integrator=integrator,
                                   res=res, threads=threads, tile=tile, device=device,
                                   progress=progress).images


# ---------------------------------------------------------------------------------------------------
# Time: this machine's speed on a scene, and renders to a time budget
# ---------------------------------------------------------------------------------------------------

PROBE_WIDTH = 48            # a speed probe renders the scene this wide (or narrower), same aspect
PROBE_SECONDS = 0.2         # ... at a spp raised until one probe takes about this long


def measured_speed(scene, sampler=DEFAULT_SAMPLER, integrator=None, res=None, threads=None,
                   tile=None, device="cpu", probe_seconds: float = PROBE_SECONDS,
                   full_size: bool = False) -> float:
    """Samples per second of `scene` (at `res`) rendered here: short renders at PROBE_WIDTH pixels
    wide (with `full_size`, at the whole resolution), spp raised until one takes `probe_seconds`;
    they compile the kernel the render needs. A smaller image pays more per-launch overhead per
    sample, so the speed errs low."""
    spec, scene, integ = _resolve_job(scene, sampler, integrator, res)
    width = scene.width if full_size else min(scene.width, PROBE_WIDTH)
    probe = (width, max(1, round(width * scene.height / scene.width)))
    spp = 1
    while True:
        st = render_with_stats(scene, spp=spp, sampler=sampler, integrator=integ, res=probe,
                               threads=threads, tile=tile, device=device, progress=False)
        if st.render_seconds >= probe_seconds or spp >= 1 << 16:
            return st.samples_per_second
        spp *= int(min(64, max(2, probe_seconds / max(st.render_seconds, 1e-4))))


def render_for_seconds(scene, seconds: float, sampler=DEFAULT_SAMPLER, integrator=None, seed=0,
                       res=None, threads=None, tile=None, device="cpu", progress=None,
                       variance=False) -> RenderStats:
    """As many whole passes (PASS_SAMPLES samples per pixel each, at least one) as fit in `seconds`
    of rendering, Mitsuba's `timeout` for equal-time comparisons: the kernel is compiled and the
    speed measured at the full resolution first (not counted), then the render is
    render_with_stats(..., spp=passes * PASS_SAMPLES), bit for bit; `stats.spp` is the spp reached.
    Every point set stratifies for the spp it gets, which a render stopped mid-way could not give
    it. (Counting the compile and a speed probe on a smaller image, a 1 s budget rendered 0.23 s.)"""
    seconds = fields.budget_seconds(seconds, "seconds")
    _, resolved, integ = _resolve_job(scene, sampler, integrator, res)
    # The first probe compiles; the speed comes from the later ones (5% of the budget, at most
    # PROBE_SECONDS each).
    speed = measured_speed(resolved, sampler, integ, None, threads, tile, device,
                           probe_seconds=min(PROBE_SECONDS, 0.05 * seconds), full_size=True)
    per_pass = resolved.width * resolved.height * PASS_SAMPLES
    passes = max(1, min(round(seconds * speed / per_pass), fields.MAX_COUNT // PASS_SAMPLES))
    return render_with_stats(resolved, spp=passes * PASS_SAMPLES, sampler=sampler,
                             integrator=integ, seed=seed, threads=threads, tile=tile, device=device,
                             progress=progress, variance=variance)
