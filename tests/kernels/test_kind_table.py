"""What every material kind of the kind table (`MaterialKind.model`: a module in kernels/materials/
with eval, pdf and sample on MaterialAt) must do in the renderer, whatever its model: every integrator
renders it finite and non-negative, whitted ends a ray at it with direct light (as at ggx), and its
sampled weights are what eval_bsdf / pdf say. Each model's own statistics live beside it
(test_beckmann.py, test_ggx_separable.py). The renders here are of the kinds added after the nine
the built-in scenes render (those have their own tests: test_ggx.py, test_plastic.py,
test_analytic.py, ...); every model kind gets its own kernel cache key."""

import numpy as np
import pytest

import drtlab
from drtlab.experiments.stats import chi2 as C
from drtlab.kernels.materials.kinds import model_module
from drtlab.kernels.scene_model.material_kinds import KIND_BY_NAME, KINDS, MATERIAL_CODE

from bsdf_checks import assert_consistent
from scene_pieces import glossy_ggx_as

ALL_MODEL_KINDS = [k.name for k in KINDS if k.model]
# The kinds with a density (a delta kind's eval and pdf are 0: no weights to check, and whitted
# continues its ray) added after the nine.
ADDED = [k for k in KINDS[MATERIAL_CODE["ggx_dielectric"] + 1:] if not k.delta]
MODEL_KINDS = [k.name for k in ADDED if k.model]
REFLECTING = [k.name for k in ADDED if k.model and not k.transmits]
TRANSMITTING = [k.name for k in ADDED if k.model and k.transmits]
# The kinds whose model reads a table row compile alike but for their code: one of each model renders.
RENDERED = [k.name for i, k in enumerate(ADDED)
            if k.model and not (k.table and any(j.table and j.model == k.model for j in ADDED[:i]))]
# Kinds whose model has a mirror lobe beside its density (kernels/materials/smooth_plastic.py).
MIRRORED = {k.name for k in KINDS if k.delta_lobe}


@pytest.mark.parametrize("kind", ALL_MODEL_KINDS)
def test_every_model_module_has_the_one_interface(kind):
    """eval, pdf and sample of every kind's module (delta and table kinds included) take the material
    at the hit (MaterialAt) and the same arguments, and what a module has beyond them is what its row
    declares: `sampling` exactly where `strategy_sampling`, `table_row` exactly where `table`."""
    import warp as wp
    from drtlab.kernels.materials.material_at import MaterialAt
    from drtlab.kernels.materials.scatter import Scatter
    k = KIND_BY_NAME[kind]
    m = model_module(k)
    want = {"eval": ((MaterialAt, wp.vec3, wp.vec3, wp.vec3), wp.vec3),
            "pdf": ((MaterialAt, wp.vec3, wp.vec3, wp.vec3), wp.float32),
            "sample": ((MaterialAt, wp.vec3, wp.vec3, wp.float32, wp.vec2), Scatter)}
    as32 = {float: wp.float32}
    for name, (args, ret) in want.items():
        fn = getattr(m, name)
        assert tuple(as32.get(t, t) for t in fn.input_types.values()) == args, (kind, name)
        r = fn.func.__annotations__["return"]
        assert as32.get(r, r) is ret, (kind, name)
    assert hasattr(m, "sampling") == k.strategy_sampling, kind
    assert hasattr(m, "table_row") == k.table, kind


def test_the_table_has_model_kinds():
    assert {"beckmann", "ggx_separable"} <= set(REFLECTING) and "ggx_dielectric_separable" in TRANSMITTING
    # Every kind that scatters is a model module (delta kinds included): bsdf.py has no kind's code
    # but the emitter's "scatters nothing".
    assert {k.name for k in KINDS if not k.model} == {"emitter"}


# drt (the studies' integrator) for every kind, path for the glass: each pair is a kernel variant to
# compile, and whitted has its own tests below.
@pytest.mark.parametrize("kind,integrator", [(k, "drt") for k in RENDERED] + [(TRANSMITTING[0], "path")])
def test_integrators_render_it_finite(kind, integrator):
    img = drtlab.render(glossy_ggx_as(kind, integrator), spp=4, sampler="independent+importance", seed=1)
    assert np.all(np.isfinite(img)) and np.all(img >= 0) and img.mean() > 0


# A rough plastic's coat reflects white whatever its albedo: black, it is no black surface.
@pytest.mark.parametrize("kind", [k for k in REFLECTING if not KIND_BY_NAME[k].table])
def test_whitted_ends_the_ray_at_it_with_direct_light(kind):
    """A black surface of the kind renders exactly as a black diffuse one: a continued (mirror) ray
    would show reflections."""
    images = [drtlab.render(glossy_ggx_as(k, "whitted", albedo=[0, 0, 0]), spp=1, seed=1) for k in (kind, "diffuse")]
    assert np.array_equal(images[0], images[1])


@pytest.mark.parametrize("kind", TRANSMITTING)
def test_whitted_splits_at_it_as_at_a_smooth_dielectric(kind):
    """Whitted treats a transmitting kind as ggx_dielectric: a smooth interface it splits into
    reflection and refraction, so the two render the same image, bit for bit (and not a black
    surface's: the split does something)."""
    images = [drtlab.render(glossy_ggx_as(k, "whitted"), spp=1, seed=1) for k in (kind, "ggx_dielectric", "diffuse")]
    assert np.array_equal(images[0], images[1]) and not np.array_equal(images[0], images[2])


@pytest.mark.parametrize("kind", MODEL_KINDS)
@pytest.mark.parametrize("lobe", [True, False])
def test_weights_are_eval_over_pdf(kind, lobe):
    case = (kind, (0.8, 0.6, 0.4), 0.4, 1.5, (0.0, 0.0, 1.0), (0.6, 0.0, 0.8))
    assert_consistent(C.BSDFAdapter(lobe).sample(case, 20_000, 3), f"{kind} lobe={lobe}", delta=kind in MIRRORED)


def _bsdf_kernel_hash(kinds: frozenset, microfacet: str = "vndf") -> bytes:
    """Warp's module hash (the disk cache's key) of a kernel calling make_bsdf's functions."""
    import dataclasses

    import warp as wp
    from drtlab.experiments.stats.chi2.adapters import routine_variant
    from drtlab.kernels.materials import make_bsdf
    from drtlab.kernels.materials.material_at import MaterialAt
    features, strategy = routine_variant(microfacet=microfacet)
    b = make_bsdf(dataclasses.replace(features, kinds=kinds), strategy)
    sample_bsdf, eval_bsdf = b.sample_bsdf, b.eval_bsdf

    @wp.kernel(enable_backward=False, module="unique")
    def k(mat: MaterialAt, out: wp.array(dtype=wp.vec3)):
        n = wp.vec3(0.0, 0.0, 1.0)
        s = sample_bsdf(mat, n, n, 0.5, wp.vec2(0.3, 0.6))
        out[0] = s.weight + eval_bsdf(mat, n, n, n)
    return k.module.get_module_hash()


def test_kinds_of_the_table_change_the_kernel_cache_key():
    """Two scenes whose only difference is which model kind they hold compile apart: Warp does not
    hash an unrolled loop's static values (kernels/static_tag.py), the variant tag does."""
    hashes = {kind: _bsdf_kernel_hash(frozenset({"emitter", kind})) for kind in ALL_MODEL_KINDS}
    assert len(set(hashes.values())) == len(ALL_MODEL_KINDS), hashes


@pytest.mark.parametrize("kind", ["ggx", "ggx_dielectric"])
def test_the_strategys_microfacet_sampler_changes_the_kernel_cache_key(kind):
    """A model's `sampling(microfacet)` closures share one source: the tag names the choice; a kind
    whose sampling ignores it (diffuse) keeps one key (the negative control)."""
    assert _bsdf_kernel_hash(frozenset({kind}), "vndf") != _bsdf_kernel_hash(frozenset({kind}), "d")
    assert _bsdf_kernel_hash(frozenset({"diffuse"}), "vndf") == _bsdf_kernel_hash(frozenset({"diffuse"}), "d")


def test_the_variant_tag_reads_numbers_and_sources():
    from drtlab.kernels.materials import beckmann, ggx_separable
    from drtlab.kernels.static_tag import variant_tag
    assert variant_tag(((9, beckmann),)) == variant_tag(((9, beckmann),))
    assert len({variant_tag(()), variant_tag(((9, beckmann),)), variant_tag(((10, beckmann),)),
                variant_tag(((9, ggx_separable),)), variant_tag(((9, beckmann.sample),)),
                variant_tag(((9, beckmann.pdf),))}) == 6
