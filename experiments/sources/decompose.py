"""The variance decomposition of a scene's samples over the dimension groups
(`estimators.dimensions.GROUPS`): each base sample n renders f(A), f(B) and f(A_B^g) of every pixel
in one batch of the `pickfreeze` point set (seeds differing only in their group code), one sample
per pixel each, and `experiments/stats/sobol_indices.py` turns their terms into S_g and T_g.

Image level: the terms are averaged over pixels and channels, so the indices split the mean
per-pixel variance of one sample (a render's MSE is that over spp); with metric "relmse" each pixel
weighs 1 / (mean^2 + REL_EPS) as in the studies' relMSE (its mean from the independent pilot render),
so that a few very bright pixels (a light's edge seen directly) do not decide the split alone. Pixel level: each pixel's own
terms give its total indices, and the map of which group holds most of its variance.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from drtlab.errors import InputError
from drtlab.estimators.dimensions import GROUPS

DEFAULT_SAMPLES = 256
METRICS = ("mse", "relmse")
MAX_SAMPLES = 1 << 16
PILOT_SPP = 64               # the pilot render whose mean centres the first-order terms (and weighs relmse)
BATCH_PIXELS = 1 << 21       # pixels x images of one batch (~50 MB of float64 images)


def check_groups(groups, field: str = "groups") -> tuple[str, ...]:
    """The groups to decompose (names of GROUPS, any order, no repeats), in GROUPS order."""
    if groups is None:
        return GROUPS
    names = [g.strip() for g in (groups.split(",") if isinstance(groups, str) else groups)]
    bad = [g for g in names if g not in GROUPS]
    if bad or not names or len(set(names)) != len(names):
        raise InputError(field, f"must be distinct names from {', '.join(GROUPS)}, got "
                                   f"{','.join(names) if names else 'nothing'}")
    return tuple(g for g in GROUPS if g in names)


def check_metric(metric, field: str = "metric") -> str:
    if metric not in METRICS:
        raise InputError(field, f"must be one of {', '.join(METRICS)}, got {metric!r}")
    return metric


def check_samples(n) -> int:
    from drtlab import fields
    return fields.integer_in(n, "spp", 2, MAX_SAMPLES)


@dataclass
class Sources:
    """A decomposition: image-level indices per group, and per-pixel maps."""
    scene: str
    sampler: str
    integrator: str
    metric: str                  # what the image-level indices split: "mse" or "relmse"
    samples: int                 # base samples per pixel (each renders len(groups) + 2 samples)
    seed: int
    groups: tuple
    indices: dict                # sobol_indices(terms, groups) at CI_LEVEL
    terms: object                # the per-sample terms (stats.sobol_indices.PickFreezeTerms)
    image: np.ndarray            # (H, W, 3): the mean of the f(A) samples
    pixel_variance: np.ndarray   # (H, W): each pixel's variance of one sample (channels summed)
    pixel_total: np.ndarray      # (G, H, W): each pixel's total index per group (NaN: no variance)
    seconds: float
    render_seconds: float

    def indices_at(self, level: float) -> dict:
        """`indices` with intervals at another confidence level (tests correct for multiplicity)."""
        from drtlab.experiments.stats.sobol_indices import sobol_indices
        return sobol_indices(self.terms, self.groups, level)

    def frame(self):
        """One row per group: group, first_order, total and their _lo/_hi interval ends."""
        import pandas as pd
        return pd.DataFrame(self.indices["groups"])

    def dominant(self) -> tuple[np.ndarray, np.ndarray]:
        """(index into `groups` of the group with the largest total index, that index) per pixel;
        -1 and NaN where the pixel has no variance."""
        t = np.nan_to_num(self.pixel_total, nan=-1.0)
        arg = np.argmax(t, axis=0)
        share = np.take_along_axis(t, arg[None], axis=0)[0]
        none = ~np.isfinite(self.pixel_total).any(axis=0)
        return np.where(none, -1, arg), np.where(none, np.nan, share)


def max_seed(spp: int) -> int:
    """The largest first base seed of a decomposition of `spp` base samples: the bases seed ...
    seed + spp (the pilot's included) stay below the pick-freeze set's BASE_LIMIT (the seed's top
    byte carries the group)."""
    from drtlab.estimators.pointsets.pickfreeze import BASE_LIMIT
    return BASE_LIMIT - spp - 2


def check_seed(seed, spp: int, field: str = "seed") -> int:
    """`seed` as an integer in [0, max_seed(spp)]."""
    from drtlab import fields
    return fields.integer_in(seed, field, 0, max_seed(spp))


def variance_sources(scene, spp: int = DEFAULT_SAMPLES, res=None, groups=None, strategy: str | None = None,
                     integrator: str | None = None, seed: int = 0, threads: int | None = None,
                     device: str = "cpu", progress: bool = False, pointset=None,
                     metric: str = "mse") -> Sources:
    """Decompose `scene`'s sample variance (a Scene, built-in name or .toml path) with `spp` base
    samples per pixel; `strategy` as in POINTS+STRATEGY (default: the default sampler's). `pointset`
    is a pick-freeze PointSet (default: `pickfreeze.POINTSET`; tests pass one with a wrong group
    map). The pick-freeze set is this tool's, not a sampler of the registry: with seeds below 2^24
    it is `independent`, and its codes mean something only to this function."""
    from drtlab import fields
    from drtlab.estimators.defaults import DEFAULT_SAMPLER
    from drtlab.estimators.registry import parse_sampler
    from drtlab.estimators.pointsets.pickfreeze import CODE_B, POINTSET, pick_freeze_seed
    from drtlab.estimators.registry import SamplerSpec
    from drtlab.estimators.strategies import STRATEGIES
    from drtlab.experiments.stats.sobol_indices import pick_freeze_terms, sobol_indices
    from drtlab.kernels.render import resolve_scene, render_batch_with_stats, render_with_stats
    t_start = time.perf_counter()
    n = check_samples(spp)
    names = check_groups(groups)
    check_metric(metric)
    seed = check_seed(seed, n)
    strat = strategy if strategy is not None else parse_sampler(DEFAULT_SAMPLER).strategy.name
    if strat not in STRATEGIES:
        raise InputError("strategy", f"must be one of {', '.join(STRATEGIES)}, got {strat!r}")
    spec = SamplerSpec(POINTSET if pointset is None else pointset, STRATEGIES[strat])
    sampler = spec.name
    scene = resolve_scene(scene, res)
    from drtlab.estimators.registry import parse_integrator
    if parse_integrator(integrator if integrator is not None else scene.integrator).name == "whitted":
        raise InputError("integrator", "whitted draws no random numbers (a fixed grid), so it has no "
                                       "variance to decompose; use drt or path")
    codes = [0, CODE_B] + [1 + GROUPS.index(g) for g in names]
    kw = dict(sampler=spec, integrator=integrator, threads=threads, device=device)
    # The pilot: samples of seed + n (never a base below), indices 0 ... PILOT_SPP - 1.
    pilot = render_with_stats(scene, spp=PILOT_SPP, seed=pick_freeze_seed(seed + n, 0), **kw)
    centre = pilot.image
    H, W = centre.shape[:2]
    # Every term is a product of two differences of f: weighting a pixel by w scales f by sqrt(w).
    from drtlab.kernels.error_sums import REL_EPS
    scale = 1.0 if metric == "mse" else 1.0 / np.sqrt(np.square(centre) + REL_EPS)
    per_batch = max(1, BATCH_PIXELS // (H * W * len(codes)))
    terms = None
    image = np.zeros((H, W, 3))
    pvar = np.zeros((H, W))
    ptot = np.zeros((len(names), H, W))
    render_s = pilot.render_seconds
    integ = pilot.integrator
    for a in range(0, n, per_batch):
        bases = range(seed + a, seed + min(a + per_batch, n))
        seeds = [pick_freeze_seed(b, c) for b in bases for c in codes]
        out = render_batch_with_stats(scene, seeds, spp=1, progress=progress, **kw)
        render_s += out.render_seconds
        f = out.images.reshape(len(bases), len(codes), H, W, 3)
        fa, fb, fab = f[:, 0], f[:, 1], np.moveaxis(f[:, 2:], 1, 0)
        t = pick_freeze_terms(fa * scale, fb * scale, fab * scale, centre * scale)
        terms = t if terms is None else terms.merged(t)
        image += fa.sum(axis=0)
        pvar += 0.5 * np.square(fa - fb).sum(axis=(0, 3))
        ptot += 0.5 * np.square(fab - fa[None]).sum(axis=(1, 4))
    with np.errstate(invalid="ignore", divide="ignore"):
        pixel_total = np.where(pvar > 0, ptot / pvar, np.nan)
    return Sources(scene=scene.name, sampler=sampler, integrator=integ, metric=metric, samples=n, seed=seed, groups=names,
                   indices=sobol_indices(terms, names), terms=terms, image=image / n, pixel_variance=pvar / n,
                   pixel_total=pixel_total, seconds=time.perf_counter() - t_start,
                   render_seconds=render_s)
