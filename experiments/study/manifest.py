"""`manifest.json`: what produced an experiment's results (code, packages, machine, seeds, time)."""
from __future__ import annotations

import datetime as _dt
import os
import sys
from pathlib import Path

from drtlab.experiments.files import atomic_write_json
from drtlab.experiments.provenance import git_info, machine_info, package_versions, peak_rss_mib

def _wall_seconds(stats: dict, wall: float, recs: list, gts: dict) -> dict:
    """Where this invocation's time went. `render_share_of_sweep`: the batches' render calls over
    the sweep excluding its ground truth (and the kernel compiles, which precede it)."""
    sweep = stats.get("sweep_seconds")
    gt = stats.get("ground_truth_total", sum((i.get("wall_seconds") or 0.0) for i in gts.values()))
    render = stats.get("render_total", sum(r["render_seconds"] for r in recs))
    out = {
        "this_invocation": wall,
        "render_total": render,
        "compile_total": sum(r["compile_seconds"] for r in recs),
        "kernel_precompile": (stats.get("kernel_precompile") or {}).get("wall_seconds", 0.0),
        "ground_truth_total": gt,
        "sweep": sweep,
        "calibration": stats.get("calibration_seconds"),
        "analysis": stats.get("analysis_seconds"),
    }
    if sweep is not None and sweep - gt > 0:
        out["render_share_of_sweep"] = render / (sweep - gt)
    return out


def _plugins() -> list:
    from drtlab.estimators.plugins import manifest
    return manifest()


def write_manifest(out_dir: Path, exp, backend, plan, records: dict, gts: dict, stats: dict,
                   wall_seconds: float, argv=None) -> dict:
    recs = [records[r.run_id] for r in plan if r.run_id in records]
    m = {
        "experiment": exp.name, "profile": exp.profile, "file": exp.path,
        "experiment_hash": exp.text_hash, "sources": exp.sources,
        "command": argv if argv is not None else sys.argv,
        "finished": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "git": git_info(), "packages": package_versions(), "machine": machine_info(),
        "backend": backend.name, "code_version": backend.code_version, "plugins": _plugins(),
        "seeds": {
            "scheme": "run seed = blake2b(root, scene, sampler, integrator, resolution, spp, repetition) "
                      "& 0x7fffffff; ground-truth batch seeds have the top bit set (disjoint)",
            "roots": {st.name: st.seed for st in exp.studies},
            "runs": "see runs.csv (column seed)",
            "ground_truth": {info["dir"]: info.get("seeds") for info in gts.values()},
        },
        "runs": stats,
        "wall_seconds": _wall_seconds(stats, wall_seconds, recs, gts),
        "peak_rss_mib": peak_rss_mib(),
        "environment": {k: os.environ.get(k) for k in ("WARP_CACHE_PATH", "OMP_NUM_THREADS")},
    }
    atomic_write_json(Path(out_dir) / "manifest.json", m)
    return m
