"""Scene loader: a TOML scene (built-in name or path) -> a validated `Scene` (see SCENE_FORMAT.md).

This module finds and reads the file and applies overrides; `scene_tables` validates each table.
Validation is strict on purpose: a typo in a research scene silently changes what is measured, so
every problem raises exactly one `InputError` whose `field` is the dotted path of the offending value
(`shapes[2].radius`, `materials.red.albedo`, `camera.fov`) and whose message says what is allowed and
what was given. Nothing here imports Warp: loading a scene must stay cheap and testable anywhere.
"""
from __future__ import annotations

import copy
import json
import re
import tomllib
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from drtlab.errors import InputError
from drtlab.fields import REQUIRED, check_nesting, file_kind, name_lengths, show, too_deep
from drtlab.kernels.scene_model.scene import Scene
from drtlab.kernels.scene_model.scene_tables import TOP_LEVEL_KEYS, build_scene, parse_settings
from drtlab.kernels.scene_model.texture import TEXTURE_SLOTS, slot_key

BUILTIN_DIR = Path(__file__).parent / "scenes"


# ---------------------------------------------------------------------------------------------------
# Public API
# ---------------------------------------------------------------------------------------------------

def builtin_names() -> list[str]:
    """Names of the built-in scenes (the stems of kernels/scene_model/scenes/*.toml), sorted."""
    return sorted(p.stem for p in BUILTIN_DIR.glob("*.toml"))


def output_stem(scene, given: str, overridden: bool = False) -> str:
    """A scene's part of a default output name: its name, with a hash of its content for a scene
    file or overrides, so that two scene files of one name never write the same default file."""
    if overridden or given not in builtin_names():
        return f"{scene.name}-{scene.content_hash()[:8]}"
    return scene.name


def builtin_descriptions() -> dict[str, str]:
    """Built-in name -> its one-line description (each scene is fully validated on the way)."""
    return {name: load_scene(name).description for name in builtin_names()}


def load_scene(name_or_path: str | Path, overrides: dict | None = None) -> Scene:
    """Load a built-in scene by name, or a .toml (or Mitsuba 3 .xml) file by path, applying
    dotted-key `overrides` (to the drtlab scene an .xml file becomes: kernels/scene_model/mitsuba_import.py).

    `overrides` maps dotted keys to values, e.g. {"scene.resolution": [32, 24],
    "materials.gloss1.exponent": 10, "shapes[0].radius": 0.5}; they are applied to the parsed TOML
    before validation, so an override is validated exactly like the file's own value.
    """
    if not isinstance(name_or_path, (str, Path)):
        raise InputError("scene", f"must be a built-in scene name, a .toml or .xml path or a dict shaped like a "
                                  f"scene file, got {type(name_or_path).__name__}")
    path, name, source = _resolve(name_or_path)
    if _is_xml(path):
        from drtlab.kernels.scene_model.mitsuba_import import scene_dict
        data, text = scene_dict(path)
        _apply_overrides(data, overrides or {})
        return _build_xml(data, name, source, text + _overrides_suffix(overrides), path)
    text = _read_text(path)
    data = _parse_toml(text, path)
    _apply_overrides(data, overrides or {})
    _anchor_mesh_files(data, path.parent)
    _anchor_environment_file(data, path.parent)
    _anchor_texture_files(data, path.parent)
    return build_scene(data, name=name, source=source, text=text + _overrides_suffix(overrides))


def scene_data(name_or_path: str | Path, overrides: dict | None = None) -> dict:
    """The scene's table as the loader receives it (overrides applied, not validated): what an
    exporter reads of what the file said rather than of the validated model (a light's direction
    as written, before the loader normalises it)."""
    path, _, _ = _resolve(name_or_path)
    if _is_xml(path):
        from drtlab.kernels.scene_model.mitsuba_import import scene_dict
        data = scene_dict(path)[0]
    else:
        data = _parse_toml(_read_text(path), path)
    _apply_overrides(data, overrides or {})
    return data


def scene_settings(name_or_path: str | Path) -> dict:
    """The validated [scene] table of a scene (description, width, height, spp, integrator, ...), its
    shapes not built: listing the built-ins then neither generates displaced-sphere's mesh nor
    imports trimesh (0.65 s of `drtlab scenes`)."""
    path, _, _ = _resolve(name_or_path)
    if _is_xml(path):
        from drtlab.kernels.scene_model.mitsuba_import import scene_dict
        return parse_settings(scene_dict(path)[0]["scene"])
    return parse_settings(_parse_toml(_read_text(path), path).get("scene", REQUIRED))


def scene_from_dict(d: dict, name: str = "inline", overrides: dict | None = None) -> Scene:
    """Validate an already-parsed scene dict (as tomllib would return it) into a `Scene`."""
    if not isinstance(d, dict):
        raise InputError("scene", f"a scene must be a table of tables ({', '.join(TOP_LEVEL_KEYS)}), "
                                  f"got {show(d)}")
    data = copy.deepcopy(check_nesting(d, "scene"))
    _apply_overrides(data, overrides or {})
    scene = build_scene(data, name=name, source="<dict>", text="")
    # The canonical JSON of the (valid) dict stands in for the TOML text, so content_hash() still
    # identifies the scene; overrides are already part of it.
    scene.text = json.dumps(data, sort_keys=True, separators=(",", ":"), default=repr)
    return scene


# ---------------------------------------------------------------------------------------------------
# Finding and reading the file
# ---------------------------------------------------------------------------------------------------

def _resolve(name_or_path: str | Path) -> tuple[Path, str, str]:
    """(path, scene name, source): a built-in name wins over a same-named file in the cwd."""
    if isinstance(name_or_path, str) and name_or_path in builtin_names():
        return BUILTIN_DIR / f"{name_or_path}.toml", name_or_path, name_or_path
    if not str(name_or_path).strip():
        raise InputError("scene", f"must be a built-in scene name or a path to a .toml or .xml scene "
                                  f"file, got {show(str(name_or_path))}")
    path = Path(name_or_path).expanduser()
    name_lengths(path, "scene")
    if path.is_file():
        return path, path.stem, str(path)
    kind = file_kind(path)
    if kind is not None:
        raise InputError("scene", f"'{name_or_path}' is {kind}, not a scene file (.toml or .xml)")
    if isinstance(name_or_path, Path) or "/" in str(name_or_path) or path.suffix in (".toml", ".xml"):
        raise InputError("scene", f"scene file '{name_or_path}' does not exist")
    raise InputError("scene", f"unknown scene '{name_or_path}'; built-ins: "
                              f"{', '.join(builtin_names())} or a path to a .toml file (or a Mitsuba 3 .xml file)")


def _is_xml(path: Path) -> bool:
    return path.suffix.lower() == ".xml"


def _build_xml(data: dict, name: str, source: str, text: str, path: Path) -> Scene:
    """A Mitsuba file's converted dict through the loader; what the loader refuses is named after the
    file and the drtlab key it became (the file's elements are checked by the importer first)."""
    try:
        return build_scene(data, name=name, source=source, text=text)
    except InputError as exc:
        raise InputError(f"{path.name}: as drtlab's {exc.field}", exc.message) from None


def _read_text(path: Path) -> str:
    try:
        return path.read_bytes().decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError("scene", f"malformed TOML in {path}: not UTF-8 ({exc})") from None
    except OSError as exc:
        raise InputError("scene", f"cannot read {path}: {exc.strerror or exc}") from None


def _parse_toml(text: str, path: Path) -> dict:
    try:
        return check_nesting(tomllib.loads(text), "scene")
    except tomllib.TOMLDecodeError as exc:
        raise InputError("scene", f"malformed TOML in {path}: {exc}") from None
    except RecursionError:
        raise too_deep("scene") from None


def _anchor_mesh_files(data: dict, folder: Path) -> None:
    """A mesh shape's relative `file` names a file next to the scene file, wherever the process runs
    (an inline scene dict keeps paths relative to the working directory)."""
    shapes = data.get("shapes")
    for shape in shapes if isinstance(shapes, list) else ():
        if isinstance(shape, dict) and shape.get("kind") == "mesh" and isinstance(shape.get("file"), str):
            file = Path(shape["file"]).expanduser()
            if not file.is_absolute():
                shape["file"] = str(folder / file)


def _anchor_texture_files(data: dict, folder: Path) -> None:
    """A texture's relative `file` names a file next to the scene file (as meshes')."""
    materials = data.get("materials")
    for body in materials.values() if isinstance(materials, dict) else ():
        for slot in TEXTURE_SLOTS if isinstance(body, dict) else ():
            tex = body.get(slot_key(slot))
            if isinstance(tex, dict) and isinstance(tex.get("file"), str):
                file = Path(tex["file"]).expanduser()
                if not file.is_absolute():
                    tex["file"] = str(folder / file)


def _anchor_environment_file(data: dict, folder: Path) -> None:
    """An environment image's relative `file` names a file next to the scene file (as meshes')."""
    env = data.get("environment")
    if isinstance(env, dict) and isinstance(env.get("file"), str):
        file = Path(env["file"]).expanduser()
        if not file.is_absolute():
            env["file"] = str(folder / file)


def _overrides_suffix(overrides: dict | None) -> str:
    """Canonical text of the overrides, appended to Scene.text so content_hash() sees them."""
    if not overrides:
        return ""
    return "\n# overrides: " + json.dumps(overrides, sort_keys=True, separators=(",", ":"), default=repr)


# ---------------------------------------------------------------------------------------------------
# Overrides
# ---------------------------------------------------------------------------------------------------

_KEY_SEGMENT = re.compile(r"^([A-Za-z0-9_\-]+)((?:\[\d+\])*)$")


def _split_key(key: str) -> list[str | int]:
    """'shapes[2].radius' -> ['shapes', 2, 'radius']."""
    parts: list[str | int] = []
    for segment in key.split("."):
        match = _KEY_SEGMENT.match(segment)
        if not match:
            raise InputError(key, "malformed override key: expected dotted names with optional [index], "
                                  "e.g. 'camera.fov' or 'shapes[2].radius'")
        parts.append(match.group(1))
        parts.extend(int(i) for i in re.findall(r"\[(\d+)\]", match.group(2)))
    return parts


def _apply_overrides(data: dict, overrides: dict) -> None:
    if not isinstance(overrides, dict):
        raise InputError("overrides", f"must be a dict of dotted keys to values, got {show(overrides)}")
    check_nesting(overrides, "overrides")
    for key, value in overrides.items():
        if not isinstance(key, str) or not key:
            raise InputError("overrides", f"keys must be non-empty dotted strings, got {show(key)}")
        parts = _split_key(key)
        container: Any = data
        for depth, part in enumerate(parts[:-1]):
            container = _step(container, part, key, parts[:depth + 1])
        last = parts[-1]
        if isinstance(last, int):
            _step(container, last, key, parts)      # the element must exist to be replaced
        elif not isinstance(container, dict):
            raise InputError(key, f"cannot override: '{_join_key(parts[:-1])}' is not a table")
        container[last] = copy.deepcopy(value)


def _step(container: Any, part: str | int, key: str, prefix: list[str | int]) -> Any:
    """One level down an override path; a missing table or element is an error naming the key."""
    if isinstance(part, int):
        if isinstance(container, list) and part < len(container):
            return container[part]
    elif isinstance(container, dict) and part in container:
        return container[part]
    raise InputError(key, f"cannot override: '{_join_key(prefix)}' does not exist in the scene "
                          "(overrides may add keys to existing tables only)")


def _join_key(parts: Sequence[str | int]) -> str:
    out = ""
    for p in parts:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else p)
    return out
