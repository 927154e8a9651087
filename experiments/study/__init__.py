"""The study pipeline: experiment config, plan and sweep, run store, ground truth, metrics, analysis,
results, report, figures, manifest, Dask cluster. May import experiments.stats and the experiments/ leaves."""
