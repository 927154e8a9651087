"""drtlab: Monte Carlo estimator variance studies for distribution ray tracing.

The Python API a notebook needs; each name imports its layer (and Warp) only when first called:

    import drtlab
    scene = drtlab.load_scene("glossy", {"scene.resolution": [64, 48]})
    image = drtlab.render(scene, spp=64, sampler="stratified+importance")      # (H, W, 3) float64
    summary = drtlab.run_experiment(drtlab.load_experiment("stratified"))

The top-level folders are mapped under this package: `drtlab.estimators`, `drtlab.kernels`,
`drtlab.experiments` (see pyproject.toml).
"""
__version__ = "0.1.0"


def render(*args, **kwargs):
    """`drtlab.kernels.render.render`: (H, W, 3) float64 linear radiance of a scene."""
    from drtlab.kernels.render import render as _render
    return _render(*args, **kwargs)


def load_scene(*args, **kwargs):
    """`drtlab.kernels.scene_file.load_scene`: a built-in name or .toml path -> a validated Scene."""
    from drtlab.kernels.scene_file import load_scene as _load_scene
    return _load_scene(*args, **kwargs)


def load_experiment(*args, **kwargs):
    """`drtlab.experiments.config.load_experiment`: a built-in name or .toml path -> an Experiment."""
    from drtlab.experiments.config import load_experiment as _load_experiment
    return _load_experiment(*args, **kwargs)


def run_experiment(*args, **kwargs):
    """`drtlab.experiments.runner.run_experiment`: ground truth, runs, analysis, report."""
    from drtlab.experiments.runner import run_experiment as _run_experiment
    return _run_experiment(*args, **kwargs)
