"""The documentation runs: every fenced block of README.md, every docs/*.md page (a new page is
covered by being there), experiments/README.md and kernels/scene_model/SCENE_FORMAT.md is executed or checked,
at small settings, so that no example drifts from the code.

Each block runs in its own scratch folder, which holds links to the repository's source folders
(so documented paths such as examples/plugins/r2.py resolve as from the repository root) and its
own results/ (so nothing is written into the checkout). By the block's info string:

* Shell blocks (```sh, and untagged blocks whose first line is a command): each command, in order
  (so `info results/renders/dof.exr` reads what `render` wrote): `drtlab ...` runs in this process
  with its sizes shrunk (SHRINK: --spp, --res, --n, ...); the commands that take long whatever their
  flags (PARSE_ONLY: experiments, the scorecard, the interval audit) and `python -m` tools are
  parsed by their own parser, after the plugins they name are loaded, and an experiment is loaded;
  `make T` needs a Makefile target T; `dask` needs .venv/bin/dask; `python -m pytest` needs the
  options it names to be the suite's and the paths to exist.
* ```python blocks run as they are written (pages keep their examples small), from a file, so that
  Warp can read the source of the functions they define; what they register is unregistered after.
* ```python template blocks are checked differently: a block that shows a shape to fill in rather
  than a program is compiled, and every module and name it imports and every `drtlab.NAME` it uses
  must exist.
* ```text blocks are output shown to the reader and are not run; an untagged block whose first line
  is not a command is treated the same way.
* TOML blocks: an experiment file is loaded by the experiment loader; a scene file is loaded by the
  scene loader and rendered at 8 pixels; SCENE_FORMAT's reference block (every key) is checked key
  by key against the loader's key lists, and its documented defaults against the loader's.
Any other info string fails: a block this test cannot check is not allowed.
"""
from __future__ import annotations

import re
import shlex
import tomllib
from pathlib import Path

import numpy as np
import pytest

from drtlab.cli import build_parser, main
from drtlab.kernels.scene_model.scene_file import scene_from_dict

from repo_paths import REPO

DOCS = ("README.md", *sorted(str(p.relative_to(REPO)) for p in (REPO / "docs").glob("*.md")),
        "experiments/README.md", "kernels/scene_model/SCENE_FORMAT.md")
# The guide's own pages: the newcomer's README and the manual in docs/.
GUIDE = ("README.md", *(d for d in DOCS if d.startswith("docs/")))
README_MAX_LINES = 200
# Repository folders a block may name by a relative path (linked into its scratch folder).
SOURCE_FOLDERS = ("drtlab", "kernels", "estimators", "experiments", "examples", "tests", "docs")
# Flag -> the value a command runs with here (the documented value is only parsed).
SHRINK = {"--spp": "2", "--res": "16", "--n": "16", "--realisations": "2", "--pixels": "256",
          "--samples": "20000", "--batch-spp": "1", "--seconds": "0.5"}
# Commands that take minutes whatever their flags: parsed (and their experiment loaded), not run.
PARSE_ONLY = ("experiment", "check", "audit-intervals")
# Exit codes a command may document besides 0: validate and lobe exit 1 when a test rejects.
VERDICT_COMMANDS = ("validate", "lobe")
COMMAND_WORDS = ("make", "drtlab", "python", "dask")
# Info strings of blocks that are not run (output shown to the reader).
SHOWN_ONLY = ("text",)


def blocks(doc: str) -> list[tuple[str, int, str]]:
    """(info string, first line number, text) of every fenced block of `doc`; the info string's
    words joined by one space ("python template")."""
    return fenced_blocks((REPO / doc).read_text())


def fenced_blocks(markdown: str) -> list[tuple[str, int, str]]:
    out, lines = [], markdown.splitlines()
    i = 0
    while i < len(lines):
        m = re.match(r"^```(.*)$", lines[i])
        if m:
            j = next(k for k in range(i + 1, len(lines)) if lines[k].startswith("```"))
            out.append((" ".join(m.group(1).split()), i + 2, "\n".join(lines[i + 1:j])))
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
    from drtlab.estimators.plugins import load_plugins, plugin_args
    from drtlab.experiments.study.config import load_experiment
    load_plugins(plugin_args(args))          # as `drtlab` does before parsing: NAME may be a plugin's
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


def _pytest_command(words: list[str]) -> None:
    """`python -m pytest ARGS`: every --option is one the suite's conftest adds, every path exists."""
    conftest = (REPO / "tests" / "conftest.py").read_text()
    for w in words:
        if w.startswith("--"):
            assert f'"{w.split("=")[0]}"' in conftest, f"pytest has no option {w} here"
        elif not w.startswith("-"):
            assert (REPO / w).exists(), f"pytest: no such path {w}"


def _make_target(target: str) -> None:
    """make knows the target (an explicit rule or the studies' static pattern rule): `make -n`
    prints its commands without running them, and fails on an unknown target."""
    import subprocess
    r = subprocess.run(["make", "-n", "-C", str(REPO), target], capture_output=True, text=True)
    assert r.returncode == 0 and "No rule to make target" not in r.stderr, f"no make target {target}"


@pytest.fixture
def scratch(tmp_path, monkeypatch):
    for name in SOURCE_FOLDERS:
        (tmp_path / name).symlink_to(REPO / name, target_is_directory=True)
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
        elif name == "python" and cmd[1:3] == ["-m", "pytest"]:
            _pytest_command(cmd[3:])
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


def run_python_block(text: str, where: str, folder: Path | None = None) -> None:
    """Run the block from a file in `folder` (Warp reads a kernel function's source from its file)."""
    if folder is None:
        exec(compile(text, where, "exec"), {"__name__": "__doc_example__"})
        return
    path = folder / "doc_block.py"
    path.write_text(text)
    exec(compile(text, str(path), "exec"), {"__name__": "__doc_example__", "__file__": str(path)})


def check_template_block(text: str, where: str) -> None:
    """A block that shows a shape rather than a program: it compiles, and what it names exists."""
    import ast
    import importlib
    import drtlab
    tree = ast.parse(compile(text, where, "exec", flags=ast.PyCF_ONLY_AST))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                importlib.import_module(alias.name)
        elif isinstance(node, ast.ImportFrom):
            module = importlib.import_module(node.module)
            for alias in node.names:
                assert hasattr(module, alias.name), f"{where}: {node.module} has no {alias.name}"
        elif (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
              and node.value.id == "drtlab"):
            assert hasattr(drtlab, node.attr), f"{where}: drtlab has no {node.attr}"


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


def check_xml_block(text: str, where: str, tmp_path: Path) -> None:
    """A Mitsuba 3 scene: it loads through the importer (kernels/scene_model/mitsuba_import.py), every shape kept."""
    from drtlab.kernels.scene_model.scene_file import load_scene
    path = tmp_path / "doc-scene.xml"
    path.write_text(text)
    scene = load_scene(path)
    assert len(scene.shapes) == text.count("<shape "), f"{where}: shapes lost"
    assert scene.emitter_shapes(), f"{where}: no light"


# ---------------------------------------------------------------------------------------------------
# SCENE_FORMAT's reference block
# ---------------------------------------------------------------------------------------------------

MINIMAL = {"scene": {"description": "d"}, "camera": {"position": [0, 1, 5], "look_at": [0, 1, 0]},
           "materials": {"m": {}},
           "shapes": [{"kind": "sphere", "material": "m", "center": [0, 0, 0], "radius": 1}]}


def _material_keys() -> set[str]:
    """Every key some material kind accepts (the kind table's)."""
    from drtlab.kernels.scene_model.material_kinds import KIND_BY_NAME
    return {k for spec in KIND_BY_NAME.values() for k in spec.keys}


def check_scene_reference(ref: dict) -> None:
    from drtlab.kernels.scene_model import scene_tables as T
    from drtlab.kernels.scene_model.camera_table import CAMERA_KEYS
    from drtlab.kernels.scene_model.transforms import TRANSFORM_KEYS
    assert set(ref["scene"]) == set(T.SCENE_KEYS)
    assert set(ref["camera"]) == set(CAMERA_KEYS)
    for kind, keys in T.SHAPE_KEYS.items():
        documented = set().union(*(s for s in ref["shapes"] if s["kind"].split()[0] == kind))
        assert documented <= set(keys), (kind, documented - set(keys))
    shape_keys = set().union(*ref["shapes"])
    assert shape_keys >= set(T.SHAPE_COMMON_KEYS)
    assert set(ref["shapes"][-1]["transform"]) <= set(TRANSFORM_KEYS)
    for kind, keys in T.LIGHT_KEYS.items():    # a kind's alternatives (direction, look_at) in two blocks
        assert set().union(*(x for x in ref["lights"] if x["kind"] == kind)) == set(keys), kind
    from drtlab.kernels.scene_model.environment_map import KEYS as ENVIRONMENT_KEYS
    assert set(ref["environment"]) == set().union(*ENVIRONMENT_KEYS.values())
    (material,) = ref["materials"].values()
    assert set(material) == _material_keys()
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
def test_documented_block_runs(doc, lang, line, text, scratch, capsys, clean_registry):
    where = f"{doc}:{line}"
    if lang == "python":
        run_python_block(text, where, scratch)
    elif lang == "python template":
        check_template_block(text, where)
    elif lang in SHOWN_ONLY:
        pass
    elif lang == "toml":
        check_toml_block(text, where, scratch)
    elif lang == "xml":
        check_xml_block(text, where, scratch)
    elif lang == "sh" or (lang == "" and commands(text) and _is_command(commands(text)[0])):
        run_shell_block(text, where, capsys)
    else:
        assert lang == "", f"{where}: a ```{lang} block this test does not know how to run"


def test_every_doc_has_blocks_this_test_runs():
    for doc in DOCS:
        kinds = {lang for lang, _, text in blocks(doc)}
        assert kinds & {"sh", "python", "toml", ""}, doc


def test_scene_table_lists_every_built_in_scene():
    from drtlab.kernels.scene_model.scene_file import builtin_names
    table = re.findall(r"^\| `([a-z0-9-]+)` \|", (REPO / "docs" / "scenes.md").read_text(), re.M)
    assert sorted(table) == sorted(builtin_names())


def test_help_examples_name_real_scene_values():
    """`render --help`'s --set example must apply to the scene it names."""
    from drtlab.kernels.scene_model.scene_file import load_scene
    render_cmd = build_parser()._subparsers._group_actions[0].choices["render"]
    text = " ".join(a.help for a in render_cmd._actions if a.dest == "set")
    for key, scene in re.findall(r"--set (\S+?)=\S+ \((\w[\w-]*)\)", text):
        load_scene(scene, {key: 50})           # raises InputError for a key the scene lacks
    assert re.findall(r"--set (\S+?)=\S+ \((\w[\w-]*)\)", text), text


def test_a_stale_key_in_a_block_fails(scratch, capsys):
    """Negative control: the same machinery rejects a stale key, a stale target and a wrong default."""
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
    return next(t for lang, _, t in blocks("kernels/scene_model/SCENE_FORMAT.md")
                if lang == "toml" and t.lstrip().startswith("# reference"))


# ---------------------------------------------------------------------------------------------------
# The guide's shape: a short README, and pages that cite no tracker or date
# ---------------------------------------------------------------------------------------------------

# What a user's guide must not say: a tracker reference ("#21", "issue 21", "issues #10") or a
# dated anecdote (a calendar date, "today", "this session"); measurements with dates live in
# CHANGELOG.md. Code (fenced blocks, `spans`) and link targets are not prose and are left out.
FORBIDDEN = {"issue number": re.compile(r"(?<![\w&])#\d+\b|\bissues? #?\d+", re.I),
             "date": re.compile(r"\b20\d\d-\d\d-\d\d\b"),
             "dated anecdote": re.compile(r"\btoday\b|\bthis session\b|\bwhen .{1,40} was filed\b", re.I)}


def prose(markdown: str) -> str:
    """The Markdown without its fenced blocks, inline code spans and link/URL targets."""
    text = re.sub(r"^```.*?^```[^\n]*$", "", markdown, flags=re.M | re.S)
    text = re.sub(r"`[^`\n]*`", "", text)
    text = re.sub(r"\]\([^)\s]*\)", "]", text)
    return re.sub(r"https?://\S+", "", text)


def guide_problems(markdown: str) -> list[str]:
    found = []
    for line_no, line in enumerate(prose(markdown).splitlines(), 1):
        for kind, pattern in FORBIDDEN.items():
            found += [f"{kind} {m.group(0)!r}" for m in pattern.finditer(line)]
    return found


def test_readme_is_a_short_page():
    lines = (REPO / "README.md").read_text().splitlines()
    assert len(lines) <= README_MAX_LINES, f"README.md has {len(lines)} lines; the manual goes in docs/"


@pytest.mark.parametrize("doc", GUIDE)
def test_guide_pages_cite_no_issue_or_date(doc):
    assert guide_problems((REPO / doc).read_text()) == [], doc


def test_guide_checks_catch_what_they_forbid():
    """Negative control: each forbidden form is found in prose and left alone in code and links."""
    bad = "Fixed in #21.\nSee issue 21 and issues #10.\nMeasured on 2026-12-03.\nToday it is faster.\n"
    found = guide_problems(bad)
    assert [f.split(" '")[0] for f in found] == ["issue number", "issue number", "issue number",
                                                 "date", "dated anecdote"], found
    fine = ("A heading link [x](#section-2), `git show #21`, https://host/issues/21, C# 3.\n"
            "```sh\ngit log --grep '#21'   # 2026-12-03\n```\n")
    assert guide_problems(fine) == []
    assert len(fenced_blocks("```python template\nx = ...\n```\n")) == 1
    with pytest.raises(AssertionError):
        check_template_block("import drtlab\ndrtlab.no_such_function(...)", "control")
    with pytest.raises(SyntaxError):
        check_template_block("def f(:\n    ...", "control")
