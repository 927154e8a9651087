"""Integrators as plugins (drtlab.register_integrator, kernels/integrators/api.py): bad ones refused
at registration in one line (exit 2 on the command line), an edited one fingerprinted anew into
kernel and run keys, the sample-dimension layout of an integrator's own decisions, and the
examples (examples/plugins/splitting.py, one_sample_mis.py) agreeing with the built-in `path`,
with splitting that forgets to divide by its count as the negative control."""
import subprocess
import sys

import numpy as np
import pytest
from scipy import stats

import drtlab
from drtlab.errors import InputError
from drtlab.estimators import dimensions as dims
from drtlab.estimators import plugin_checks, plugins
from drtlab.estimators.integrators import INTEGRATORS
from drtlab.experiments.stats.hypothesis_tests import sidak

from repo_paths import PLUGIN_EXAMPLES

# A minimal integrator: the emission of what the camera ray hits (BODY replaced by the cases).
PLUGIN = '''
import warp as wp
import drtlab
from drtlab.kernels.device_scene import SceneData


def make(api):
    intersect, emitted = api.intersect, api.emitted
    {API}

    @wp.func
    def trace(sd: SceneData, seed: wp.uint32, pix: wp.uint32, idx: wp.uint32, spp: wp.uint32,
              o: wp.vec3, d: wp.vec3, dt: float) -> wp.vec3:
        h = intersect(sd, o, d, 1.0e30, dt)
        if h.index < 0:
            return wp.vec3(0.0)
        return emitted(sd, h, -d) * SCALE{BAD}

    return trace


drtlab.register_integrator("{NAME}", make, "emission seen", unbiased=False, handles=(){CHECK})
'''


def _write(path, name="seen", scale="1.0", bad="", api="", check=""):
    path.write_text(PLUGIN.replace("SCALE", scale).replace("{NAME}", name).replace("{BAD}", bad)
                    .replace("{API}", api).replace("{CHECK}", check))
    return path


@pytest.mark.parametrize("case, message", [
    ("codegen", "does not compile at"),
    ("missing", "asks the API for something it does not have"),
    ("clash", "is a built-in integrator"),
    ("signature", "make(api)'s trace must take"),
    ("overload", "overload for 'intersect'"),
])
def test_bad_integrators_are_one_line_with_exit_2(tmp_path, case, message):
    path = tmp_path / f"{case}.py"
    if case == "codegen":
        _write(path, bad=" + not_defined_anywhere")
    elif case == "missing":
        _write(path, api="nope = api.trace_everything")
    elif case == "clash":
        _write(path, name="path")
    elif case == "overload":                        # an API function called with too few arguments
        path.write_text(_write(path).read_text().replace("intersect(sd, o, d, 1.0e30, dt)",
                                                         "intersect(sd, o, d, 1.0e30)"))
    elif case == "signature":
        path.write_text(PLUGIN.replace(", dt: float) -> wp.vec3", ") -> wp.vec3").replace(", dt)", ", 0.0)")
                        .replace("SCALE", "1.0").replace("{NAME}", "seen").replace("{BAD}", "")
                        .replace("{API}", "").replace("{CHECK}", ""))
    r = subprocess.run([sys.executable, "-m", "drtlab.cli", "--plugin", str(path), "samplers"],
                       capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == 2, r.stderr
    lines = r.stderr.splitlines()
    assert len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
    assert lines[0].startswith(f"drtlab: --plugin {path.name}: ") and message in lines[0], lines[0]
    assert f"{path}:" in lines[0]                   # the user's file and line, not Warp's or drtlab's
    assert "__locals__" not in lines[0]              # the API's names as the user calls them


def test_a_light_selection_that_does_not_compile_is_refused_when_registered(tmp_path, clean_registry):
    src = (PLUGIN_EXAMPLES / "nearest_light.py").read_text()
    path = tmp_path / "broken_light.py"
    path.write_text(src.replace("return _weight(sd, x, li) / total", "return _weight(sd, x, li) / totl"))
    from drtlab.kernels.light_selection import LIGHT_SELECTIONS
    before = LIGHT_SELECTIONS.get("nearest")          # another test on this worker may have loaded it
    with pytest.raises(InputError) as e:
        plugins.load_plugin(path)
    assert "light selection 'nearest' does not compile at" in e.value.message
    assert str(path) in e.value.message and "\n" not in e.value.message
    assert LIGHT_SELECTIONS.get("nearest") is before            # the broken one is not registered


def test_a_lobe_sampler_that_does_not_compile_is_refused_when_registered(tmp_path, clean_registry):
    src = (PLUGIN_EXAMPLES / "defensive_phong.py").read_text()
    path = tmp_path / "broken_lobe.py"
    assert "return 0.5 * phong_lobe_pdf(" in src
    path.write_text(src.replace("return 0.5 * phong_lobe_pdf(", "return 0.5 * phong_lobe_pdff("))
    from drtlab.kernels.lobe_samplers import LOBE_SAMPLERS
    before = LOBE_SAMPLERS.get("defensive-phong")     # another test on this worker may have loaded it
    with pytest.raises(InputError) as e:
        plugins.load_plugin(path)
    assert "lobe sampler 'defensive-phong' does not compile at" in e.value.message
    assert str(path) in e.value.message and "\n" not in e.value.message
    assert LOBE_SAMPLERS.get("defensive-phong") is before      # the broken one is not registered


def test_an_edited_integrator_changes_its_kernel_and_run_keys(tmp_path, clean_registry):
    from drtlab.estimators.registry import parse_sampler
    from drtlab.kernels.plugin_compile import small_features
    from drtlab.kernels.variants import variant_key
    path = _write(tmp_path / "seen.py", check=", check=False")
    plugins.load_plugin(path)
    spec = parse_sampler("independent")
    fp1 = INTEGRATORS["seen"].fingerprint
    key1 = variant_key(small_features("seen"), spec, "cpu")
    run1 = plugin_checks.sampler_fingerprint("independent", "seen")
    plugins.load_plugin(path)                                 # unchanged: the same record
    assert INTEGRATORS["seen"].fingerprint == fp1
    _write(path, scale="2.0", check=", check=False")          # the user edits it
    plugins.load_plugin(path)
    assert INTEGRATORS["seen"].fingerprint != fp1
    assert variant_key(small_features("seen"), spec, "cpu") != key1
    assert plugin_checks.sampler_fingerprint("independent", "seen") not in ("", run1)
    assert plugin_checks.sampler_fingerprint("independent", "path") == ""
    assert INTEGRATORS["seen"].biased and not INTEGRATORS["seen"].unbiased
    assert any(s[0] == str(path) for s in plugins.shipped())  # what a Dask worker loads


def test_own_decisions_move_no_built_in_dimension():
    offsets, stride = dims.own_layout((("split_light", 9), ("technique", 1)))
    assert offsets == {"split_light": 0, "technique": 9} and stride == 10
    own = [dims.own_dim(stride, b, o) for b in range(3) for o in range(stride)]
    assert len(set(own)) == len(own) and min(own) > dims.bounce_dim(512, dims.PER_BOUNCE)
    assert all(dims.split(d) is None and dims.group_of(d) == dims.GROUPS.index("later") for d in own)
    assert dims.bounce_dim(2, dims.DIRECTION) == 5 + 16 + 4          # the built-in layout as before
    with pytest.raises(ValueError):
        dims.own_layout((("direction", 2),))                         # a built-in decision's name
    with pytest.raises(ValueError):
        dims.own_layout((("x", 0),))


def test_the_samplers_listing_shows_a_registered_integrator(tmp_path):
    path = _write(tmp_path / "seen.py", check=", check=False")
    r = subprocess.run([sys.executable, "-m", "drtlab.cli", "--plugin", str(path), "samplers"],
                       capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert any(line.split()[:2] == ["seen", "biased"] for line in r.stdout.splitlines())


# The examples against the built-in path tracer: per-seed image means (R seeds each), a Welch test
# per colour channel, ALPHA for the family of the examples' tests by Sidak's correction.
SCENE, RES, SPP, SEEDS, ALPHA = "cornell-box", (16, 12), 16, range(10), 0.01


def _means(integrator):
    images = drtlab.render_batch(SCENE, seeds=SEEDS, spp=SPP, res=RES, integrator=integrator)
    return images.mean(axis=(1, 2))                      # (R, 3)


def _p_values(a, b):
    return [stats.ttest_ind(a[:, c], b[:, c], equal_var=False).pvalue for c in range(3)]


def test_the_example_integrators_agree_with_path_and_broken_splitting_does_not(tmp_path, clean_registry):
    plugins.load_plugin(PLUGIN_EXAMPLES / "splitting.py")
    plugins.load_plugin(PLUGIN_EXAMPLES / "one_sample_mis.py")
    broken = tmp_path / "broken_splitting.py"
    src = (PLUGIN_EXAMPLES / "splitting.py").read_text()
    assert "L += direct / float(n)" in src
    broken.write_text(src.replace("L += direct / float(n)", "L += direct")
                      .replace('"splitting", make', '"splitting-broken", make'))
    plugins.load_plugin(broken)
    path = _means("path")
    tests = {name: _p_values(_means(name), path) for name in ("splitting", "one-sample-mis")}
    level = sidak(ALPHA, 3 * len(tests))
    for name, p in tests.items():
        assert min(p) > level, (name, p, level)
    # The negative control: the first vertex's direct light counted SPLITS times over.
    assert min(_p_values(_means("splitting-broken"), path)) < level
    # Splitting draws its extra light samples from its own dimensions: its mean over the same seeds
    # differs from path's only by noise, and its noise is lower (more light samples per pixel).
    split = drtlab.render_batch(SCENE, seeds=SEEDS, spp=SPP, res=RES, integrator="splitting")
    plain = drtlab.render_batch(SCENE, seeds=SEEDS, spp=SPP, res=RES, integrator="path")
    assert split.var(axis=0).mean() < plain.var(axis=0).mean()


def test_the_study_lists_its_integrator_plugins(clean_registry):
    from drtlab.experiments.study.config import load_experiment
    exp = load_experiment(str(PLUGIN_EXAMPLES / "integrators.toml"), check_scenes=False)
    assert [s.integrator for s in exp.studies] == ["path", "splitting", "one-sample-mis"]
    assert {s.samplers for s in exp.studies} == {exp.studies[0].samplers}   # the same samplers each
