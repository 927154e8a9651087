"""ARCHITECTURE.md's claims, checked on the code: the table "What may import what" parsed into rules
and enforced on every import (module level and inside functions alike), the files and functions of
"From a scene file to a report", no import cycle between modules, no private name imported across
modules. The rules come from the document, so the document cannot drift from the code."""
import ast
import collections
import functools
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LAYERS = ("estimators", "kernels", "experiments")
TOPS = ("drtlab", *LAYERS, "examples", "tests")     # what a path in the document starts from


def _module(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts if parts[0] == "drtlab" else ["drtlab", *parts])


@functools.cache
def _tree(path: Path) -> ast.AST:
    return ast.parse(path.read_text())


# ---------------------------------------------------------------------------------------------
# The document
# ---------------------------------------------------------------------------------------------

def _section(title: str, text: str | None = None) -> str:
    text = (ROOT / "ARCHITECTURE.md").read_text() if text is None else text
    start = text.index(f"\n## {title}\n")
    end = text.find("\n## ", start + 1)
    return text[start:end if end > 0 else len(text)]


def _rows(section: str) -> list[list[str]]:
    """The cells of a section's table, header and rule left out."""
    lines = [ln for ln in section.splitlines() if ln.startswith("|")][2:]
    return [[c.strip() for c in re.split(r"(?<!\\)\|", ln.strip()[1:-1])] for ln in lines]


def _ticked(text: str) -> list[str]:
    return re.findall(r"`([^`]+)`", text)


def _unparenthesized(text: str) -> str:
    while (shorter := re.sub(r"\([^()]*\)", "", text)) != text:
        text = shorter
    return text


def _bullet(section: str, word: str) -> list[str]:
    """The drtlab/ modules a bullet of the section names (`- **Leaves**, ...`: every .py in it)."""
    bullets = section.split("\n|")[0].split("\n- ")
    line = next(b for b in bullets if b.startswith(f"**{word}**"))
    return [f"drtlab/{t}" for t in _ticked(line) if t.endswith(".py") and "/" not in t]


def _path(token: str, top: str) -> str:
    """A path the document names, repository-relative: from the root when it starts with a top
    folder, else inside the row's top folder (`study/` in a row of experiments/)."""
    return token if token.split("/")[0] in TOPS else f"{top}/{token}"


def _exists(path: str) -> bool:
    return (ROOT / path).is_dir() if path.endswith("/") else (ROOT / path).is_file()


class Rules:
    """What may import what, as the document says it: each folder's grants, the root's leaves and
    surface, the experiments/ leaves. A grant is a path prefix (a folder ends in /, a module is its
    .py) or "" (everything)."""

    PHRASES = ("everything", "the root leaves", "the leaves", "the `experiments/` leaves",
               "the public `drtlab` API", "—")

    def __init__(self, text: str | None = None):
        section = _section("What may import what", text)
        self.errors: list[str] = []
        self.leaves = _bullet(section, "Leaves")
        self.surface = _bullet(section, "The surface")
        rows = {_ticked(r[0])[0]: r for r in _rows(section)}
        self.folders = sorted(rows, key=len, reverse=True)
        self.experiment_leaves = [f"experiments/{t}" for t in _ticked(rows["experiments/"][1])
                                  if t.endswith(".py")]
        self.grants: dict[str, set[str]] = {}
        for folder, cells in rows.items():
            if not _exists(folder):
                self.errors.append(f"{folder}: no such folder")
            if folder == "drtlab/":
                for part in cells[-1].split(";"):
                    who, _, what = part.partition(":")
                    self.grants[{"the surface": "surface", "the leaves": "leaves"}.get(
                        who.strip(), who.strip())] = self._parse(what, "drtlab")
            else:
                self.grants[folder] = self._parse(cells[-1], folder.split("/")[0])

    def _parse(self, text: str, top: str) -> set[str]:
        out = set()
        for item in (i.strip() for i in re.split(r"[,;]", _unparenthesized(text))):
            if item in ("everything",):
                out.add("")
            elif item == "the root leaves":
                out.update(self.leaves)
            elif item == "the `experiments/` leaves":
                out.update(self.experiment_leaves)
            elif item == "the leaves":
                out.update(self.leaves + self.experiment_leaves)
            elif item == "the public `drtlab` API":
                out.add("drtlab/__init__.py")
            elif item == "—" or item.startswith("nothing of `"):
                pass
            elif re.fullmatch(r"`[^`]+`", item):
                path = _path(item.strip("`"), top)
                path = path if path.endswith(("/", ".py")) else f"{path}.py"
                out.add(path)
                if not _exists(path):
                    self.errors.append(f"{item}: no such path ({path})")
            else:
                self.errors.append(f"{item!r}: not a path or one of {self.PHRASES}")
        return out

    def row(self, path: str) -> str:
        """The row a file belongs to: its most specific folder; in drtlab/, surface or leaves."""
        if path.startswith("drtlab/") and "/" not in path[len("drtlab/"):]:
            return "leaves" if path in self.leaves else "surface" if path in self.surface else "?"
        return next((f for f in self.folders if path.startswith(f)), "?")

    def allows(self, source: str, target: str) -> bool:
        mine, theirs = self.row(source), self.row(target)
        if mine == theirs and mine not in ("leaves", "?"):
            return True
        return any(target == g or (g.endswith("/") or g == "") and target.startswith(g)
                   for g in self.grants.get(mine, ()))


def _sources() -> dict[str, Path]:
    """Every module of the package and every example plugin, by repository-relative path."""
    found = [p for folder in ("drtlab", *LAYERS, "examples") for p in (ROOT / folder).rglob("*.py")]
    return {str(p.relative_to(ROOT)): p for p in found}


def _path_graph() -> dict[str, set[str]]:
    modules = _module_files()
    path_of = {m: str(p.relative_to(ROOT)) for m, p in modules.items()}
    return {src: {path_of[t] for t in _module_imports(_tree(p), modules) if t in path_of}
            for src, p in _sources().items()}


def _forbidden(rules: Rules, graph: dict[str, set[str]]) -> list[tuple[str, str]]:
    return sorted((s, t) for s, targets in graph.items() for t in targets if not rules.allows(s, t))


# Left for the registration module: drtlab check composes its strategy with the surface's
# `drtlab.register_strategy`, which moves below the surface when the two register_strategy become
# one. This list must shrink, never grow.


def test_the_import_rules_of_the_document_parse_and_name_real_paths():
    rules = Rules()
    assert rules.errors == []
    assert rules.leaves and rules.surface and rules.experiment_leaves
    # the two bullets split drtlab/ exactly: every module of the root is a leaf or the surface
    root = {str(p.relative_to(ROOT)) for p in (ROOT / "drtlab").glob("*.py")}
    assert sorted(rules.leaves + rules.surface) == sorted(root)
    # every module and example plugin falls in a row of the table
    assert [s for s in _sources() if rules.row(s) == "?"] == []


def test_every_import_is_one_the_document_allows():
    assert _forbidden(Rules(), _path_graph()) == []


def test_the_document_rules_catch_a_forbidden_import_and_a_bad_row():
    # negative controls: the real graph plus a kernel importing the study, a leaf importing a layer
    # and the estimators importing a kernel; and a table with an unparseable item and a wrong path
    rules = Rules()
    graph = _path_graph()
    added = {("kernels/render.py", "experiments/study/runner.py"), ("drtlab/fields.py", "kernels/render.py"),
             ("estimators/registry.py", "kernels/lights.py"), ("kernels/render.py", "drtlab/cli.py")}
    for s, t in added:
        graph[s] = graph[s] | {t}
    assert set(_forbidden(rules, graph)) == added
    text = (ROOT / "ARCHITECTURE.md").read_text()
    bad = text.replace("| the root leaves |", "| the root leaves, the stats, `kernels/nowhere.py` |", 1)
    assert bad != text
    assert sorted(Rules(bad).errors) == ["'the stats': not a path or one of " + str(Rules.PHRASES),
                                         "`kernels/nowhere.py`: no such path (kernels/nowhere.py)"]


def test_no_two_folders_import_each_other():
    """Between two rows of the table imports go one way; a folder and its own subfolder (kernels/
    and kernels/intersection/) are one folder in parts, and the drtlab/ root is the surface."""
    rules, edges = Rules(), collections.defaultdict(set)
    for s, targets in _path_graph().items():
        for t in targets:
            edges[rules.row(s)].add(rules.row(t))
    assert sorted((a, b) for a in edges for b in edges[a]
                  if a < b and a in edges.get(b, ()) and not (a.startswith(b) or b.startswith(a))
                  and "surface" not in (a, b)) == []


# ---------------------------------------------------------------------------------------------
# "From a scene file to a report": every file it names exists, every name is defined there
# ---------------------------------------------------------------------------------------------

def _named_files(cell: str) -> tuple[list[str], list[str]]:
    """(paths, errors) of the files a cell names: a path from a top folder, or a bare file name in
    the folder of the path before it (`experiments/pointsets/analysis.py`, `plots.py`). Inside
    parentheses only .py files and folders count (a `calibration.json` there is an output)."""
    paths, errors, base = [], [], ""
    outside = set(_ticked(_unparenthesized(cell)))
    for token in _ticked(cell):
        kinds = (".py", "/") if token not in outside else (".py", "/", ".toml", ".json", ".sh", ".md")
        if not token.endswith(kinds) or " " in token:
            continue
        path = token if token.split("/")[0] in TOPS else base + token if base else None
        if path is None or not _exists(path):
            errors.append(f"`{token}`: no such file{f' ({path})' if path else ''}")
            continue
        base = path if path.endswith("/") else path.rsplit("/", 1)[0] + "/"
        paths.append(path)
    return paths, errors


def _definitions(path: str) -> tuple[set[str], dict[str, set[str]]]:
    """(names, members by class) a module defines: every def and class at any depth (a factory's
    Warp functions count), module-level assignments; a class's methods, fields and constants."""
    tree = _tree(ROOT / path)
    names, members = set(), {}
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        if isinstance(node, ast.ClassDef):
            members[node.name] = {b.name for b in node.body if isinstance(b, (ast.FunctionDef, ast.ClassDef))} | {
                n.id for b in node.body if isinstance(b, (ast.Assign, ast.AnnAssign))
                for t in (b.targets if isinstance(b, ast.Assign) else [b.target]) for n in ast.walk(t)
                if isinstance(n, ast.Name)}
    names |= {n.id for b in tree.body if isinstance(b, (ast.Assign, ast.AnnAssign))
              for t in (b.targets if isinstance(b, ast.Assign) else [b.target]) for n in ast.walk(t)
              if isinstance(n, ast.Name)}
    return names, members


@functools.cache
def _types() -> frozenset[str]:
    """Every class of the package: a name after `->` is a type, defined wherever it lives."""
    return frozenset(n.name for p in _module_files().values() for n in ast.walk(_tree(p))
                     if isinstance(n, ast.ClassDef))


def _pipeline_errors(text: str | None = None) -> list[str]:
    rows = _rows(_section("From a scene file to a report", text))
    errors = [f"{r[0][:50]}...: {len(r)} cells, not 3 (a bare | in a cell?)" for r in rows if len(r) != 3]
    for step, file_cell, name_cell in (r[:3] for r in rows):
        named, bad = _named_files(file_cell)
        more, bad_more = _named_files(name_cell)           # `make_camera` (`kernels/camera.py`)
        modules = [str(q.relative_to(ROOT)) for p in named + more
                   for q in (sorted((ROOT / p).glob("*.py")) if p.endswith("/") else [ROOT / p])
                   if q.suffix == ".py"]
        defs = {Path(p).stem: _definitions(p) for p in modules}
        bare = _unparenthesized(name_cell)
        for token in _ticked(bare):
            parts = re.split(r"[(\s]", token)[0].split(".")
            if "/" in token:
                continue
            found = any(parts[0] in names and (len(parts) == 1 or parts[1] in members.get(parts[0], ()))
                        for names, members in defs.values())
            found = found or (len(parts) == 2 and parts[0] in defs and parts[1] in defs[parts[0]][0])
            found = found or (f"-> `{token}`" in bare and token in _types())
            if not found:
                bad.append(f"`{token}`: not in {', '.join(modules) or 'any file'}")
        errors += [f"{step[:50]}...: {e}" for e in bad + bad_more]
    return errors


def test_every_file_and_function_of_the_pipeline_table_exists():
    assert _pipeline_errors() == []


def test_the_pipeline_check_sees_a_missing_file_and_a_missing_function():
    text = (ROOT / "ARCHITECTURE.md").read_text()
    bad = text.replace("| `kernels/scene_model/scene_tables.py`, `kernels/scene_model/camera_table.py`, "
                       "`kernels/scene_model/material_table.py` | `build_scene`;",
                       "| `kernels/scene_model/scene_tablez.py`, `kernels/scene_model/camera_table.py`, "
                       "`kernels/scene_model/material_table.py` | `build_scene`;", 1)
    bad = bad.replace("| `experiments/study/config.py` | `load_experiment` |",
                      "| `experiments/study/config.py` | `load_experiments` |", 1)
    assert bad.count("scene_tablez") == 1 and bad.count("load_experiments") == 1
    assert [e.split(": ", 1)[1] for e in _pipeline_errors(bad)] == [
        "`kernels/scene_model/scene_tablez.py`: no such file (kernels/scene_model/scene_tablez.py)",
        "`build_scene`: not in kernels/scene_model/camera_table.py, kernels/scene_model/material_table.py",
        "`load_experiments`: not in experiments/study/config.py"]


def _test_table_errors(text: str | None = None) -> list[str]:
    """Every test file "Where the tests are" names exists: `sub/test_x.py` under tests/, and a bare
    name in the folder of the path before it."""
    errors = []
    for cells in _rows(_section("Where the tests are", text)):
        base = "tests/"
        for token in (t for t in _ticked(cells[-1]) if t.endswith(".py")):
            path = f"tests/{token}" if "/" in token else base + token
            base = path.rsplit("/", 1)[0] + "/"
            if not _exists(path):
                errors.append(f"`{token}`: no such test file ({path})")
    return errors


def test_every_test_file_the_map_names_exists():
    assert _test_table_errors() == []
    # control: a renamed file is caught
    text = (ROOT / "ARCHITECTURE.md").read_text().replace("`test_render_batch.py`", "`test_render_batches.py`", 1)
    assert _test_table_errors(text) == ["`test_render_batches.py`: no such test file "
                                        "(tests/kernels/test_render_batches.py)"]


def test_every_package_is_listed_for_a_non_editable_install():
    """pyproject.toml names its packages one by one (the top-level folders are mapped under drtlab):
    a folder missing there imports from a checkout but not from a built wheel."""
    import tomllib
    listed = set(tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    found = {_module(p) for folder in ("drtlab", *LAYERS) for p in (ROOT / folder).rglob("__init__.py")
             if ".venv" not in p.parts}
    assert found - listed == set(), f"packages missing from pyproject.toml: {sorted(found - listed)}"


def test_the_scene_model_holds_no_warp_code():
    """kernels/scene_model/ reads and checks scenes in numpy: no Warp, and of the rest of kernels/
    only its Warp-free leaves, so a scene loads without the device layer."""
    leaves = {"drtlab.kernels.colour", "drtlab.kernels.imageio", "drtlab.kernels.filters"}
    bad = []
    for path in (ROOT / "kernels" / "scene_model").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0:
                names = [node.module]
            else:
                continue
            bad += [(path.name, n) for n in names
                    if n.split(".")[0] == "warp" or n == "drtlab.warp_runtime"
                    or (n.startswith("drtlab.kernels.") and n not in leaves
                        and not n.startswith("drtlab.kernels.scene_model"))]
    assert bad == []


# ---------------------------------------------------------------------------------------------
# Module cycles and private names, every import counted (module level and inside functions)
# ---------------------------------------------------------------------------------------------

def _module_files() -> dict[str, Path]:
    return {_module(p): p for folder in ("drtlab", *LAYERS) for p in (ROOT / folder).rglob("*.py")}


def _module_imports(tree: ast.AST, modules) -> set[str]:
    """The modules a parsed file imports anywhere in it: `from P import n` is P.n where that is a
    module, else P (so `from drtlab import render` is the package `drtlab`, the surface)."""
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names if a.name.split(".")[0] == "drtlab")
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and (node.module or "").split(".")[0] == "drtlab":
            out.update(f"{node.module}.{a.name}" if f"{node.module}.{a.name}" in modules else node.module
                       for a in node.names)
    return out


def _module_graph() -> dict[str, set[str]]:
    files = _module_files()
    return {m: _module_imports(_tree(p), files) for m, p in files.items()}


def _cycles(graph: dict[str, set[str]]) -> list[tuple[str, ...]]:
    """Every elementary cycle of `graph`, each once, starting at its smallest module."""
    found = []

    def walk(start, path, on_path):
        for nxt in sorted(graph.get(path[-1], ())):
            if nxt == start:
                found.append(tuple(path))
            elif nxt > start and nxt not in on_path and nxt in graph:
                on_path.add(nxt)
                walk(start, path + [nxt], on_path)
                on_path.discard(nxt)

    for start in sorted(graph):
        walk(start, [start], {start})
    return found


# Left for the registration module (estimators/plugins.py is being split in two): the registry loads
# the installed plugins' entry points through plugins.py, whose registration half imports the
# registry back. Split off the loader (load_plugin, load_entry_points, `_loading`), which imports no
# registry, and both go. This list must shrink, never grow: the test fails on any other cycle and
# on one of these that is gone.


def test_no_import_cycle_between_modules():
    assert _cycles(_module_graph()) == []


def test_the_cycle_finder_sees_cycles_through_imports_inside_functions(tmp_path):
    # negative control: a synthetic graph with a two-cycle, a three-cycle and a self-import, and the
    # real graph with one edge a function-level import would add (a kernel importing the surface)
    graph = {"a": {"b"}, "b": {"a", "c"}, "c": {"d"}, "d": {"b"}, "e": {"e", "a"}, "f": {"a"}}
    assert sorted(_cycles(graph)) == [("a", "b"), ("b", "c", "d"), ("e",)]
    src = "def f():\n    from drtlab import render\n    import drtlab.kernels.render\n"
    files = _module_files()
    assert _module_imports(ast.parse(src), files) == {"drtlab", "drtlab.kernels.render"}
    real = _module_graph()
    real["drtlab.kernels.render"] = real["drtlab.kernels.render"] | {"drtlab"}
    assert ("drtlab", "drtlab.kernels.render") in _cycles(real)


def _private_imports(tree: ast.AST) -> list[str]:
    """Underscore names a parsed file takes from a drtlab module: `from M import _x`, and `_x` read
    off a drtlab module it imported (`import drtlab.m as m; m._x`). Dunders are public."""
    def private(name):
        return name.startswith("_") and not name.startswith("__")
    bad, modules = [], set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.level == 0 and (node.module or "").split(".")[0] == "drtlab":
            bad += [f"{node.module}.{a.name}" for a in node.names if private(a.name)]
            modules.update(a.asname or a.name for a in node.names)
        elif isinstance(node, ast.Import):
            modules.update(a.asname or a.name.split(".")[0] for a in node.names
                           if a.name.split(".")[0] == "drtlab")
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and private(node.attr):
            base = node.value
            while isinstance(base, ast.Attribute):
                base = base.value
            if isinstance(base, ast.Name) and base.id in modules:
                bad.append(f"{ast.unparse(node.value)}.{node.attr}")
    return bad


def test_no_private_name_is_imported_across_modules():
    found = {str(p.relative_to(ROOT)): bad for p in _module_files().values()
             if (bad := _private_imports(_tree(p)))}
    assert found == {}


def test_the_private_import_finder_sees_both_forms():
    src = ("from drtlab.kernels.render import _resolve_scene, render, __version__\n"
           "def f():\n    from drtlab.estimators import registry\n    return registry._POINTSET_MODULES\n"
           "import drtlab.kernels.render as r\nr._x\nimport numpy as np\nnp._private\n")
    assert sorted(_private_imports(ast.parse(src))) == ["drtlab.kernels.render._resolve_scene",
                                                        "r._x", "registry._POINTSET_MODULES"]


MAX_LINES = 450     # past this a module usually holds two concepts: one concept, one module


def _too_long(paths) -> dict[str, int]:
    lengths = {str(p): len(p.read_text().splitlines()) for p in paths}
    return {p: n for p, n in lengths.items() if n > MAX_LINES}


def test_no_package_module_is_over_450_lines(tmp_path):
    assert _too_long(p for folder in ("drtlab", *LAYERS) for p in (ROOT / folder).rglob("*.py")) == {}
    # The check itself sees a long one, and not one of exactly the limit.
    (tmp_path / "long.py").write_text("x = 1\n" * (MAX_LINES + 1))
    (tmp_path / "fits.py").write_text("x = 1\n" * MAX_LINES)
    assert _too_long([tmp_path / "long.py", tmp_path / "fits.py"]) == {str(tmp_path / "long.py"): MAX_LINES + 1}
