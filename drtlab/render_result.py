"""One render as `drtlab.render(..., stats=True)` returns it and `drtlab render` writes it: the image,
its standard error, how long it took and the metadata its EXR carries (`drtlab:*` attributes).

Whitted renders read no sampler: their metadata says `sampler = none` (one kernel serves every
sampler name), so a file never claims an estimator that did not run.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from drtlab.errors import InputError
from drtlab.estimators.defaults import DEFAULT_SAMPLER

NO_SAMPLER = "none"


@dataclass
class RenderResult:
    """A finished render.

    `image` is (H, W, 3) float64 linear radiance, the per-pixel mean of `spp` samples; `stderr` the
    standard error of each pixel's mean, sqrt(sample variance / spp), when rendered with
    `variance=True` (exact for independent point sets, an upper bound for stratified ones), else
    None. `seconds` is the time of the kernel launches alone, `compile_seconds` the kernel's compile
    (0 when cached), `wall_seconds` the whole call. `metadata` holds what `drtlab render` writes
    into the EXR: scene, scene_hash, spp, sampler, integrator, seed, resolution, version,
    code_version, variant, device and the three times (and seconds_budget for a time-budget
    render). `stats` is the renderer's own record
    (`drtlab.kernels.render.RenderStats`: variance, variant, threads)."""
    image: np.ndarray
    stderr: np.ndarray | None
    seconds: float
    compile_seconds: float
    wall_seconds: float
    spp: int
    metadata: dict
    stats: object

    @property
    def samples_per_second(self) -> float:
        """Samples traced per second of launches (pixels x spp / seconds)."""
        return self.stats.samples_per_second

    def write_exr(self, path) -> list[Path]:
        """The image as a float32 EXR with `metadata`, and beside it PATH.stderr.exr when there is
        a standard error; returns the paths written."""
        import os

        from drtlab.fields import output_files
        from drtlab.kernels.imageio import write_exr
        if not isinstance(path, (str, os.PathLike)) or not str(path):
            raise InputError("path", f"must be a file path ending in .exr, got {path!r}")
        path = Path(path)
        if path.suffix.lower() != ".exr":
            raise InputError("path", f"must be a file path ending in .exr, got {str(path)!r}")
        # Both names checked before either is written: no image without its standard error.
        output_files([path, *([stderr_path(path)] if self.stderr is not None else [])], "path")
        write_exr(path, self.image, self.metadata)
        written = [path]
        if self.stderr is not None:
            se_path = stderr_path(path)
            write_exr(se_path, self.stderr, dict(self.metadata, what="standard error of each pixel's "
                                                 "mean, sqrt(sample variance / spp)"))
            written.append(se_path)
        return written


def stderr_path(path: Path) -> Path:
    """Where the standard error of the image at `path` goes (and where `compare` looks for it)."""
    return path.with_name(path.stem + ".stderr.exr")


def sampler_label(sampler: str, integrator: str) -> str:
    """The sampler a render's records name: none for Whitted, which reads no random numbers."""
    return NO_SAMPLER if integrator == "whitted" else sampler


def render_result(scene, spp=None, sampler: str = DEFAULT_SAMPLER, integrator=None, seed=0, res=None,
                  threads=None, tile=None, device="cpu", progress=None, *, variance: bool = False,
                  overrides: dict | None = None, seconds: float | None = None) -> RenderResult:
    """Render `scene` (a Scene, a built-in name, a .toml path or a dict shaped like a scene file,
    with dotted-key `overrides`) and return a RenderResult; the image is bit-identical to
    `drtlab.render` with the same arguments (`kernels.render.render`'s, in its order). With
    `seconds` instead of `spp`: as many whole passes as fit in that time
    (`kernels.render.render_for_seconds`); `spp` and the metadata say how many."""
    from drtlab.kernels import render as R
    t0 = time.perf_counter()
    scene = _scene(scene, overrides)
    common = dict(sampler=sampler, integrator=integrator, seed=seed, res=res, threads=threads,
                  tile=tile, device=device, progress=progress, variance=variance)
    if seconds is None:
        stats = R.render_with_stats(scene, spp=spp, **common)
    elif spp is not None:
        raise InputError("seconds", "give spp or seconds, not both")
    else:
        stats = R.render_for_seconds(scene, seconds, **common)
    return result_of(scene, stats, time.perf_counter() - t0, seconds_budget=seconds)


def result_of(scene, stats, wall_seconds: float, seconds_budget: float | None = None) -> RenderResult:
    """The RenderResult of `stats` (a kernels.render.RenderStats) rendered from `scene`, within
    `seconds_budget` when it was a time-budget render."""
    from drtlab.version import __version__
    from drtlab.kernels import CODE_VERSION
    meta = {"scene": scene.name, "scene_hash": scene.content_hash(), "spp": stats.spp,
            "sampler": sampler_label(stats.sampler, stats.integrator),
            "integrator": stats.integrator, "seed": stats.seed,
            "resolution": f"{stats.width}x{stats.height}", "version": __version__,
            "code_version": CODE_VERSION, "variant": stats.variant, "device": stats.device,
            "wall_seconds": round(wall_seconds, 4), "render_seconds": round(stats.render_seconds, 4),
            "compile_seconds": round(stats.compile_seconds, 4)}
    if seconds_budget is not None:
        meta["seconds_budget"] = seconds_budget
    return RenderResult(image=stats.image, stderr=stats.stderr, seconds=stats.render_seconds,
                        compile_seconds=stats.compile_seconds, wall_seconds=wall_seconds,
                        spp=stats.spp, metadata=meta, stats=stats)


def _scene(scene, overrides):
    from drtlab.kernels.scene_model.scene import Scene
    from drtlab.kernels.scene_model.scene_file import load_scene, scene_from_dict
    if isinstance(scene, Scene):
        if overrides:
            from drtlab.errors import InputError
            raise InputError("overrides", "apply overrides when loading the scene "
                                          "(drtlab.load_scene(name, overrides)), not to a loaded Scene")
        return scene
    if isinstance(scene, dict):
        return scene_from_dict(scene, overrides=overrides)
    return load_scene(scene, overrides)
