"""Lobe samplers: how a strategy that samples BSDF lobes draws the scattered direction of one material
kind, with the density it draws with (MIS and the sample's weight read it). A lobe sampler is the
sampling half of the one BSDF interface every material kind has (kernels/materials/__init__.py;
pbrt-v4's `BxDF::Sample_f` / `PDF` pair, for one kind), with the same signatures:

    sample(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, u_lobe: float, u: wp.vec2) -> Scatter
    pdf(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> float

`mat` is the material at the hit (kernels/materials/material_at.py: `albedo`, `shape` the lobe's
one shape parameter (the Phong exponent, the microfacet alpha or the albedo's mean), `ior`, a
conductor's `eta` and `k`, a table kind's `table` and `row`), `n` the shading normal as the surface
has it (outward: a dielectric reads inside from outside by the side wo lies on; a reflecting lobe
usually turns it to wo's side first), `u` two uniform numbers of the sample's direction dimensions
and `u_lobe` a third (a uniform number for the kinds that choose between lobes,
`material_kinds.lobe_choice`; 0 for the others). `sample` returns `proposal(wi)`
(kernels/materials/scatter.py) for a direction drawn with density `pdf`, or `delta_scatter(wi,
weight)` for a delta lobe (a kind with one, `MaterialKind.delta_lobe`: the sampler then samples it
too, and `pdf` is the density of the rest). The material's own `eval` stays the integrand: a
proposal's weight is f |cos| / pdf, so any sampler whose `pdf` is exactly what `sample` does (and is
positive wherever f is) gives the same image in expectation; a zero vector or a density of 0 drops
the sample. `drtlab check NAME` tests that (chi-square of the samples against `pdf`, the directional
albedo against the built-in sampler's, finite values at grazing angles and extreme lobe shapes).

A strategy composes samplers by name (`Strategy.lobes`; `drtlab.register_strategy(...,
lobe_samplers=[...])`); the kinds it names none for keep their model module's own sampling
(`MaterialKind.model`, composed by `kernels/materials/bsdf.py`).
"""
from dataclasses import dataclass

import warp as wp

from drtlab.errors import InputError
from drtlab.estimators.plugins import check_warp_function
from drtlab.kernels.scene_model.material_kinds import kinds_where

# Kinds a lobe sampler can serve: every kind with a density (a delta kind has none to sample, the
# emitter does not scatter).
SAMPLED_KINDS = kinds_where(lambda k: not (k.delta or k.emitter))


@dataclass(frozen=True)
class LobeSampler:
    name: str
    description: str
    kind: str                          # the material kind it samples (one of SAMPLED_KINDS)
    sample: wp.Function
    pdf: wp.Function
    fingerprint: str = ""              # a plugin's source hash (estimators/plugins.py)


LOBE_SAMPLERS: dict[str, LobeSampler] = {}


def samplers_of(strategy) -> tuple[LobeSampler, ...]:
    """The registered samplers strategy `strategy` names, one per kind."""
    missing = [n for n in strategy.lobes if n not in LOBE_SAMPLERS]
    if missing:
        raise InputError("strategy", f"strategy '{strategy.name}' samples lobes by {missing[0]!r}, which "
                                     f"is not registered; registered: {', '.join(LOBE_SAMPLERS) or 'none'}")
    return tuple(LOBE_SAMPLERS[n] for n in strategy.lobes)


def composed(names, field: str = "lobe_samplers") -> tuple[tuple[str, ...], str]:
    """(names, fingerprint) of a strategy's lobe samplers: registered, at most one per kind."""
    if not isinstance(names, (list, tuple)) or not all(isinstance(n, str) for n in names):
        raise InputError(field, f"must be a list of registered lobe sampler names, got {names!r}")
    kinds: dict[str, str] = {}
    for n in names:
        if n not in LOBE_SAMPLERS:
            raise InputError(field, f"unknown lobe sampler {n!r}; registered: "
                                    f"{', '.join(LOBE_SAMPLERS) or 'none (drtlab.register_lobe_sampler)'}")
        k = LOBE_SAMPLERS[n].kind
        if k in kinds:
            raise InputError(field, f"{kinds[k]!r} and {n!r} both sample kind {k!r}; name one per kind")
        kinds[k] = n
    return tuple(names), ":".join(LOBE_SAMPLERS[n].fingerprint for n in names)


def register(ls: LobeSampler, who: str, fingerprint: str) -> LobeSampler:
    """Add a user's sampler (checked: signatures, kind); a name registered again is replaced (an
    edited plugin)."""
    from dataclasses import replace
    # Here, not at the top: the materials package composes lobe samplers (bsdf.py imports this).
    from drtlab.kernels.materials.material_at import MaterialAt
    from drtlab.kernels.materials.scatter import Scatter
    if not isinstance(ls, LobeSampler):
        raise InputError(who, f"register_lobe_sampler takes a drtlab LobeSampler, got {type(ls).__name__}")
    if ls.kind not in SAMPLED_KINDS:
        raise InputError(who, f"kind must be one of {', '.join(SAMPLED_KINDS)} (delta and emitting kinds "
                              f"have no density to sample), got {ls.kind!r}")
    check_warp_function(ls.sample, "sample", (MaterialAt, wp.vec3, wp.vec3, float, wp.vec2), Scatter, who,
                        "(mat: MaterialAt, n: vec3, wo: vec3, u_lobe: float, u: vec2)")
    check_warp_function(ls.pdf, "pdf", (MaterialAt, wp.vec3, wp.vec3, wp.vec3), float, who,
                        "(mat: MaterialAt, n: vec3, wo: vec3, wi: vec3)")
    ls = replace(ls, fingerprint=fingerprint)
    LOBE_SAMPLERS[ls.name] = ls
    return ls
