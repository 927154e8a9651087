"""Every `register_*` of drtlab, in one place; `drtlab.register_*` are these functions.

Each checks what it is given before anything renders (a wrong type or signature, a name that is a
built-in's, Warp code that does not compile: one `InputError` naming the plugin, and where the
error is in the user's file, its file and line), fingerprints it (the importing plugin's source
hash, else the functions' source: part of every kernel key and run key, so an edited plugin
recompiles and re-renders) and records it as the importing plugin's (estimators/plugins.py: the
three ways in, the manifest, the copy a Dask worker loads).

    register_pointset(pointset, check=True)
    register_light_selection(selection, check=True)
    register_lobe_sampler(sampler, check=True)
    register_strategy(name, description, like="importance", *, light_selection, heuristic, lobe_samplers)
    register_integrator(name, make, description, *, unbiased, handles=(), dimensions=(), check=True)
    register_metric(name, per_run, description="", label=None, mse_label=None)
Imports of the layers happen inside each function: `import drtlab` stays light.
"""


def register_pointset(pointset, check: bool = True):
    """Make a `drtlab.PointSet` (your own Warp functions, or `pointset_from_table(...)`) usable by
    name in every render, study and check. Its name must not be a built-in's; registering a name
    again replaces the set (an edited notebook cell). With `check`, the set is compiled and drawn
    once: a wrong signature, a compile error or values outside [0, 1) are one InputError. Returns
    the registered set (with its fingerprint)."""
    from drtlab.estimators.plugin_checks import add_pointset
    return add_pointset(pointset, check)


def _compiled(check: bool, compile_fn, obj, what: str, who: str, functions) -> None:
    """Compile `obj` by `compile_fn` (kernels/plugin_compile.py) when `check`: a Warp error in the
    user's code is one InputError naming `who`, at the user's file and line."""
    if not check:
        return
    from drtlab.errors import InputError
    from drtlab.estimators.plugins import compile_error
    try:
        compile_fn(obj)
    except InputError:
        raise
    except Exception as e:                                        # noqa: BLE001 (user code)
        raise InputError(who, compile_error(e, what, functions)) from None


def register_light_selection(selection, check: bool = True):
    """Register a `drtlab.LightSelection` (two Warp functions: pick(sd, x, u) -> light index and
    pmf(sd, x, li) -> its probability; kernels/light_selection.py) for strategies to name. With
    `check`, both are compiled at once."""
    from drtlab.estimators.plugins import attribute
    from drtlab.kernels.light_selection import LIGHT_SELECTIONS, register
    name = getattr(selection, "name", "?")
    who, fingerprint = attribute("light_selection", name, getattr(selection, "pick", None),
                                 getattr(selection, "pmf", None))
    before = LIGHT_SELECTIONS.get(name)
    sel = register(selection, who, fingerprint)
    try:
        from drtlab.kernels.plugin_compile import compile_light_selection
        _compiled(check, compile_light_selection, sel, f"light selection '{name}'", who,
                  (sel.pick, sel.pmf))
    except Exception:
        _restore(LIGHT_SELECTIONS, name, before)
        raise
    return sel


def register_lobe_sampler(sampler, check: bool = True):
    """Register a `drtlab.LobeSampler` (two Warp functions for one material kind: sample(mat, n, wo,
    u_lobe, u) -> Scatter and pdf(mat, n, wo, wi) -> its density, the signatures of every material
    kind's; kernels/lobe_samplers.py) for strategies to compose. With `check`, both are compiled at
    once."""
    from drtlab.estimators.plugins import attribute
    from drtlab.kernels.lobe_samplers import LOBE_SAMPLERS, register
    name = getattr(sampler, "name", "?")
    who, fingerprint = attribute("lobe_sampler", name, getattr(sampler, "sample", None),
                                 getattr(sampler, "pdf", None))
    before = LOBE_SAMPLERS.get(name)
    ls = register(sampler, who, fingerprint)
    try:
        from drtlab.kernels.plugin_compile import compile_lobe_sampler
        _compiled(check, compile_lobe_sampler, ls, f"lobe sampler '{name}'", who, (ls.sample, ls.pdf))
    except Exception:
        _restore(LOBE_SAMPLERS, name, before)
        raise
    return ls


def _restore(table, name: str, before) -> None:
    """Undo a registration whose code did not compile (a registry keeps only working entries)."""
    if before is None:
        table.pop(name, None)
    else:
        table[name] = before


def register_strategy(name: str, description: str, like: str = "importance", *,
                      light_selection: str | None = None, heuristic: str | None = None,
                      lobe_samplers=None):
    """A strategy composed of registered routines: the built-in strategy `like` with another light
    selection (a built-in or `register_light_selection`'s), another MIS heuristic ("power" or
    "balance", kernels/mis.py) and/or lobe samplers (`register_lobe_sampler`'s, one per material
    kind); used as POINTS+NAME in any sampler."""
    from drtlab.estimators.plugin_checks import add_strategy
    from drtlab.kernels.strategy_composition import compose_strategy
    return add_strategy(compose_strategy(name, description, like, light_selection=light_selection,
                                         heuristic=heuristic, lobe_samplers=lobe_samplers))


def register_integrator(name: str, make, description: str = "", *, unbiased: bool, handles=(),
                        dimensions=(), check: bool = True):
    """Register an integrator written against the estimator API (docs/plugins.md): `make(api)`
    returns `trace(sd, seed, pix, idx, spp, o, d, dt) -> wp.vec3`, a Warp function called once per
    camera sample; `dimensions` declares its own named sample decisions ((name, size), ...), each
    at its own dimensions. `unbiased` is its claim (`drtlab check` tests it), `handles` the effects
    it claims to estimate (estimators/integrators.EFFECTS). With `check`, it is built and compiled
    for a small variant at once. Used by name: `--integrator NAME`, `integrator = "NAME"`."""
    from drtlab.errors import InputError
    from drtlab.estimators import dimensions as dims
    from drtlab.estimators.integrators import EFFECTS, INTEGRATORS, Integrator
    from drtlab.estimators.plugins import NAME, attribute, who_registers
    from drtlab.estimators.registry import BUILT_IN_INTEGRATORS
    who = who_registers("integrator")
    if not isinstance(name, str) or not NAME.match(name):
        raise InputError(who, "an integrator's name is lower-case letters, digits, - and _ (at most "
                              f"40, starting with a letter), got {name!r}")
    if name in BUILT_IN_INTEGRATORS:
        raise InputError(who, f"'{name}' is a built-in integrator ({', '.join(BUILT_IN_INTEGRATORS)}); "
                              "give yours another name")
    if not callable(make):
        raise InputError(who, f"make must be a function make(api) -> trace, got {type(make).__name__}")
    if not isinstance(unbiased, bool):
        raise InputError(who, f"unbiased must be True or False (the integrator's claim), got {unbiased!r}")
    handles = tuple(handles) if isinstance(handles, (tuple, list)) else None
    if handles is None or any(h not in EFFECTS for h in handles):
        raise InputError(who, f"handles must be a list of effects among {', '.join(EFFECTS)}")
    try:
        dimensions = tuple(tuple(d) if isinstance(d, list) else d for d in dimensions or ())
        dims.own_layout(dimensions)
    except (TypeError, ValueError) as e:
        raise InputError(who, f"dimensions: {e}") from None
    who, fingerprint = attribute("integrator", name, make)
    entry = Integrator(name, str(description), not unbiased, handles, make=make,
                       dimensions=dimensions, fingerprint=fingerprint)
    before = INTEGRATORS.get(name)
    INTEGRATORS[name] = entry
    try:
        if check:
            _check_integrator(entry, who)
    except Exception:
        _restore(INTEGRATORS, name, before)
        raise
    return entry


def _check_integrator(entry, who: str) -> None:
    """Build the integrator on a small variant's API (a wrong trace signature, a missing API
    function: one line) and compile it (a Warp error at the user's file and line)."""
    import warp as wp

    from drtlab.errors import InputError
    from drtlab.estimators.plugins import check_warp_function, compile_error, user_frame
    from drtlab.estimators.registry import parse_sampler
    from drtlab.kernels.device_scene import SceneData
    from drtlab.kernels.integrators.api import make_api
    from drtlab.kernels.plugin_compile import compile_integrator, small_features
    code = getattr(entry.make, "__code__", None)
    files = {code.co_filename} if code else set()
    spec = parse_sampler("independent+importance")
    try:
        trace = entry.make(make_api(small_features(entry.name), spec.pointset, spec.strategy,
                                    entry.dimensions))
    except AttributeError as e:
        where = user_frame(e, files)
        raise InputError(who, f"integrator '{entry.name}' asks the API for something it does not "
                              f"have{' at ' + where if where else ''}: {e} (docs/plugins.md lists "
                              "the API)") from None
    except KeyError as e:
        where = user_frame(e, files)
        raise InputError(who, f"integrator '{entry.name}'{' at ' + where if where else ''}: "
                              f"{e.args[0] if e.args else e}") from None
    except Exception as e:                                        # noqa: BLE001 (user code)
        where = user_frame(e, files)
        raise InputError(who, f"integrator '{entry.name}': make(api) raised {type(e).__name__}"
                              f"{' at ' + where if where else ''}: {e}") from None
    check_warp_function(trace, "make(api)'s trace", (SceneData, wp.uint32, wp.uint32, wp.uint32,
                                                     wp.uint32, wp.vec3, wp.vec3, float), wp.vec3, who,
                        "(sd: SceneData, seed, pix, idx, spp: wp.uint32, o: vec3, d: vec3, dt: float)")
    try:
        compile_integrator(entry.name)
    except InputError:
        raise
    except Exception as e:                                        # noqa: BLE001 (user code)
        raise InputError(who, compile_error(e, f"integrator '{entry.name}'", (entry.make, trace))) from None


def register_metric(name: str, per_run, description: str = "", label: str | None = None,
                    mse_label: str | None = None):
    """Register an error metric a study may rank samplers by (`metric = NAME`): `per_run(images,
    reference, reference_stderr)` gives each image's mean squared error, the reference's noise removed
    (experiments/error_metrics/base.py); reports print `label` (its root) and `mse_label`."""
    from drtlab.experiments.error_metrics import register_metric as add_metric
    return add_metric(name, per_run, description, label, mse_label)
