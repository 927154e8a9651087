"""What a study will cost, said before it starts: rendering time from a short probe per scene, peak
memory from the largest buffers the plan will hold, and a refusal beyond the limits unless the
caller says yes (`drtlab experiment --yes`, `run_experiment(..., yes=True)`); the same for the
references `drtlab ground-truth` renders (`check_references`) and for any command's rendering of a
known number of samples (`check_render`: `drtlab sources`).

Time: each group's pending samples (its reference's and the runs not stored yet) over the speed of the reference's sampler,
`stratified+importance` (one of the slower ones, so the estimate errs high), measured by the
backend's `speed`: renders of the group's image at a spp raised until one takes backend.PROBE_SECONDS
(kernels/render.py `measured_speed`). The probe runs after the sweep's kernels are compiled, so it
pays no compile of its own; on a Dask cluster nothing is probed here.

Memory: BASE_MIB (the process with Warp, the analysis and the report loaded: the default study's
whole peak is 775 MiB with images under 1 MB each), plus the largest batch's images (float64 RGB,
three copies: device sums, host copy, the batch array) and the largest reference's arrays (six
float64 RGB images: sums, squares, mean, standard error, the moments of a cell, the report's copy).
"""
from __future__ import annotations

import os
from dataclasses import dataclass

from drtlab.errors import InputError

MAX_HOURS = 24.0              # estimated rendering beyond this needs yes
MEMORY_SHARE = 0.9            # of this machine's memory: an estimate beyond it needs yes
BASE_MIB = 800.0
BATCH_COPIES, REFERENCE_COPIES = 3, 6
FAST_SAMPLES_PER_SECOND = 5e7  # above a CPU's speed on the simplest scene: fewer samples need no probe


@dataclass(frozen=True)
class Estimate:
    seconds: float | None          # rendering, references and runs (None: no speed could be probed)
    reference_seconds: float | None
    samples: int                   # pending samples, references included
    memory_mib: float

    def line(self) -> str:
        t = "time unknown" if self.seconds is None else (
            f"{_duration(self.seconds)} of rendering ({_duration(self.reference_seconds)} of it "
            f"the references)")
        if self.seconds is not None and not self.reference_seconds:
            t = f"{_duration(self.seconds)} of rendering"
        t = t if t.startswith(("under", "time")) else "about " + t
        return f"estimate: {t}, peak memory about {self.memory_mib:,.0f} MiB"


def _duration(seconds: float) -> str:
    if seconds < 1:
        return "under 1 s"
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 5400:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"


def machine_memory_mib() -> float | None:
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**20
    except (ValueError, OSError, AttributeError):
        return None


def estimate(plan, gt_req: dict, gt_pending: dict, backend, threads=None, probe: bool = True) -> Estimate:
    """The cost of rendering the runs of `plan` (those still to render) and the references of
    `gt_req` (`gt_pending`: samples still to render per group, ground_truth.pending_samples)."""
    from drtlab.experiments.study.ground_truth import GT_SAMPLER
    from drtlab.experiments.study.plan import batch_ranges
    run_samples: dict = {}
    batch_pixels = 0
    cells: dict = {}
    for r in plan:
        run_samples[r.group] = run_samples.get(r.group, 0) + r.spp * r.resolution[0] * r.resolution[1]
        cells.setdefault(r.cell, []).append(r)
    for cruns in cells.values():
        pixels = cruns[0].resolution[0] * cruns[0].resolution[1]
        batch_pixels = max([batch_pixels] + [(b - a) * pixels for a, b in
                                             batch_ranges(len(cruns), pixels, cruns[0].spp)])
    ref_pixels = max((g[2][0] * g[2][1] for g in gt_req), default=0)
    memory = BASE_MIB + (BATCH_COPIES * batch_pixels + REFERENCE_COPIES * ref_pixels) * 3 * 8 / 2**20
    total = sum(gt_pending.values()) + sum(run_samples.values())
    seconds = ref_seconds = 0.0
    for g in gt_req:
        if not gt_pending.get(g, 0) and not run_samples.get(g, 0):
            continue
        scene_ref, integrator, res = g
        speed = None
        if probe and getattr(backend, "speed", None) is not None:
            scene = backend.load_scene(scene_ref.name, scene_ref.overrides_dict or None)
            speed = backend.speed(scene, GT_SAMPLER, integrator, res, threads)
        if not speed:
            return Estimate(None, None, total, memory)
        seconds += (gt_pending.get(g, 0) + run_samples.get(g, 0)) / speed
        ref_seconds += gt_pending.get(g, 0) / speed
    return Estimate(seconds, ref_seconds, total, memory)


def check_references(jobs, backend, root, threads=None, yes: bool = False, log=None) -> None:
    """The cost of rendering references, said and checked as a study's before any is rendered:
    `jobs` are (scene ref, integrator, resolution or None, spp, batch spp) (`drtlab ground-truth`)."""
    from drtlab.experiments.study.ground_truth import pending_samples, scene_key_info
    gt_req, gt_pending = {}, {}
    for ref, integrator, res, spp, batch in jobs:
        g = (ref, integrator, scene_key_info(ref, integrator, res, backend)[1])
        gt_req[g] = (spp, batch)
        gt_pending[g] = pending_samples(ref, integrator, g[2], spp, batch, backend, root)
    what = "these references" if len(jobs) > 1 else "this reference"
    check_budget(estimate([], gt_req, gt_pending, backend, threads, probe=False), yes, what=what)
    if any(gt_pending.values()):
        cost = estimate([], gt_req, gt_pending, backend, threads)
        (log or print)(cost.line())
        check_budget(cost, yes, what=what)


def check_render(samples: int, speed, yes: bool, what: str, log=None) -> None:
    """A command's rendering of `samples` at `speed()` (samples per second, a probe's, asked only
    when `samples` could take more than a minute at the fastest speeds seen): said first, refused
    past MAX_HOURS unless `yes`."""
    if samples < FAST_SAMPLES_PER_SECOND * 60:
        return
    cost = Estimate(samples / speed(), 0.0, samples, BASE_MIB)
    (log or print)(cost.line())
    check_budget(cost, yes, what=what)


def check_budget(e: Estimate, yes: bool, field: str = "--yes", what: str = "this study") -> None:
    """One InputError when the estimate passes a limit and the caller has not said yes."""
    if yes:
        return
    if e.seconds is not None and e.seconds > MAX_HOURS * 3600:
        raise InputError(field, f"{what} would render for about {_duration(e.seconds)} "
                                f"({e.samples / 1e9:,.1f} G samples; limit {MAX_HOURS:g} h): fewer "
                                f"repetitions, spp or pixels, or --yes to run it anyway")
    have = machine_memory_mib()
    if have is not None and e.memory_mib > MEMORY_SHARE * have:
        raise InputError(field, f"{what} would need about {e.memory_mib:,.0f} MiB of memory, "
                                f"{e.memory_mib / have:.0%} of this machine's {have:,.0f} MiB (limit "
                                f"{MEMORY_SHARE:.0%}): a smaller resolution, or --yes to run it anyway")
