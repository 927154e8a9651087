"""drtlab: Monte Carlo estimator variance studies for distribution ray tracing.

The Python API a notebook needs; each name imports its layer (and Warp) only when first called:

    import drtlab
    scene = drtlab.load_scene("glossy", {"scene.resolution": [64, 48]})
    image = drtlab.render(scene, spp=64, sampler="stratified+importance")      # (H, W, 3) float64
    r = drtlab.render(scene, spp=64, stats=True, variance=True)    # RenderResult: image, stderr,
    r.seconds, r.samples_per_second, r.metadata                    # timings, the EXR's metadata
    drtlab.write_exr("x.exr", r.image, r.metadata); pixels, meta = drtlab.read_exr("x.exr")
    images = drtlab.render_batch(scene, seeds=range(16), spp=4)               # (16, H, W, 3)
    result = drtlab.run_experiment("stratified")          # or a dict shaped like an experiment file
    result.cells, result.slopes, result.comparisons, result.plot_convergence()
    result = drtlab.open_results("results/stratified")    # a finished folder: nothing re-run
    drtlab.register_pointset(drtlab.pointset_from_table("mysobol", table))   # your own point set
    drtlab.register_light_selection(drtlab.LightSelection("nearest", ..., pick, pmf))
    drtlab.register_lobe_sampler(drtlab.LobeSampler("wide", ..., "glossy", sample, pdf))
    drtlab.register_strategy("importance-nearest", "...", like="importance", light_selection="nearest",
                             lobe_samplers=["wide"])
    drtlab.register_metric("edge-mse", per_run)   # a study's error: per_run(images, ref, ref_stderr)
    drtlab.load_plugin("my_sets.py")                      # a file that registers some

The top-level folders are mapped under this package: `drtlab.estimators`, `drtlab.kernels`,
`drtlab.experiments` (see pyproject.toml).
"""
__version__ = "0.1.0"


def render(scene, *args, stats: bool = False, variance: bool = False, seconds: float | None = None,
           **kwargs):
    """`drtlab.kernels.render.render`: (H, W, 3) float64 linear radiance of a scene. With
    `stats=True`, a `RenderResult` instead (the same image, its standard error when `variance`,
    seconds, samples per second, metadata); `scene` may then also be a dict shaped like a scene
    file. `seconds=T` instead of `spp`: as many whole passes of 64 spp as fit in T seconds (the
    RenderResult's spp says how many). The default sampler is `drtlab.DEFAULT_SAMPLER`, the command
    line's."""
    if variance and not stats:
        from drtlab.errors import InputError
        raise InputError("variance", "the standard error comes with the RenderResult: pass "
                                     "stats=True as well")
    if stats or seconds is not None:
        from drtlab.render_result import render_result
        result = render_result(scene, *args, variance=variance, seconds=seconds, **kwargs)
        return result if stats else result.image
    from drtlab.kernels.render import render as _render
    return _render(scene, *args, **kwargs)


def write_exr(path, image, metadata: dict | None = None) -> None:
    """A float32 EXR of `image` (H, W, C), with `metadata` as drtlab:* attributes, written atomically."""
    from drtlab.kernels.imageio import write_exr as _write_exr
    _write_exr(path, image, metadata)


def read_exr(path):
    """(pixels as float32 (H, W, C), drtlab metadata) of an EXR (e.g. one `drtlab render` wrote)."""
    from drtlab.kernels.imageio import read_exr as _read_exr
    return _read_exr(path)


def __getattr__(name: str):
    # Lazy, so that `import drtlab` imports neither numpy-heavy modules nor Warp.
    if name == "RenderResult":
        from drtlab.render_result import RenderResult
        return RenderResult
    if name == "PointSet":
        from drtlab.estimators.pointsets.base import PointSet
        return PointSet
    if name == "LightSelection":
        from drtlab.kernels.light_selection import LightSelection
        return LightSelection
    if name == "LobeSampler":
        from drtlab.kernels.lobe_samplers import LobeSampler
        return LobeSampler
    if name == "DEFAULT_SAMPLER":
        from drtlab.estimators.defaults import DEFAULT_SAMPLER
        return DEFAULT_SAMPLER
    raise AttributeError(f"module 'drtlab' has no attribute {name!r}")


def render_batch(*args, **kwargs):
    """`drtlab.kernels.render.render_batch`: (R, H, W, 3) float64, one render per seed, rendered
    together; image r is bit-identical to `render(..., seed=seeds[r])`."""
    from drtlab.kernels.render import render_batch as _render_batch
    return _render_batch(*args, **kwargs)


def load_scene(scene, overrides: dict | None = None):
    """A validated Scene from a built-in name, a .toml (or Mitsuba 3 .xml) path, or a dict shaped like
    a scene file, with dotted-key `overrides` ({"camera.fov": 30, "shapes[0].radius": 0.5})."""
    from drtlab.kernels.scene_model.scene_file import load_scene as _load_scene, scene_from_dict
    if isinstance(scene, dict):
        return scene_from_dict(scene, overrides=overrides)
    return _load_scene(scene, overrides)


def load_experiment(*args, **kwargs):
    """`drtlab.experiments.study.config.load_experiment`: a built-in name or .toml path -> an Experiment."""
    from drtlab.experiments.study.config import load_experiment as _load_experiment
    return _load_experiment(*args, **kwargs)


def run_experiment(experiment, profile: str = "quick", name: str = "inline", **kwargs):
    """Run (or resume) an experiment: ground truth, runs, analysis, report.

    `experiment` is an `Experiment` (from `load_experiment`), a built-in name, a .toml path, or a dict
    shaped like the TOML file (then called `name`; its results go to results/NAME unless `out_dir`).
    Returns an `ExperimentResult`: `.runs`, `.cells`, `.slopes`, `.comparisons` (pandas DataFrames,
    one row per run / cell / fit / sampler against the baseline at N), `.plot_convergence()`, and
    `["studies"]` (summary.json's content); `open_results` reads the same back later. Other keyword
    arguments go to `drtlab.experiments.study.runner.run_experiment` (out_dir, gt_root, threads, fresh,
    progress)."""
    from drtlab.experiments.study.config import Experiment
    from drtlab.experiments.study.runner import run_experiment as _run_experiment
    if not isinstance(experiment, Experiment):
        experiment = load_experiment(experiment, profile, name=name)
    return _run_experiment(experiment, **kwargs)


def open_results(path):
    """A finished results folder (e.g. "results/stratified") as the `ExperimentResult` its
    `run_experiment` returned, read from summary.json, runs.parquet and manifest.json: nothing is
    rendered or analysed again. Raises `drtlab.errors.InputError` naming `path` when it is not one."""
    from drtlab.experiments.study.experiment_result import open_results as _open_results
    return _open_results(path)


def points(*args, **kwargs):
    """`drtlab.estimators.points.points`: an (n, dims) array of exactly the values the kernels use
    for a point set (scipy.stats.qmc style): points("sobol", 256, 2, seed=0, pixel=0)."""
    from drtlab.estimators.points import points as _points
    return _points(*args, **kwargs)


def variance_sources(scene, spp: int = 256, **kwargs):
    """Where `scene`'s variance comes from: a pandas DataFrame, one row per sample dimension group
    (`group`, `first_order`, `total` and their `_lo`/`_hi` 95% interval ends), the Sobol' indices of
    one sample's variance from `spp` pick-freeze samples per pixel. Keyword arguments: res, groups,
    strategy, integrator, seed, threads (as `drtlab sources`). The whole decomposition (per-pixel
    maps, interaction remainder) is `drtlab.experiments.sources.decompose.variance_sources`."""
    from drtlab.experiments.sources.decompose import variance_sources as _sources
    return _sources(scene, spp=spp, **kwargs).frame()


def register_pointset(pointset, check: bool = True):
    """`drtlab.estimators.plugins.register_pointset`: make a `drtlab.PointSet` (your own Warp functions, or
    `pointset_from_table(...)`) usable by name in every render, study and check."""
    from drtlab.estimators.plugins import register_pointset as _register
    return _register(pointset, check)


def pointset_from_table(name: str, points, n: int | None = None, randomize: str = "owen",
                        description: str | None = None):
    """A PointSet from a table of points: an (M, D) array, a .npy or UTK text file, or a
    `scipy.stats.qmc` engine / QMCPy generator with `n` points; randomized per pixel by `owen`,
    `xor`, `shift` or `none` (estimators/pointsets/tabulated.py says which keeps what)."""
    from drtlab.estimators.pointsets.tabulated import tabulated
    return tabulated(name, points, n=n, randomize=randomize, description=description)


def load_plugin(path_or_module):
    """Import a plugin file or module (it registers its point sets); returns its record."""
    from drtlab.estimators.plugins import load_plugin as _load
    return _load(path_or_module, "plugin")


def register_light_selection(selection):
    """Register a `drtlab.LightSelection` (two Warp functions: pick(sd, x, u) -> light index and
    pmf(sd, x, li) -> its probability; kernels/light_selection.py) for strategies to name."""
    from drtlab.estimators.plugins import attribute
    from drtlab.kernels.light_selection import register
    who, fingerprint = attribute("light_selection", getattr(selection, "name", "?"),
                                 getattr(selection, "pick", None), getattr(selection, "pmf", None))
    return register(selection, who, fingerprint)


def register_lobe_sampler(sampler):
    """Register a `drtlab.LobeSampler` (two Warp functions for one material kind: sample(mat, n, wo,
    u_lobe, u) -> Scatter and pdf(mat, n, wo, wi) -> its density, the signatures of every material
    kind's; kernels/lobe_samplers.py) for strategies to compose."""
    from drtlab.estimators.plugins import attribute
    from drtlab.kernels.lobe_samplers import register
    who, fingerprint = attribute("lobe_sampler", getattr(sampler, "name", "?"),
                                 getattr(sampler, "sample", None), getattr(sampler, "pdf", None))
    return register(sampler, who, fingerprint)


def register_metric(name: str, per_run, description: str = "", label: str | None = None,
                    mse_label: str | None = None):
    """Register an error metric a study may rank samplers by (`metric = NAME`): `per_run(images,
    reference, reference_stderr)` gives each image's mean squared error, the reference's noise removed
    (experiments/error_metrics/base.py); reports print `label` (its root) and `mse_label`."""
    from drtlab.experiments.error_metrics import register_metric as _register
    return _register(name, per_run, description, label, mse_label)


def register_strategy(name: str, description: str, like: str = "importance", *,
                      light_selection: str | None = None, heuristic: str | None = None,
                      lobe_samplers=None):
    """A strategy composed of registered routines: the built-in strategy `like` with another light
    selection (a built-in or `register_light_selection`'s), another MIS heuristic ("power" or
    "balance", kernels/mis.py) and/or lobe samplers (`register_lobe_sampler`'s, one per material
    kind); used as POINTS+NAME in any sampler."""
    from dataclasses import replace

    from drtlab.errors import InputError
    from drtlab.estimators.plugins import register_strategy as _register
    from drtlab.estimators.strategies import MIS_HEURISTICS, STRATEGIES
    from drtlab.kernels.light_selection import LIGHT_SELECTIONS
    if like not in STRATEGIES:
        raise InputError("like", f"must be a registered strategy ({', '.join(STRATEGIES)}), got {like!r}")
    base = STRATEGIES[like]
    if (light_selection is not None or heuristic is not None) and base.light is None:
        raise InputError("like", f"must be a strategy that samples lights to change its light selection or "
                                 f"heuristic ({', '.join(k for k, v in STRATEGIES.items() if v.light)}), "
                                 f"got {like!r}")
    light, fingerprint, lobes = base.light, base.fingerprint, base.lobes
    if light_selection is not None:
        if light_selection not in LIGHT_SELECTIONS:
            raise InputError("light_selection", f"unknown light selection {light_selection!r}; "
                                                f"registered: {', '.join(LIGHT_SELECTIONS)}")
        light = replace(light, pick=light_selection)
        fingerprint = LIGHT_SELECTIONS[light_selection].fingerprint
    if heuristic is not None:
        if heuristic not in MIS_HEURISTICS or not light.mis:
            raise InputError("heuristic", f"must be one of {', '.join(MIS_HEURISTICS)} for a strategy that "
                                          f"combines by MIS, got {heuristic!r} (like={like!r})")
        light = replace(light, heuristic=heuristic)
    if lobe_samplers is not None:
        from drtlab.kernels.lobe_samplers import composed
        if not base.lobe:
            raise InputError("like", f"must sample BSDF lobes to compose lobe samplers "
                                     f"({', '.join(k for k, v in STRATEGIES.items() if v.lobe)}), got {like!r}")
        lobes, lobe_fp = composed(lobe_samplers)
        fingerprint = f"{fingerprint}:{lobe_fp}"
    return _register(replace(base, name=name, description=description, light=light, lobes=lobes,
                             fingerprint=fingerprint))
