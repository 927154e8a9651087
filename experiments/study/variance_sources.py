"""The variance decompositions a study asks for (`variance_sources = N` in its settings): one per
scene, of the study's baseline strategy under its integrator, metric and resolution, written to
`sources/SCENE__STRATEGY__INTEGRATOR__METRIC.json` and `.png` (`experiments/sources/`), reused while
its parameters and the code version match. report.md shows them beside the study's findings."""
from __future__ import annotations

import json
import time
from pathlib import Path

SOURCES_DIR = "sources"


def _params(study, scene, backend) -> dict:
    from drtlab.estimators.registry import parse_sampler
    s = study.settings
    return {"scene": scene.key, "strategy": parse_sampler(study.baseline).strategy.name,
            "integrator": study.integrator, "metric": study.metric, "samples": s.variance_sources,
            "resolution": list(s.resolution) if s.resolution else None,
            "seed": study.seed % (1 << 20), "code_version": backend.code_version}


def stem(study, scene) -> str:
    """The file name (without suffix) of a study's decomposition of `scene` (a SceneRef)."""
    from drtlab.estimators.registry import parse_sampler
    return (f"{scene.label}__{parse_sampler(study.baseline).strategy.name}__{study.integrator}__"
            f"{study.metric}")


def source_files(studies) -> list[str]:
    """Every file `decompose_studies` may write, relative to the study's folder."""
    return [f"{SOURCES_DIR}/{stem(study, scene)}{suffix}" for study in studies
            if study.settings.variance_sources for scene in study.scenes
            for suffix in (".json", ".png", ".params.json")]


def decompose_studies(studies, out_dir: Path, backend, threads=None, log=print) -> float:
    """Run (or reuse) every decomposition the studies ask for; returns the seconds spent."""
    from drtlab.experiments.files import atomic_write_bytes, atomic_write_json
    from drtlab.experiments.sources import report
    from drtlab.experiments.sources.decompose import variance_sources
    t0 = time.perf_counter()
    for study in studies:
        if not study.settings.variance_sources:
            continue
        for scene in study.scenes:
            params = _params(study, scene, backend)
            folder = Path(out_dir) / SOURCES_DIR
            name = stem(study, scene)
            key_file = folder / f"{name}.params.json"
            if key_file.is_file() and json.loads(key_file.read_text()) == params and \
                    (folder / f"{name}.json").is_file():
                continue
            log(f"variance sources of {scene.label} ({params['samples']} samples per pixel)")
            s = variance_sources(backend.load_scene(scene.name, scene.overrides_dict or None),
                                 spp=params["samples"], res=params["resolution"],
                                 strategy=params["strategy"], integrator=params["integrator"],
                                 seed=params["seed"], threads=threads, metric=params["metric"])
            folder.mkdir(parents=True, exist_ok=True)
            atomic_write_json(folder / f"{name}.json", report.summary(s))
            atomic_write_bytes(folder / f"{name}.png", report.figure_png(s))
            atomic_write_json(key_file, params)
    return time.perf_counter() - t0


def load_sources(out_dir: Path, name: str) -> dict | None:
    """A decomposition (sources.json's content) by its `stem`, or None."""
    p = Path(out_dir) / SOURCES_DIR / f"{name}.json"
    try:
        return json.loads(p.read_text())
    except (OSError, ValueError):
        return None
