"""What the experiment code needs from the renderer, gathered in one injectable object.

The runner, the ground-truth builder and the config validator take a `Backend`; the default one wraps
the real Warp renderer. Tests inject a fake that returns ground truth plus noise of a known law.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable


@dataclass
class RenderResult:
    """The fields the runner reads from `render_with_stats`."""
    image: Any
    render_seconds: float
    compile_seconds: float = 0.0
    samples_per_second: float = 0.0


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


def default_backend(device: str = "cpu") -> Backend:
    from drtlab.kernels import CODE_VERSION
    from drtlab.kernels.render import compile_variants, render_with_stats
    from drtlab.kernels.scene_file import load_scene

    def render(scene, *, spp, sampler, integrator, seed, res, threads=None):
        return render_with_stats(scene, spp=spp, sampler=sampler, integrator=integrator, seed=seed,
                                 res=res, threads=threads, device=device, progress=False)

    def precompile(jobs, threads=None):
        return compile_variants(jobs, threads=threads, device=device)

    return Backend(load_scene=load_scene, render=render, code_version=CODE_VERSION,
                   name=f"warp-{device}", precompile=precompile)


def default_scene_loader():
    from drtlab.kernels.scene_file import load_scene
    return load_scene
