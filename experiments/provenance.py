"""Where a result came from: the git commit, the package versions, the machine, the peak memory.
Every result's manifest reads them here (a leaf: imports nothing of `experiments/`)."""
from __future__ import annotations

import os
import platform
import subprocess
import sys
from importlib import metadata
from pathlib import Path

PACKAGES = ("drtlab", "warp-lang", "numpy", "scipy", "emcee", "matplotlib", "colour-science",
            "OpenImageIO", "tqdm", "flip-evaluator")


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


def peak_rss_mib() -> float | None:
    try:
        import resource
        return round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0, 1)
    except (ImportError, OSError):
        return None


