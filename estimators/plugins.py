"""A user's own point sets, from their own file or package, without forking drtlab.

Three ways in, all ending in the same `register_*` calls a built-in's module makes:

* `--plugin FILE_OR_MODULE` on any command (repeatable), read before the command's own arguments;
* `plugins = ["my_sets.py"]` in an experiment file's [experiment] table (paths relative to it);
* the entry-point group `drtlab.plugins` of an installed package (each entry a module, imported,
  or a callable, called), loaded the first time a name is not found among the registered ones.

A plugin is a Python file or module that calls `drtlab.register_pointset(...)` (or another of
drtlab/registration.py's register_* functions, the one place they live) when imported. What
it registers carries a fingerprint (the hash of the plugin's source, or of a table's points), part
of every kernel key and run key: an edited plugin recompiles and re-renders, an unchanged one reuses
the kernel cache and the stored runs. The manifest of every result lists the loaded plugins with
the hash of their source (`manifest()`), and a sweep on a Dask cluster ships them to the workers
(`shipped()` / `ensure_shipped`): a file plugin travels as its text, a module by its name (it must
be installed on the workers).

Bad plugins are one line naming the plugin and what is wrong (missing file, nothing registered, an
error while importing it, a Warp compile error at the user's file and line, a wrong signature,
values outside [0, 1), a name that clashes with a built-in), raised as InputError before any work.
"""
from __future__ import annotations

import hashlib
import importlib
import importlib.util
import inspect
import re
import sys
import tempfile
import traceback
from dataclasses import dataclass
from pathlib import Path

from drtlab.errors import InputError
from drtlab.fields import file_kind, name_lengths

ENTRY_POINT_GROUP = "drtlab.plugins"
NAME = re.compile(r"^[a-z][a-z0-9_-]{0,39}$")


@dataclass(frozen=True)
class Plugin:
    spec: str                       # as given: a path or a module name
    module: str                     # the Python module it was imported as
    path: str | None                # its source file
    sha256: str                     # of that file's bytes
    registered: tuple = ()          # "pointset:NAME", ...

    def to_json(self) -> dict:
        return {"spec": self.spec, "module": self.module, "path": self.path, "sha256": self.sha256,
                "registered": list(self.registered)}


_loaded: dict[str, Plugin] = {}       # by resolved path or module name
# Every registration a plugin may make (docs/plugins.md, `--plugin`'s help, "registers nothing").
REGISTER_CALLS = ("drtlab.register_pointset(...), register_light_selection(...), "
                  "register_lobe_sampler(...), register_strategy(...), register_integrator(...) or "
                  "register_metric(...)")
_loading: list[list] = []             # registrations of the plugins being imported (nested)
_entry_points_done = False


def loaded() -> list[Plugin]:
    return list(_loaded.values())


def manifest() -> list[dict]:
    """The loaded plugins, as every result's manifest records them."""
    return [p.to_json() for p in _loaded.values()]


def _sha(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


# ---------------------------------------------------------------------------------------------------
# Registration
# ---------------------------------------------------------------------------------------------------

def _source_fingerprint(*functions) -> str:
    """Hash of the Warp functions' Python source: what an in-notebook registration compiles from."""
    h = hashlib.sha256()
    for f in functions:
        try:
            h.update(inspect.getsource(getattr(f, "func", f)).encode())
        except (OSError, TypeError):
            h.update(repr(id(f)).encode())      # no source to read: never reuse a kernel across objects
    return h.hexdigest()[:16]


def check_warp_function(fn, what: str, args: tuple, ret, who: str, shape: str | None = None) -> None:
    """`fn` is a Warp function taking `args` (types) and returning `ret`, else one InputError naming
    `what`; `shape` words the expected parameters (default: the type names). float and int stand
    for Warp's float32 and int32."""
    import warp as wp
    if not isinstance(fn, wp._src.context.Function):
        raise InputError(who, f"{what} must be a Warp function (@wp.func), got {type(fn).__name__}")
    same = {float: wp.float32, int: wp.int32}
    name = lambda t: getattr(t, "__name__", str(t))                           # noqa: E731
    got = tuple(same.get(t, t) for t in fn.input_types.values())
    if len(got) != len(args) or any(g is not same.get(a, a) for g, a in zip(got, args)):
        raise InputError(who, f"{what} must take {shape or '(' + ', '.join(map(name, args)) + ')'}; "
                              f"got ({', '.join(map(name, got))})")
    try:
        r = inspect.get_annotations(fn.func, eval_str=True).get("return")
    except Exception:                                             # noqa: BLE001 (user annotations)
        r = fn.func.__annotations__.get("return")
    if same.get(r, r) is not same.get(ret, ret):
        raise InputError(who, f"{what} must return {name(ret)}, got {name(r)!r}")


def user_frame(exc: BaseException, files: set[str]) -> str:
    """'file:line' of the deepest frame of the exception in one of `files`, else ''."""
    where = ""
    for fs in traceback.extract_tb(exc.__traceback__):
        if fs.filename in files:
            where = f"{fs.filename}:{fs.lineno}"
    for m in re.finditer(r'(?:File "([^"]+)", line |at ([^\s:"]+):)(\d+)', str(exc)):
        if (m.group(1) or m.group(2)) in files:
            where = f"{m.group(1) or m.group(2)}:{m.group(3)}"
    return where


def last_words(exc: BaseException) -> str:
    """The innermost message of an exception (Warp's codegen errors nest every enclosing function)."""
    parts = [p.strip(" '\"\n") for p in re.split(r"\\n;|\n;|;\n", str(exc))]
    parts = [p for p in parts if p and not p.startswith("Error while parsing function")]
    return (parts[-1] if parts else type(exc).__name__).splitlines()[-1].strip(" '\"")


def who_registers(kind: str) -> str:
    """What an error of a registration names: the plugin being imported, else the API call."""
    return _loading[-1][0] if _loading else f"register_{kind}"


def fingerprint(own: str, *functions) -> str:
    """A registration's fingerprint: the plugin's source hash while one is imported, else the hash
    of the functions' source; with `own` (a table's hash) mixed in."""
    base = _loading[-1][1] if _loading else _source_fingerprint(*functions)
    return _sha(f"{base}:{own}".encode())[:16]


def note(kind: str, name: str) -> None:
    if _loading:
        _loading[-1][2].append(f"{kind}:{name}")


def attribute(kind: str, name: str, *functions) -> tuple[str, str]:
    """(who, fingerprint) of a registration made outside this module (a light selection, in
    kernels/light_selection.py), recorded as the importing plugin's."""
    who, fp = who_registers(kind), fingerprint("", *functions)
    note(kind, name)
    return who, fp


def compile_error(e: BaseException, what: str, functions) -> str:
    """One line for a Warp error in a plugin's code: `what` does not compile at FILE:LINE: why."""
    files = set()
    for f in functions:
        code = getattr(getattr(f, "func", f), "__code__", None)
        if code is not None:
            files.add(code.co_filename)
    where = user_frame(e, files)
    # Warp names a function made in a factory FACTORY__locals__NAME: the user knows it as NAME.
    why = re.sub(r"\b\w+__locals__", "", last_words(e))
    return f"{what} does not compile{' at ' + where if where else ''}: {why}"


# ---------------------------------------------------------------------------------------------------
# Loading
# ---------------------------------------------------------------------------------------------------

def _import(spec: str, base: Path | None, field: str) -> tuple[str, str | None, bytes, callable]:
    """(module name, path, source bytes, importer) of a plugin given as a path or a module name."""
    name_lengths(Path(spec).expanduser(), field)        # a longer name fails every look-up
    looks_like_path = spec.endswith(".py") or "/" in spec or "\\" in spec
    if looks_like_path:
        path = Path(spec).expanduser()
        if not path.is_absolute() and base is not None:
            path = base / path
        path = path.resolve()
        kind = file_kind(path)
        if kind is not None:
            raise InputError(field, f"{spec!r} is {kind}, not a plugin file (.py)")
        if not path.is_file():
            raise InputError(field, f"no plugin file {spec!r}" + (f" (looked in {base})" if base else ""))
        if path.suffix != ".py":
            raise InputError(field, f"{spec!r} is not a Python file: a plugin is a .py file or an "
                                    "importable module name")
        data = path.read_bytes()
        module = f"drtlab_plugin_{re.sub(r'[^0-9a-zA-Z_]', '_', path.stem)}_{_sha(data)[:12]}"

        def run():
            s = importlib.util.spec_from_file_location(module, path)
            m = importlib.util.module_from_spec(s)
            sys.modules[module] = m          # Warp reads the functions' module while it compiles
            s.loader.exec_module(m)
            return m
        return module, str(path), data, run
    if not re.match(r"^[A-Za-z_][\w.]*$", spec):
        raise InputError(field, f"a plugin is a .py file or an importable module name, got {spec!r}")
    try:
        found = importlib.util.find_spec(spec.split(".")[0]) and importlib.util.find_spec(spec)
    except (ImportError, ValueError):       # `os.x`: a submodule of a module that is no package
        found = None
    if found is None:
        kind = file_kind(spec) or ("a file but not a Python file (.py)" if Path(spec).is_file() else None)
        if kind is not None:
            raise InputError(field, f"{spec!r} is {kind}: a plugin is a .py file or an importable "
                                    "module name")
        raise InputError(field, f"no plugin module {spec!r} (not installed, and not a .py path)")
    path = found.origin if found.origin and Path(found.origin).is_file() else None
    data = Path(path).read_bytes() if path else spec.encode()
    return spec, path, data, lambda: importlib.import_module(spec)


def load_plugin(spec, field: str = "--plugin", base: Path | None = None) -> Plugin:
    """Import a plugin (a .py path, relative to `base` when given, or a module name) once per
    process and content; returns its record. Loading the same file again is free; an edited file
    is imported anew and its sets replace the old ones."""
    if isinstance(spec, Path):
        spec = str(spec)
    if not isinstance(spec, str) or not spec.strip():
        raise InputError(field, f"must be a plugin file (.py) or module name, got {spec!r}")
    module, path, data, run = _import(spec.strip(), base, field)
    key, sha = path or module, _sha(data)
    if key in _loaded and _loaded[key].sha256 == sha:
        return _loaded[key]
    label = f"{field} {Path(path).name if path else module}"
    _loading.append([label, sha[:16], []])
    try:
        run()
    except InputError as e:
        sys.modules.pop(module, None)
        # A refused registration names the line of the user's file that made it.
        where = user_frame(e, {path} if path else set())
        message = e.message if not where or path in e.message else f"{e.message} (at {where})"
        raise InputError(label if e.field in (label, "pointset") else f"{label}: {e.field}",
                         message) from None
    except SystemExit as e:
        # sys.exit() (or exit()) at import would end drtlab itself, silently, with the plugin's code.
        sys.modules.pop(module, None)
        raise InputError(label, f"called sys.exit({'' if e.code is None else repr(e.code)}) while "
                                "importing it: a plugin registers its routines and returns, it does "
                                "not end the program") from None
    except Exception as e:                                        # noqa: BLE001 (user code)
        sys.modules.pop(module, None)
        where = user_frame(e, {path} if path else set())
        raise InputError(label, f"{type(e).__name__} while importing it"
                                f"{' at ' + where if where else ''}: {e}") from None
    finally:
        _, _, registered = _loading.pop()
    if not registered:
        raise InputError(label, f"registers nothing: a plugin calls {REGISTER_CALLS} when imported")
    _loaded[key] = Plugin(spec, module, path, sha, tuple(registered))
    return _loaded[key]


def load_plugins(specs, field: str = "--plugin", base: Path | None = None) -> list[Plugin]:
    """Each of `specs` (a flag's values, or a file's list: then named `field[i]`)."""
    return [load_plugin(s, field if field.startswith("--") else f"{field}[{i}]", base)
            for i, s in enumerate(specs or [])]


def load_entry_points() -> list[Plugin]:
    """The installed packages' plugins (group `drtlab.plugins`), once per process."""
    global _entry_points_done
    if _entry_points_done:
        return []
    _entry_points_done = True
    from importlib.metadata import entry_points
    out = []
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        module = ep.value.split(":")[0]
        if ":" in ep.value:
            _loading.append([f"entry point {ep.name}", _sha(ep.value.encode())[:16], []])
            try:
                ep.load()()
            finally:
                _, _, registered = _loading.pop()
            _loaded[ep.value] = Plugin(ep.value, module, None, _sha(ep.value.encode()), tuple(registered))
            out.append(_loaded[ep.value])
        else:
            out.append(load_plugin(module, f"entry point {ep.name}"))
    return out


def plugin_args(argv: list[str]) -> list[str]:
    """The values of every `--plugin X` / `--plugin=X` of a command line (before a bare `--`)."""
    out, i = [], 0
    while i < len(argv) and argv[i] != "--":
        a = argv[i]
        if a == "--plugin":
            if i + 1 >= len(argv):
                raise InputError("--plugin", "needs a plugin file (.py) or module name")
            out.append(argv[i + 1])
            i += 2
            continue
        if a.startswith("--plugin="):
            out.append(a.split("=", 1)[1])
        i += 1
    return out


# ---------------------------------------------------------------------------------------------------
# Dask workers
# ---------------------------------------------------------------------------------------------------

def shipped() -> tuple:
    """What a worker needs to load this process's plugins: (path, sha, text) per file plugin,
    (module, sha, None) per module plugin."""
    return tuple((p.path or p.module, p.sha256, Path(p.path).read_text() if p.path else None)
                 for p in _loaded.values() if p.path or p.module)


def ensure_shipped(items: tuple) -> None:
    """Load the plugins `shipped()` sent: a file from its own path when it is there with the same
    content, else from a copy of its text in the temporary folder; a module by name."""
    for where, sha, text in items or ():
        if where in _loaded and _loaded[where].sha256 == sha:
            continue
        if text is None:
            load_plugin(where, "worker plugin")
            continue
        path = Path(where)
        if not (path.is_file() and _sha(path.read_bytes()) == sha):
            path = Path(tempfile.gettempdir()) / "drtlab-plugins" / sha[:16] / Path(where).name
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text)
        load_plugin(str(path), "worker plugin")
