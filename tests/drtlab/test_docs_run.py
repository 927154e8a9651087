"""The documentation runs (issue 20): every fenced block of README.md, experiments/README.md and
kernels/SCENE_FORMAT.md is executed or checked, at small settings, so that no example drifts from
the code again.

* Shell blocks (```sh, and untagged blocks whose first line is a command): each command, in order,
  in one scratch folder per block (so `info results/renders/dof.exr` reads what `render` wrote):
  `drtlab ...` runs in this process with its sizes shrunk (SHRINK: --spp, --res, --n, ...); the
  long-running ones (experiments, `python -m` tools) are parsed by their own parser and their
  experiment loaded; `make T` needs a Makefile target T; `dask` needs .venv/bin/dask.
* Python blocks run as they are written (the README keeps its example small).
* TOML blocks: an experiment file is loaded by the experiment loader; a scene file is loaded by the
  scene loader and rendered at 8 pixels; SCENE_FORMAT's reference block (every key) is checked key
  by key against the loader's key lists, and its documented defaults against the loader's.
"""
from __future__ import annotations

import re
import shlex
import tomllib
from pathlib import Path

import numpy as np
import pytest

from drtlab.cli import build_parser, main
from drtlab.kernels.scene_file import scene_from_dict

from repo_paths import REPO

DOCS = ("README.md", "experiments/README.md", "kernels/SCENE_FORMAT.md")
# Flag -> the value a command runs with here (the documented value is only parsed).
SHRINK = {"--spp": "2", "--res": "16", "--n": "16", "--realisations": "2", "--pixels": "256",
          "--samples": "20000", "--batch-spp": "1", "--seconds": "0.5"}
# Commands that take minutes whatever their flags: parsed (and their experiment loaded), not run.
PARSE_ONLY = ("experiment",)
# Exit codes a command may document besides 0: validate and lobe exit 1 when a test rejects.
VERDICT_COMMANDS = ("validate", "lobe")
COMMAND_WORDS = ("make", "drtlab", "python", "dask")


def blocks(doc: str) -> list[tuple[str, int, str]]:
    """(info string, first line number, text) of every fenced block of `doc`."""
    out, lines = [], (REPO / doc).read_text().splitlines()
    i = 0
    while i < len(lines):
        m = re.match(r"^```(\S*)\s*$", lines[i])
        if m:
            j = next(k for k in range(i + 1, len(lines)) if lines[k].startswith("```"))
            out.append((m.group(1), i + 2, "\n".join(lines[i + 1:j])))
            i = j
        i += 1
    return out


def _all_blocks():
    return [pytest.param(doc, lang, line, text, id=f"{doc}:{line}")
            for doc in DOCS for lang, line, text in blocks(doc)]


def commands(text: str) -> list[list[str]]:
    """The block's commands as argument lists: continuation lines joined, comments dropped."""
    joined = re.sub(r"\\\n\s*", " ", text)
    out = []
    for line in joined.splitlines():
        words = shlex.split(line, comments=True)
        if words:
            out.append(words)
    return out


def _program(words: list[str]) -> tuple[list[str], list[str]]:
    """(leading VAR=value words, the command from its program on)."""
    k = 0
    while k < len(words) and re.match(r"^[A-Z_]+=", words[k]):
        k += 1
    return words[:k], words[k:]


def _is_command(words: list[str]) -> bool:
    _, cmd = _program(words)
    return bool(cmd) and not cmd[0].endswith("/") and Path(cmd[0]).name in COMMAND_WORDS


def shrunk(args: list[str]) -> list[str]:
    out = list(args)
    for k, a in enumerate(out[:-1]):
        if a in SHRINK:
            out[k + 1] = SHRINK[a]
    if out and out[0] == "validate" and "--pixels" not in out:
        out += ["--pixels", SHRINK["--pixels"]]
    if out and out[0] == "lobe" and "--samples" not in out:
        out += ["--samples", SHRINK["--samples"]]
    return out


def _parse_only(args: list[str]) -> None:
    from drtlab.experiments.study.config import load_experiment
    ns = build_parser().parse_args(args)
    if ns.command == "experiment" and (not ns.experiment.endswith(".toml")
                                       or Path(ns.experiment).is_file()):
        load_experiment(ns.experiment, ns.profile)


def _python_module(words: list[str]) -> None:
    """`python -m MODULE ARGS`: the module exists and its own parser accepts ARGS."""
    import importlib
    assert words[1] == "-m", words
    module = importlib.import_module(words[2])
    module.build_parser().parse_args(words[3:])


def _make_target(target: str) -> None:
    """make knows the target (an explicit rule or the studies' static pattern rule): `make -n`
    prints its commands without running them, and fails on an unknown target."""
    import subprocess
    r = subprocess.run(["make", "-n", "-C", str(REPO), target], capture_output=True, text=True)
    assert r.returncode == 0 and "No rule to make target" not in r.stderr, f"no make target {target}"


@pytest.fixture
def scratch(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("DRTLAB_RESULTS", str(tmp_path / "results"))
    monkeypatch.setenv("DRTLAB_GT_DIR", str(tmp_path / "results" / "ground-truth"))
    return tmp_path


def run_shell_block(text: str, where: str, capsys) -> None:
    cmds = commands(text)
    for words in cmds:
        assert _is_command(words), f"{where}: not a command this test knows: {' '.join(words)}"
        _, cmd = _program(words)
        name = Path(cmd[0]).name
        if name == "make":
            _make_target(cmd[1])
        elif name == "dask":
            assert (REPO / ".venv" / "bin" / "dask").is_file(), "dask is not installed"
        elif name == "python":
            _python_module(cmd)
        elif cmd[1:2] in (["--version"], ["--help"]):
            with pytest.raises(SystemExit) as e:
                main(cmd[1:])
            assert e.value.code == 0
        elif cmd[1] in PARSE_ONLY:
            _parse_only(cmd[1:])
        else:
            args = shrunk(cmd[1:])
            rc = main(args)
            err = capsys.readouterr().err
            allowed = (0, 1) if cmd[1] in VERDICT_COMMANDS else (0,)
            assert rc in allowed, f"{where}: drtlab {' '.join(args)} exited {rc}: {err}"
            assert "Traceback" not in err


def run_python_block(text: str, where: str) -> None:
    code = compile(text, where, "exec")
    exec(code, {"__name__": "__doc_example__"})


def check_toml_block(text: str, where: str, tmp_path: Path) -> None:
    data = tomllib.loads(text)
    if "experiment" in data:
        from drtlab.experiments.study.config import load_experiment
        path = tmp_path / "doc-experiment.toml"
        path.write_text(text)
        for profile in ["quick", *data.get("profile", {})]:
            load_experiment(str(path), profile)
    elif text.lstrip().startswith("# reference"):
        check_scene_reference(data)
    else:
        from drtlab.kernels.render import render
        scene = scene_from_dict(data)
        image = render(scene, spp=1, res=8)
        assert np.all(np.isfinite(image)) and np.any(image > 0), f"{where}: a black image"


# ---------------------------------------------------------------------------------------------------
# SCENE_FORMAT's reference block
# ---------------------------------------------------------------------------------------------------

MINIMAL = {"scene": {"description": "d"}, "camera": {"position": [0, 1, 5], "look_at": [0, 1, 0]},
           "materials": {"m": {}},
           "shapes": [{"kind": "sphere", "material": "m", "center": [0, 0, 0], "radius": 1}]}


def _material_keys(T) -> set[str]:
    """Every key some material kind accepts (the loader's table of kinds, in either spelling)."""
    if hasattr(T, "MATERIAL_KEYS"):
        return set().union(*T.MATERIAL_KEYS.values())
    return {k for spec in T.KIND_BY_NAME.values() for k in spec.keys}


def check_scene_reference(ref: dict) -> None:
    from drtlab.kernels import scene_tables as T
    from drtlab.kernels.transforms import TRANSFORM_KEYS
    assert set(ref["scene"]) == set(T.SCENE_KEYS)
    assert set(ref["camera"]) == set(T.CAMERA_KEYS)
    for kind, keys in T.SHAPE_KEYS.items():
        documented = set().union(*(s for s in ref["shapes"] if s["kind"].split()[0] == kind))
        assert documented <= set(keys), (kind, documented - set(keys))
    shape_keys = set().union(*ref["shapes"])
    assert shape_keys >= set(T.SHAPE_COMMON_KEYS)
    assert set(ref["shapes"][-1]["transform"]) <= set(TRANSFORM_KEYS)
    for light in ref["lights"]:
        assert set(light) == set(T.LIGHT_KEYS[light["kind"]])
    from drtlab.kernels.environment_map import KEYS as ENVIRONMENT_KEYS
    assert set(ref["environment"]) == set().union(*ENVIRONMENT_KEYS.values())
    (material,) = ref["materials"].values()
    assert set(material) == _material_keys(T)
    # "Every field not marked required has the default shown": the loader's defaults.
    scene = scene_from_dict(MINIMAL)
    s, c = ref["scene"], ref["camera"]
    assert [scene.width, scene.height] == s["resolution"]
    assert (scene.spp, scene.integrator, scene.max_depth, scene.russian_roulette, scene.rr_depth) == \
        (s["spp"], s["integrator"], s["max_depth"], s["russian_roulette"], s["rr_depth"])
    assert scene.background.tolist() == s["background"]
    assert scene.camera.up.tolist() == c["up"] and scene.camera.vfov_deg == c["fov"]
    assert list(scene.camera.shutter) == c["shutter"]
    assert scene.materials[0].kind == material["kind"]
    assert scene.materials[0].albedo.tolist() == material["albedo"]
    assert scene.shapes[0].velocity.tolist() == ref["shapes"][0]["velocity"]


# ---------------------------------------------------------------------------------------------------
# The tests
# ---------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("doc,lang,line,text", _all_blocks())
def test_documented_block_runs(doc, lang, line, text, scratch, capsys):
    where = f"{doc}:{line}"
    if lang == "python":
        run_python_block(text, where)
    elif lang == "toml":
        check_toml_block(text, where, scratch)
    elif lang == "sh" or (lang == "" and commands(text) and _is_command(commands(text)[0])):
        run_shell_block(text, where, capsys)
    else:
        assert lang == "", f"{where}: a ```{lang} block this test does not know how to run"


def test_every_doc_has_blocks_this_test_runs():
    for doc in DOCS:
        kinds = {lang for lang, _, text in blocks(doc)}
        assert kinds & {"sh", "python", "toml", ""}, doc


def test_readme_scene_table_lists_every_built_in_scene():
    from drtlab.kernels.scene_file import builtin_names
    table = re.findall(r"^\| `([a-z0-9-]+)` \|", (REPO / "README.md").read_text(), re.M)
    assert sorted(table) == sorted(builtin_names())


def test_help_examples_name_real_scene_values():
    """`render --help`'s --set example must apply to the scene it names."""
    from drtlab.kernels.scene_file import load_scene
    render_cmd = build_parser()._subparsers._group_actions[0].choices["render"]
    text = " ".join(a.help for a in render_cmd._actions if a.dest == "set")
    for key, scene in re.findall(r"--set (\S+?)=\S+ \((\w[\w-]*)\)", text):
        load_scene(scene, {key: 50})           # raises InputError for a key the scene lacks
    assert re.findall(r"--set (\S+?)=\S+ \((\w[\w-]*)\)", text), text


def test_a_stale_key_in_a_block_fails(scratch, capsys):
    """Negative control: the same machinery rejects what the issue found in the README."""
    from drtlab.errors import InputError
    with pytest.raises(InputError):
        run_python_block('import drtlab\ndrtlab.load_scene("glossy", {"materials.gloss1.exponent": 50})',
                         "control")
    with pytest.raises(AssertionError):
        run_shell_block(".venv/bin/drtlab render glossy --set materials.gloss.exponent=50", "control",
                        capsys)
    with pytest.raises(AssertionError):
        run_shell_block("make no-such-target", "control", capsys)
    with pytest.raises(AssertionError):
        check_scene_reference({**tomllib.loads(_reference_block()), "camera": {"shutter": [0.0, 1.0]}})


def _reference_block() -> str:
    return next(t for lang, _, t in blocks("kernels/SCENE_FORMAT.md")
                if lang == "toml" and t.lstrip().startswith("# reference"))
