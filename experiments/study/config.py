"""Experiment files (TOML) -> the validated model of experiment_model.py. Every problem is one
`InputError(field, message)`.

An experiment is a list of studies (scenes x samplers on one integrator) swept over an spp ladder
with independent repetitions. Run-size settings live in `[experiment]` and may be overridden by a
`[profile.NAME]` section (`quick` is the default, `full` for publication); `include` pulls in the
studies of other experiment files, each resolved with its own settings for the same profile.

    [experiment]
    description = "..."                      # required
    seed        = 0                          # root seed; run seeds are hashes of it (seeds.py)
    integrator  = "drt"                      # drt | path (whitted is biased: no ground truth)
    include     = ["stratified", ...]        # other experiment files (names or paths)
    spp         = [1, 4, 16, 64, 256]        # the ladder, strictly increasing, >= 2 entries
    repetitions = 4                          # independent seeds per (scene, sampler, spp), >= 2
    samples_per_cell = 320                   # optional: runs per cell >= this / spp (equal samples)
    resolution  = [48, 36]                   # [width, height]; omit for each scene's own
    gt_spp      = 16384                      # ground-truth samples per pixel
    gt_batch_spp = 512                       # ground truth is accumulated in batches of this size
    target_rmse = 0.01                       # optional: time-to-reach target (default: automatic)
    target_rel_ci = 0.1                      # optional: add repetitions to a cell until the 95% CI
                                             # of its mean MSE is within +-10% ...
    max_samples_per_cell = 4096              # ... or it has this many samples per pixel (runs x spp)
    max_seconds = 20                         # optional: render seconds per study spent on growing
                                             # the cells that are not resolved (largest run dominant)
    keep_images = false                      # keep every repetition's image (error spectra)
    colour_difference_runs = 16              # optional: CIEDE2000 of a cell's first 16 runs only
                                             # (each costs as much as a 1-spp render); default: all
    flip_runs   = 1                          # optional: HDR-FLIP of a cell's first runs (0: none);
                                             # default 1 (each costs 25-90 ms at 96x72)
    strip_spp   = [1, 16, 256]               # optional: spp shown in the image strips
    variance_sources = 256                   # optional: decompose each scene's variance over the
                                             # sample dimension groups (`drtlab sources`) with this
                                             # many samples per pixel; report.md shows where it lives

    [[study]]
    name     = "stratification"               # required, unique
    scenes   = ["aa-edges", {name = "glossy", overrides = {"scene.max_depth" = 3}, label = "glossy-d3"}]
    samplers = ["uniform", "stratified"]      # presets or POINTS+STRATEGY
    baseline = "uniform"                      # default: the first sampler
    integrator = "drt"                        # default: [experiment].integrator
    metric   = "mse"                          # mse (RMSE) | relmse (relative MSE, for bright emitters)

    [profile.quick]                           # any of the run-size keys above
    spp = [1, 4, 16]
"""
from __future__ import annotations

import math
import tomllib
from dataclasses import replace
from pathlib import Path
from typing import Callable

from drtlab.experiments.error_metrics import check_name
from drtlab.experiments.seeds import short_hash
from drtlab import fields
from drtlab.errors import InputError
# The model's names, importable from here as before the model had its own module.
from drtlab.experiments.study.experiment_model import (  # noqa: F401
    DEFAULT_PROFILE, DEFAULTS, EXPERIMENT_DIR, EXPERIMENT_KEYS, MAX_RUNS_PER_CELL, MAX_STUDY_SECONDS,
    MIN_GT_BATCHES, SCENE_KEYS, SETTINGS_KEYS, STUDY_KEYS, Experiment, SceneRef, Settings, Study, freeze)


# ---------------------------------------------------------------------------------------------
def builtin_experiments() -> list[str]:
    return sorted(p.stem for p in EXPERIMENT_DIR.glob("*.toml"))


def resolve_path(name_or_path: str, base: Path | None = None) -> Path:
    p = Path(name_or_path)
    fields.name_lengths(p, "experiment")
    candidates = []
    if p.suffix == ".toml" or p.exists():
        if base is not None and not p.is_absolute():
            candidates.append(base / p)
        candidates.append(p)
    else:
        if base is not None:
            candidates.append(base / f"{name_or_path}.toml")
        candidates.append(EXPERIMENT_DIR / f"{name_or_path}.toml")
    for c in candidates:
        if c.is_file():
            return c
    if (p / "summary.json").is_file():
        raise InputError("experiment", f"'{name_or_path}' is a finished study's results folder, not an "
                         f"experiment file: drtlab.open_results({str(name_or_path)!r}) reads it")
    for c in candidates or [p]:
        kind = fields.file_kind(c)
        if kind is not None:
            raise InputError("experiment", f"'{name_or_path}' is {kind}, not an experiment file (.toml)")
    raise InputError("experiment", f"no experiment file '{name_or_path}'; built-in experiments: "
                     f"{', '.join(builtin_experiments())}, or a path to a .toml file")


def _int(v, fld, lo=None):
    return fields.integer(v, fld) if lo is None else fields.integer_in(v, fld, lo)


def _setting(key, v, fld):
    if key == "spp":
        if not isinstance(v, list) or len(v) < 2:
            raise InputError(fld, f"must be a list of at least 2 sample counts (e.g. [1, 4, 16, 64]), got {v!r}")
        out = tuple(_int(x, f"{fld}[{i}]", 1) for i, x in enumerate(v))
        for i in range(1, len(out)):
            if out[i] <= out[i - 1]:
                raise InputError(f"{fld}[{i}]", f"the ladder must be strictly increasing, got {list(out)}")
        return out
    if key == "repetitions":
        return _int(v, fld, 2)
    if key == "samples_per_cell":
        return _int(v, fld, 2)
    if key == "resolution":
        return fields.resolution(v, fld, name_elements=True)
    if key in ("gt_spp", "gt_batch_spp"):
        return _int(v, fld, 1)
    if key == "target_rmse":
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
            raise InputError(fld, f"must be a finite number > 0, got {v!r}")
        return float(v)
    if key == "target_rel_ci":
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0 < v < 1:
            raise InputError(fld, f"must be a number in (0, 1) (e.g. 0.1: the 95% interval of a cell's "
                                  f"mean MSE within +-10%), got {v!r}")
        return float(v)
    if key == "max_samples_per_cell":
        return _int(v, fld, 2)
    if key == "max_seconds":
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0 < v <= MAX_STUDY_SECONDS:
            raise InputError(fld, f"must be a number of seconds in (0, {MAX_STUDY_SECONDS:g}], got {v!r}")
        return float(v)
    if key == "colour_difference_runs":
        return _int(v, fld, 2)
    if key == "flip_runs":
        return _int(v, fld, 0)
    if key == "variance_sources":
        from drtlab.experiments.sources.decompose import MAX_SAMPLES
        return fields.integer_in(v, fld, 2, MAX_SAMPLES)
    if key == "keep_images":
        if not isinstance(v, bool):
            raise InputError(fld, f"must be true or false, got {v!r}")
        return v
    if key == "strip_spp":
        if not isinstance(v, list) or not v:
            raise InputError(fld, f"must be a non-empty list of sample counts, got {v!r}")
        return tuple(_int(x, f"{fld}[{i}]", 1) for i, x in enumerate(v))
    raise AssertionError(key)


def _settings(exp_table, profile_table, profile) -> Settings:
    vals, where = dict(DEFAULTS), {k: f"experiment.{k}" for k in DEFAULTS}
    for k in SETTINGS_KEYS:
        if k in exp_table:
            vals[k] = _setting(k, exp_table[k], f"experiment.{k}")
    for k in SETTINGS_KEYS:
        if profile_table is not None and k in profile_table:
            where[k] = f"profile.{profile}.{k}"
            vals[k] = _setting(k, profile_table[k], where[k])
    spp = tuple(vals["spp"])
    if vals["gt_spp"] % vals["gt_batch_spp"] != 0:
        raise InputError(where["gt_spp"], f"must be a multiple of gt_batch_spp = {vals['gt_batch_spp']}, "
                         f"got {vals['gt_spp']}")
    if vals["gt_spp"] // vals["gt_batch_spp"] < MIN_GT_BATCHES:
        raise InputError(where["gt_spp"], f"must be at least {MIN_GT_BATCHES} batches of gt_batch_spp = "
                         f"{vals['gt_batch_spp']} (the standard error needs them), got {vals['gt_spp']}")
    strip = vals["strip_spp"]
    if strip is None:
        strip = (spp[0], spp[len(spp) // 2], spp[-1]) if len(spp) > 2 else spp
        strip = tuple(dict.fromkeys(strip))
    else:
        for i, s in enumerate(strip):
            if s not in spp:
                raise InputError(f"{where['strip_spp']}[{i}]", f"{s} is not on the spp ladder {list(spp)}")
    if vals["repetitions"] > MAX_RUNS_PER_CELL:
        raise InputError(where["repetitions"], f"at most {MAX_RUNS_PER_CELL} runs per cell (a cell's interval "
                         f"narrows as 1/sqrt(runs): use target_rel_ci to grow the cells that need it), "
                         f"got {vals['repetitions']}")
    per_cell = vals["samples_per_cell"]
    if per_cell is not None and -(-per_cell // spp[0]) > MAX_RUNS_PER_CELL:
        raise InputError(where["samples_per_cell"], f"would need {-(-per_cell // spp[0])} runs at "
                         f"spp = {spp[0]}; at most {MAX_RUNS_PER_CELL} runs per cell, so at most "
                         f"{MAX_RUNS_PER_CELL * spp[0]} here, got {per_cell}")
    return Settings(spp=spp, repetitions=vals["repetitions"], resolution=vals["resolution"],
                    gt_spp=vals["gt_spp"], gt_batch_spp=vals["gt_batch_spp"],
                    target_rmse=vals["target_rmse"], strip_spp=tuple(strip),
                    samples_per_cell=per_cell, target_rel_ci=vals["target_rel_ci"],
                    max_samples_per_cell=vals["max_samples_per_cell"], max_seconds=vals["max_seconds"],
                    keep_images=vals["keep_images"],
                    colour_difference_runs=vals["colour_difference_runs"], flip_runs=vals["flip_runs"],
                    variance_sources=vals["variance_sources"])


def scene_ref(entry, fld, base: Path | None = None) -> SceneRef:
    if isinstance(entry, str):
        name, overrides, label = fields.nonempty_string(entry, fld), {}, None
    elif isinstance(entry, dict):
        fields.check_keys(entry, SCENE_KEYS, fld)
        if "name" not in entry:
            raise InputError(f"{fld}.name", "required (a built-in scene name or a path)")
        name = fields.nonempty_string(entry["name"], f"{fld}.name")
        overrides = entry.get("overrides", {})
        if not isinstance(overrides, dict):
            raise InputError(f"{fld}.overrides", f"must be a table of dotted keys, got {overrides!r}")
        label = fields.nonempty_string(entry["label"], f"{fld}.label") if "label" in entry else None
    else:
        raise InputError(fld, f"must be a scene name or a table {{name, overrides, label}}, got {entry!r}")
    is_path = "/" in name or name.endswith((".toml", ".xml"))
    if is_path and base is not None and not Path(name).is_absolute() and (base / name).is_file():
        name = str((base / name).resolve())        # relative to the experiment file
    if label is None:
        label = Path(name).stem if is_path else name
        if overrides:
            label = f"{label}~{short_hash(overrides, 6)}"
    bad = [c for c in label if not (c.isalnum() or c in "-_.~")]
    if bad:
        raise InputError(f"{fld}.label", f"may hold letters, digits and - _ . ~ only, got {label!r}")
    return SceneRef(name=name, label=label,
                    overrides=tuple(sorted((k, freeze(v)) for k, v in overrides.items())))


def _canonical_sampler(name, fld) -> str:
    from drtlab.estimators.registry import parse_sampler
    return parse_sampler(name, fld).name


def _integrator(name, fld) -> str:
    from drtlab.estimators.registry import parse_integrator
    return parse_integrator(name, fld, unbiased=True).name


def _study(t, i, exp_name, seed, default_integrator, settings, base: Path | None = None) -> Study:
    fld = f"study[{i}]"
    fields.check_keys(t, STUDY_KEYS, fld)
    for req in ("name", "scenes", "samplers"):
        if req not in t:
            raise InputError(f"{fld}.{req}", "required")
    name = fields.nonempty_string(t["name"], f"{fld}.name")
    scenes = t["scenes"]
    if not isinstance(scenes, list) or not scenes:
        raise InputError(f"{fld}.scenes", f"must be a non-empty list of scenes, got {scenes!r}")
    refs = tuple(scene_ref(s, f"{fld}.scenes[{j}]", base) for j, s in enumerate(scenes))
    labels = [r.label for r in refs]
    for j, lab in enumerate(labels):
        if labels.index(lab) != j:
            raise InputError(f"{fld}.scenes[{j}]", f"scene '{lab}' is listed twice (give it a distinct label)")
    samplers = t["samplers"]
    if not isinstance(samplers, list) or not samplers:
        raise InputError(f"{fld}.samplers", f"must be a non-empty list of samplers, got {samplers!r}")
    canon = tuple(_canonical_sampler(s, f"{fld}.samplers[{j}]") for j, s in enumerate(samplers))
    for j, c in enumerate(canon):
        if canon.index(c) != j:
            raise InputError(f"{fld}.samplers[{j}]", f"'{samplers[j]}' is the same sampler as "
                             f"'{samplers[canon.index(c)]}'")
    baseline = canon[0]
    if "baseline" in t:
        baseline = _canonical_sampler(t["baseline"], f"{fld}.baseline")
        if baseline not in canon:
            raise InputError(f"{fld}.baseline", f"'{t['baseline']}' is not one of the study's samplers "
                             f"({', '.join(samplers)})")
    integrator = _integrator(t.get("integrator", default_integrator), f"{fld}.integrator")
    desc = t.get("description", "")
    if not isinstance(desc, str):
        raise InputError(f"{fld}.description", f"must be a string, got {desc!r}")
    metric = check_name(t.get("metric", "mse"), f"{fld}.metric")
    return Study(name=name, description=desc, experiment=exp_name, seed=seed, scenes=refs,
                 samplers=canon, baseline=baseline, integrator=integrator, settings=settings,
                 metric=metric)


def _plugins(specs, path: Path, sources: dict) -> None:
    """Load the experiment's plugins (paths relative to its file) before its samplers are checked;
    each plugin's source hash joins the experiment's sources (and so its hash and manifest)."""
    from drtlab.estimators.plugins import load_plugins
    if not isinstance(specs, list) or not all(isinstance(x, str) for x in specs):
        raise InputError("experiment.plugins", f"must be a list of plugin files (.py, relative to "
                                               f"{path.name}) or module names, got {specs!r}")
    for p in load_plugins(specs, "experiment.plugins", path.parent):
        sources[f"plugin:{p.path or p.module}"] = p.sha256[:16]


def _parse_file(path: Path, profile: str, stack: tuple, sources: dict,
                profiles_seen: set) -> tuple[str, list[Study]]:
    try:
        text = path.read_bytes().decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(path.name, f"not valid TOML: not UTF-8 text ({exc.reason} at byte "
                                    f"{exc.start})") from None
    except OSError as exc:
        raise InputError(path.name, f"cannot read {path}: {exc.strerror or exc}") from None
    sources[str(path)] = short_hash(text, 16)
    try:
        data = fields.check_nesting(tomllib.loads(text), path.name)
    except tomllib.TOMLDecodeError as e:
        raise InputError(path.name, f"not valid TOML: {e}") from None
    except RecursionError:
        raise fields.too_deep(path.name) from None
    return _parse_data(data, path, profile, stack, sources, profiles_seen)


def _parse_data(data: dict, path: Path, profile: str, stack: tuple, sources: dict,
                profiles_seen: set) -> tuple[str, list[Study]]:
    """An experiment's parsed TOML; `path` names it (its stem) and anchors relative paths."""
    fields.check_keys(data, ("experiment", "study", "profile"), "", "an experiment")
    if "experiment" not in data:
        raise InputError("experiment", "required table [experiment] is missing")
    exp = data["experiment"]
    fields.check_keys(exp, EXPERIMENT_KEYS, "experiment")
    if "description" not in exp:
        raise InputError("experiment.description", "required (one line saying what the study asks)")
    desc = fields.nonempty_string(exp["description"], "experiment.description")
    _plugins(exp.get("plugins", []), path, sources)
    seed = _int(exp.get("seed", 0), "experiment.seed", 0)
    integrator = exp.get("integrator", "drt")
    _integrator(integrator, "experiment.integrator")

    profiles = data.get("profile", {})
    if not isinstance(profiles, dict):
        raise InputError("profile", "must be a table of [profile.NAME] sections")
    profiles_seen.update(profiles)
    for pname, ptab in profiles.items():
        fields.check_keys(ptab, SETTINGS_KEYS, f"profile.{pname}")
        _settings(exp, ptab, pname)            # every profile is checked, not only the one asked for
    if profile in profiles:
        ptable = profiles[profile]
    elif profile == DEFAULT_PROFILE or not profiles:
        ptable = None
    else:
        raise InputError("profile", f"unknown profile '{profile}' in {path.name}; defined: "
                         f"{', '.join(profiles) or DEFAULT_PROFILE}")
    settings = _settings(exp, ptable, profile)

    studies: list[Study] = []
    includes = exp.get("include", [])
    if not isinstance(includes, list) or not all(isinstance(x, str) for x in includes):
        raise InputError("experiment.include", f"must be a list of experiment names or paths, got {includes!r}")
    for k, inc in enumerate(includes):
        try:
            ipath = resolve_path(inc, path.parent)
        except InputError as e:
            raise InputError(f"experiment.include[{k}]", e.message) from None
        if ipath.resolve() in stack:
            raise InputError(f"experiment.include[{k}]", f"'{inc}' includes itself (cycle)")
        try:
            _, sub = _parse_file(ipath, profile, stack + (ipath.resolve(),), sources, profiles_seen)
        except InputError as e:
            if e.field == ipath.name or e.field.startswith(f"{ipath.name}:"):
                raise
            raise InputError(f"{ipath.name}:{e.field}", e.message) from None
        studies.extend(sub)

    raw = data.get("study", [])
    if not isinstance(raw, list):
        raise InputError("study", "must be an array of tables: write each as [[study]]")
    for i, t in enumerate(raw):
        studies.append(_study(t, i, path.stem, seed, integrator, settings, path.parent))
    if not studies:
        raise InputError("study", "no [[study]] section and nothing included: the experiment is empty")
    return desc, studies


def load_experiment(name_or_path: str | Path | dict, profile: str = DEFAULT_PROFILE,
                    scene_loader: Callable | None = None, check_scenes: bool = True,
                    name: str = "inline") -> Experiment:
    """Parse and fully validate an experiment (a built-in name, a .toml path, or a dict shaped like
    the TOML file, which is then called `name`); raises InputError and writes nothing."""
    if not isinstance(profile, str) or not profile:
        raise InputError("profile", f"must be a profile name, got {profile!r}")
    if not isinstance(name_or_path, (str, Path, dict)) or name_or_path in ("", Path()):
        raise InputError("experiment", f"must be a built-in experiment name, a .toml path or a dict "
                                       f"shaped like an experiment file, got {fields.show(name_or_path)}")
    sources: dict = {}
    profiles_seen: set = set()
    if isinstance(name_or_path, dict):
        fields.check_nesting(name_or_path, "experiment")
        if not isinstance(name, str) or not name or any(not (c.isalnum() or c in "-_.") for c in name):
            raise InputError("name", f"an experiment's name holds letters, digits and - _ . only "
                                     f"(it names the results folder), got {name!r}")
        # An experiment defined in memory: named by `name`, relative paths from the working folder.
        path = Path.cwd() / f"{name}.toml"
        sources["<dict>"] = short_hash(name_or_path, 16)
        desc, studies = _parse_data(name_or_path, path, profile, (path,), sources, profiles_seen)
    else:
        path = resolve_path(name_or_path)
        desc, studies = _parse_file(path, profile, (path.resolve(),), sources, profiles_seen)
    if profile != DEFAULT_PROFILE and profile not in profiles_seen:
        known = [DEFAULT_PROFILE] + sorted(profiles_seen - {DEFAULT_PROFILE})
        raise InputError("profile", f"unknown profile '{profile}': {path.name} (with its includes) "
                         f"defines {', '.join(known)} ('{DEFAULT_PROFILE}' is the [experiment] settings "
                         f"when no [profile.{DEFAULT_PROFILE}] is given)")

    names = [s.name for s in studies]
    for i, n in enumerate(names):
        if names.index(n) != i:
            # Included experiments may reuse a study name; keep them apart by their file.
            studies = [replace(s, name=f"{s.experiment}/{s.name}") if names.count(s.name) > 1 else s
                       for s in studies]
            break
    names = [s.name for s in studies]
    for i, n in enumerate(names):
        if names.index(n) != i:
            raise InputError(f"study[{i}].name", f"study name '{n}' is used twice")
    # One label must mean one scene across the whole experiment (cache and file names rely on it).
    by_label: dict = {}
    for si, st in enumerate(studies):
        for j, sc in enumerate(st.scenes):
            prev = by_label.setdefault(sc.label, sc)
            if prev != sc:
                raise InputError(f"study[{si}].scenes[{j}]", f"label '{sc.label}' names two different "
                                 f"scenes ({prev.name} {prev.overrides_dict} and {sc.name} "
                                 f"{sc.overrides_dict}); give one a distinct label")
    if check_scenes:
        loader = scene_loader
        if loader is None:
            from drtlab.kernels.scene_model.scene_file import load_scene as loader
        checked = set()
        for si, st in enumerate(studies):
            for j, sc in enumerate(st.scenes):
                if sc in checked:
                    continue
                checked.add(sc)
                try:
                    loader(sc.name, sc.overrides_dict or None)
                except InputError as e:
                    where = f"study[{si}].scenes[{j}]" if st.experiment == path.stem else \
                        f"{st.experiment}.toml:study '{st.name}'.scenes[{j}]"
                    raise InputError(where, f"scene '{sc.name}': {e.field}: {e.message}") from None
    return Experiment(name=path.stem, description=desc, path=str(path), profile=profile,
                      text_hash=short_hash(sorted(sources.items()), 16), studies=tuple(studies),
                      sources=sources, profiles=tuple(sorted(profiles_seen)))
