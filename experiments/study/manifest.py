"""`manifest.json`: what produced an experiment's results (code, packages, machine, seeds, time)."""
from __future__ import annotations

import datetime as _dt
import os
import platform
import subprocess
import sys
from importlib import metadata
from pathlib import Path

from drtlab.experiments.files import atomic_write_json

PACKAGES = ("drtlab", "warp-lang", "numpy", "scipy", "emcee", "matplotlib", "colour-science",
            "OpenImageIO", "tqdm")


def git_info(cwd: Path | None = None) -> dict:
    cwd = cwd or Path(__file__).resolve().parent

    def git(*args):
        try:
            return subprocess.run(["git", *args], cwd=cwd, capture_output=True, text=True,
                                  timeout=10).stdout.strip()
        except (OSError, subprocess.SubprocessError):
            return ""
    sha = git("rev-parse", "HEAD")
    dirty = bool(git("status", "--porcelain", "--untracked-files=no")) if sha else None
    return {"sha": sha or None, "dirty": dirty}


def package_versions(packages=PACKAGES) -> dict:
    out = {}
    for p in packages:
        try:
            out[p] = metadata.version(p)
        except metadata.PackageNotFoundError:
            out[p] = None
    return out


def cpu_model() -> str | None:
    """The first `model name` of /proc/cpuinfo; None where there is none (not Linux, or ARM)."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return None


def machine_info() -> dict:
    model = cpu_model()
    cpu = platform.processor() if model is None else model
    try:
        affinity = len(os.sched_getaffinity(0))
    except AttributeError:
        affinity = os.cpu_count()
    mem = None
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemTotal"):
                mem = round(int(line.split()[1]) / 2 ** 20, 1)
    except OSError:
        pass
    return {"hostname": platform.node(), "platform": platform.platform(), "python": sys.version.split()[0],
            "cpu": cpu, "cpu_count": os.cpu_count(), "usable_cpus": affinity, "memory_gib": mem}


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


def peak_rss_mib() -> float | None:
    try:
        import resource
        return round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0, 1)
    except (ImportError, OSError):
        return None


def _plugins() -> list:
    from drtlab.plugins import manifest
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
