"""What the experiment code needs from the renderer, gathered in one injectable object.

The runner, the ground-truth builder and the config validator take a `Backend`; the default one wraps
the real Warp renderer. Tests inject a fake that returns ground truth plus noise of a known law.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

# The study estimate's speed probe (estimate.py): renders at a spp raised until one takes this long.
PROBE_SECONDS = 0.05


@dataclass
class RenderResult:
    """The fields the runner reads from `render_with_stats`."""
    image: Any
    render_seconds: float
    compile_seconds: float = 0.0
    samples_per_second: float = 0.0


@dataclass
class BatchResult:
    """The fields the runner reads from `render_batch_with_stats`: one image per seed."""
    images: Any                  # (R, H, W, 3)
    render_seconds: float        # wall seconds of the whole batch
    cpu_seconds: float           # CPU seconds of the render call, all threads
    compile_seconds: float = 0.0


@dataclass
class Backend:
    # load_scene(name_or_path, overrides) -> Scene; raises InputError on bad input
    load_scene: Callable[..., Any]
    # render(scene, spp=, sampler=, integrator=, seed=, res=, threads=) -> RenderResult-like
    render: Callable[..., Any]
    # hash of the kernel + estimator sources: a change invalidates ground truth and runs
    code_version: str
    name: str = "warp-cpu"
    # precompile(jobs, threads) -> facts: compile the variants of (scene, sampler, integrator) jobs
    # side by side before a sweep needs them one by one; None: nothing to compile (fakes)
    precompile: Callable[..., Any] | None = None
    # render_batch(scene, spp=, sampler=, integrator=, seeds=, res=, threads=) -> BatchResult-like;
    # None: `batch` renders the seeds one by one through `render` (fakes)
    render_batch: Callable[..., Any] | None = None
    # speed(scene, sampler, integrator, res, threads) -> samples per second, from a short probe
    # (the up-front estimate, study/estimate.py); None: not known (fakes)
    speed: Callable[..., Any] | None = None

    def batch(self, scene, *, spp, sampler, integrator, seeds, res, threads=None) -> BatchResult:
        """One render per seed, as one batch when the renderer can."""
        if self.render_batch is not None:
            return self.render_batch(scene, spp=spp, sampler=sampler, integrator=integrator,
                                     seeds=list(seeds), res=res, threads=threads)
        rs = [self.render(scene, spp=spp, sampler=sampler, integrator=integrator, seed=s, res=res,
                          threads=threads) for s in seeds]
        seconds = sum(float(r.render_seconds) for r in rs)
        import numpy as np
        return BatchResult(np.stack([np.asarray(r.image, dtype=np.float64) for r in rs]), seconds,
                           seconds, sum(float(getattr(r, "compile_seconds", 0.0)) for r in rs))


def default_backend(device: str = "cpu") -> Backend:
    from drtlab.kernels import CODE_VERSION
    from drtlab.kernels.render import compile_variants, render_batch_with_stats, render_with_stats
    from drtlab.kernels.scene_model.scene_file import load_scene

    def render(scene, *, spp, sampler, integrator, seed, res, threads=None):
        return render_with_stats(scene, spp=spp, sampler=sampler, integrator=integrator, seed=seed,
                                 res=res, threads=threads, device=device, progress=False)

    def render_batch(scene, *, spp, sampler, integrator, seeds, res, threads=None):
        return render_batch_with_stats(scene, seeds, spp=spp, sampler=sampler, integrator=integrator,
                                       res=res, threads=threads, device=device, progress=False)

    def precompile(jobs, threads=None):
        return compile_variants(jobs, threads=threads, device=device)

    def speed(scene, sampler, integrator, res, threads=None):
        from drtlab.kernels.render import measured_speed
        return measured_speed(scene, sampler, integrator, res=res, threads=threads, device=device,
                              probe_seconds=PROBE_SECONDS, full_size=True)

    return Backend(load_scene=load_scene, render=render, code_version=CODE_VERSION,
                   name=f"warp-{device}", precompile=precompile, render_batch=render_batch, speed=speed)
