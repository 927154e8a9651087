"""A StudyResult built from the results model alone (no renderer, no analysis): each sampler's error
falls as N^slope with a fixed relative interval, each cell costs seconds proportional to N with a
fixed relative cost interval, and every non-baseline sampler has a comparison with the baseline at
each N (the last sampler's not resolved, so figures show both kinds)."""
from __future__ import annotations

import math

from drtlab.experiments.study.compare import Comparison
from drtlab.experiments.study.results import (Bias, Cell, Interval, NoiseFloor, SceneResult, Speed,
                                              SlopeFit, StudyResult)


def _iv(m: float, rel: float, n: int) -> Interval:
    return Interval(m, m / (1 + rel), m * (1 + rel), n)


def synthetic_cell(sampler: str, n: int, error: float, seconds: float, reps: int = 5,
                   cost_rel: float = 0.2) -> Cell:
    e, mse = _iv(error, 0.1, reps), _iv(error ** 2, 0.2, reps)
    return Cell(sampler=sampler, spp=n, n=reps, rmse=e, rmse_corrected=e, mse=mse, mse_corrected=mse,
                relmse=mse, relmse_corrected=mse, mae=e, ciede2000=e, mean_error=_iv(1e-4, 1.0, reps),
                render_seconds=_iv(seconds, 0.3, reps), compile_seconds=_iv(0.0, 0.0, reps),
                wall_seconds=_iv(seconds, 0.3, reps), rmse_of_mean_mse=e, rrmse_of_mean_relmse=e,
                bias=Bias(0.0, -1e-4, 1e-4, 0.0, error ** 2, False), repetitions_for_10pct={},
                seconds=seconds, efficiency=1 / (error ** 2 * seconds),
                efficiency_relmse=1 / (error ** 2 * seconds),
                seconds_ci=_iv(seconds, cost_rel, 12), resolved=True)


def _comparison(s: str, base: str, n: int, ratio: float, resolved: bool) -> Comparison:
    return Comparison(sampler=s, baseline=base, spp=n, mse_ratio=ratio, mse_ratio_lo=ratio / 1.2,
                      mse_ratio_hi=ratio * 1.2, efficiency=ratio, efficiency_lo=ratio / 1.3,
                      efficiency_hi=ratio * 1.3, speedup=ratio ** 0.7, speedup_lo=ratio ** 0.7 / 1.3,
                      speedup_hi=ratio ** 0.7 * 1.3, target_rmse=0.01, samples_to_target=n / 2,
                      baseline_samples_to_target=n, extrapolated=False, resolved=resolved,
                      speedup_resolved=resolved, why=None if resolved else f"{s} at N={n}: heavy tail",
                      claim="better" if resolved and ratio > 1 else "not resolved")


def synthetic_study(n_samplers: int = 2, n_scenes: int = 6, spp=(1, 4, 16, 64), *,
                    rising=False, name: str = "synthetic") -> StudyResult:
    """`n_samplers` samplers (the first the baseline) on `n_scenes` scenes; with `rising` (True, or
    one bool per sampler) the errors grow with N: points in the lower left corner of a panel, and
    with a falling sampler beside a rising one in all four."""
    rising = tuple(rising) if isinstance(rising, (tuple, list)) else (rising,) * n_samplers
    samplers = [f"sampler-{i}" for i in range(n_samplers)]
    base = samplers[0]
    scenes = []
    for k in range(n_scenes):
        cells, rows = [], []
        for i, s in enumerate(samplers):
            slope = (0.5 + 0.05 * i) if rising[i] else -(0.5 + 0.05 * i)
            for n in spp:
                # A rising sampler ends where a falling one starts: together they reach every corner.
                scale = spp[-1] ** -slope if rising[i] else 1.0
                cells.append(synthetic_cell(s, n, 0.1 * (1 + 0.1 * k) * scale * n ** slope,
                                            1e-3 * n * (1 + 0.05 * i)))
                if s != base:
                    rows.append(_comparison(s, base, n, 1.0 + 0.4 * i, resolved=i < n_samplers - 1))
        noise = NoiseFloor(gt_dir=f"scene-{k}", gt_spp=4096, gt_variance=1e-8, smallest_mse=1e-6,
                           fraction_of_smallest_mse=0.01, warning=False)
        speed = Speed(target_rmse=0.01, target_auto=True, time_to_target={}, speedup_vs_baseline={})
        scenes.append(SceneResult(scene=f"scene-{k}", scene_name=f"scene-{k}", overrides={}, cells=cells,
                                  slopes={s: SlopeFit(n_points=len(spp), dropped=0, level=0.95, ok=False,
                                                      reason="synthetic") for s in samplers},
                                  noise_floor=noise, speed=speed, vs_baseline={}, efficiency={},
                                  comparisons=rows))
    return StudyResult(name=name, description="", experiment="synthetic", integrator="drt",
                       samplers=samplers, baseline=base, metric="mse", metric_label="RMSE", mse_label="MSE",
                       spp=list(spp), repetitions=5, resolution=[16, 12], gt_spp=4096, seed=1,
                       strip_spp=[1], scenes=scenes)
