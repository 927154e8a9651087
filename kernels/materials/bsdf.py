"""One kernel variant's BSDF: the kind table's model modules of the kinds the scene has, composed
through the one interface every kind has (eval, pdf, sample on MaterialAt; the package docstring),
in one loop per function."""
from typing import NamedTuple

import warp as wp

from drtlab.estimators.strategies import Strategy
from drtlab.kernels.features import Features
from drtlab.kernels.lobe_samplers import samplers_of
from drtlab.kernels.scene_model.material_kinds import KINDS, MATERIAL_CODE
from drtlab.kernels.static_tag import variant_tag
from drtlab.kernels.materials import mask, uniform
from drtlab.kernels.materials.kinds import model_module
from drtlab.kernels.materials.material_at import MaterialAt
from drtlab.kernels.materials.scatter import Scatter
from drtlab.kernels.materials.shading_frame import mapped_bsdf


class Bsdf(NamedTuple):
    eval_bsdf: wp.Function      # (mat: MaterialAt, n, wo, wi) -> f|cos|
    pdf_bsdf: wp.Function       # (mat, n, wo, wi) -> sample_bsdf's density (it reads no albedo)
    sample_bsdf: wp.Function    # (mat, n, wo, u_lobe, u) -> Scatter


class KindFunctions(NamedTuple):
    """What a variant calls for one kind: its model's eval, and the sample / pdf pair the strategy
    samples it with (its model's, a lobe sampler's or the uniform proposal)."""
    code: int
    eval: wp.Function
    sample: wp.Function
    pdf: wp.Function
    lobe_choice: bool           # sample reads u_lobe (MaterialKind.lobe_choice); else it gets 0
    tag: object                 # what names the pair for the kernel cache (static_tag.py)


def make_bsdf(f: Features, strategy: Strategy) -> Bsdf:
    kinds = kind_functions(f.kinds, strategy)
    eval_bsdf = _make_eval(kinds)
    pdf_bsdf = _make_pdf(kinds)
    sample_bsdf = _make_sampler(kinds, eval_bsdf, pdf_bsdf)
    if f.masks or f.one_sided:          # mask.py: opacity and one-sidedness around every kind
        eval_bsdf, pdf_bsdf, sample_bsdf = mask.wrap(eval_bsdf, pdf_bsdf, sample_bsdf, f.masks,
                                                     f.one_sided, kinds, f.faults)
    b = Bsdf(eval_bsdf=eval_bsdf, pdf_bsdf=pdf_bsdf, sample_bsdf=sample_bsdf)
    # A normal or bump map perturbs the normal every kind sees (compiled only where a scene has one)
    return mapped_bsdf(b) if f.frame_maps else b


def kind_functions(kinds: frozenset, strategy: Strategy) -> tuple:
    """(KindFunctions, ...) of the present kinds that scatter, in code order. The sampling pair is a
    lobe sampler's where the strategy names one for the kind (kernels/lobe_samplers.py), the
    uniform proposal (uniform.py) for a kind with a density only under a strategy that does not
    sample lobes, else its model's (`sampling(strategy)` where the row declares it)."""
    plugged = {s.kind: s for s in samplers_of(strategy)} if strategy.lobe and strategy.lobes else {}
    out = []
    for k in KINDS:
        if not k.model or k.name not in kinds:
            continue
        m = model_module(k)
        if k.name in plugged:
            # The plugin's fingerprint (its whole file): the tag covers helpers its functions call.
            p = plugged[k.name]
            sample, pdf, tag = p.sample, p.pdf, p.fingerprint
        elif not strategy.lobe and not (k.delta or k.delta_lobe):
            sample, pdf = ((uniform.sample_sphere, uniform.pdf_sphere) if k.transmits or k.params
                           else (uniform.sample_hemisphere, uniform.pdf_hemisphere))
            tag = uniform
        elif k.strategy_sampling:
            # Two closures of one source: the tag names which one.
            sample, pdf = m.sampling(strategy)
            tag = (m, strategy.lobe, strategy.microfacet == "vndf")
        else:
            sample, pdf, tag = m.sample, m.pdf, m
        out.append(KindFunctions(MATERIAL_CODE[k.name], m.eval, sample, pdf, k.lobe_choice, (m, tag)))
    return tuple(out)


def _make_eval(kinds: tuple):
    """eval_bsdf (f|cos|) of the kinds (0 for the others, and for delta lobes)."""
    KINDS_ = kinds

    @wp.func
    def eval_bsdf(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> wp.vec3:
        kind = mat.kind
        r = wp.vec3(0.0)
        _variant = wp.static(variant_tag(KINDS_))  # noqa: F841 (the loop table, hashed: static_tag.py)
        for i in range(wp.static(len(KINDS_))):
            if kind == wp.static(KINDS_[i].code):
                r = wp.static(KINDS_[i].eval)(mat, n, wo, wi)
        return r

    return eval_bsdf


def _make_pdf(kinds: tuple):
    """pdf_bsdf: the density with which sample_bsdf proposes wi (its non-delta part)."""
    KINDS_ = kinds

    @wp.func
    def pdf_bsdf(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> float:
        kind = mat.kind
        p = float(0.0)
        _variant = wp.static(variant_tag(KINDS_))  # noqa: F841 (static_tag.py)
        for i in range(wp.static(len(KINDS_))):
            if kind == wp.static(KINDS_[i].code):
                p = wp.static(KINDS_[i].pdf)(mat, n, wo, wi)
        return p

    return pdf_bsdf


def _make_sampler(kinds: tuple, eval_bsdf, pdf_bsdf):
    """sample_bsdf: the kind's sample; a proposal (delta 0) weighed by eval_bsdf / pdf_bsdf, and
    dropped where either is 0."""
    KINDS_ = kinds

    @wp.func
    def sample_bsdf(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, u_lobe: float, u: wp.vec2) -> Scatter:
        kind = mat.kind
        s = Scatter()
        s.valid = 0
        s.delta = 0
        _variant = wp.static(variant_tag(KINDS_))  # noqa: F841 (static_tag.py)
        for i in range(wp.static(len(KINDS_))):
            if kind == wp.static(KINDS_[i].code):
                ul = float(0.0)
                if wp.static(KINDS_[i].lobe_choice):
                    ul = u_lobe
                s = wp.static(KINDS_[i].sample)(mat, n, wo, ul, u)
        if s.valid == 1 and s.delta == 0:
            s.valid = 0
            pdf = pdf_bsdf(mat, n, wo, s.wi)
            if pdf > 0.0:
                fc = eval_bsdf(mat, n, wo, s.wi)
                if fc[0] > 0.0 or fc[1] > 0.0 or fc[2] > 0.0:
                    s.pdf = pdf
                    s.weight = fc / pdf
                    s.valid = 1
        return s

    return sample_bsdf
