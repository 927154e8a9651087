"""One kernel variant's BSDF: the kind table's model modules of the kinds the scene has, composed
(eval, pdf and sample; the package docstring describes them)."""
from typing import NamedTuple

import warp as wp

from drtlab.estimators.domain_maps import (INV_4PI, INV_PI, frame_to_world, square_to_uniform_hemisphere,
                                           square_to_uniform_sphere)
from drtlab.estimators.strategies import Strategy
from drtlab.kernels.features import Features
from drtlab.kernels.scene_model.material_kinds import KINDS, MATERIAL_CODE
from drtlab.kernels.static_tag import variant_tag
from drtlab.kernels.materials.conductor import half_fresnel
from drtlab.kernels.materials.kinds import EMITTER, LOBE_CHOICE_KINDS, model_module
from drtlab.kernels.materials.material_at import MaterialAt
from drtlab.kernels.materials.scatter import Scatter


LOBE_CHOICE_CODES = frozenset(MATERIAL_CODE[k] for k in LOBE_CHOICE_KINDS)


class Bsdf(NamedTuple):
    eval_bsdf: wp.Function      # (mat: MaterialAt, n, wo, wi) -> f|cos|
    pdf_bsdf: wp.Function       # (mat, n, wo, wi) -> sample_bsdf's density (it reads no albedo)
    sample_bsdf: wp.Function    # (mat, n, wo, u_lobe, u) -> Scatter


def make_bsdf(f: Features, strategy: Strategy) -> Bsdf:
    models = _models(f.kinds, delta=False)
    plug = _plugged(f.kinds, strategy, models)
    tabled = _table_models(f.kinds)
    eval_bsdf = _make_eval(models, tabled)
    pdf_bsdf = _make_pdf(strategy.lobe, plug, models, tabled)
    sample_bsdf = _make_sampler(strategy.lobe, eval_bsdf, pdf_bsdf, plug, models, tabled,
                                _models(f.kinds, delta=True))
    return Bsdf(eval_bsdf=eval_bsdf, pdf_bsdf=pdf_bsdf, sample_bsdf=sample_bsdf)


def _models(kinds: frozenset, delta: bool) -> tuple:
    """((kind code, module, transmits, conductor), ...) of the present kinds the kind table gives a
    model module (MaterialKind.model), delta or not: a non-delta one's eval_bsdf (times the
    conductor Fresnel for a conductor kind), and its lobe sampling unless a strategy's lobe sampler
    replaces it; a delta one's sample_delta."""
    return tuple((MATERIAL_CODE[k.name], model_module(k),
                  k.transmits, k.conductor) for k in KINDS if k.model and not k.table and k.delta == delta
                  and k.name in kinds)


def _table_models(kinds: frozenset) -> tuple:
    """((kind code, module), ...) of the present kinds whose model reads its material's row of the
    flat per-material table (MaterialKind.table): their eval_bsdf, sample and pdf take the table and
    the row's offset after `ior` (rough_plastic.py)."""
    return tuple((MATERIAL_CODE[k.name], model_module(k))
                 for k in KINDS if k.table and k.name in kinds)


def _model_sampling(m, strategy: Strategy) -> tuple:
    """(sample, pdf, cache tag) of model module `m` under `strategy`: a module with `sampling`
    (the GGX kinds) draws its microfacet normal as the strategy's `microfacet` says, which the tag
    must then name (its two closures have one source)."""
    if hasattr(m, "sampling"):
        return m.sampling(strategy.microfacet) + ((m, strategy.microfacet == "vndf"),)
    return m.sample, m.pdf, m


def _plugged(kinds: frozenset, strategy: Strategy, models: tuple) -> tuple:
    """((kind code, sample, pdf, reads u_lobe, cache tag), ...): the strategy's lobe samplers
    (kernels/lobe_samplers.py) for the kinds present, then the model kinds' own sampling for the
    rest; only a strategy that samples lobes uses them."""
    if not strategy.lobe:
        return ()
    out = []
    if strategy.lobes:
        from drtlab.kernels.lobe_samplers import samplers_of
        # The plugin's fingerprint (its whole file) last: the cache tag of the unrolled table covers
        # helpers the two functions call (static_tag.py).
        out = [(MATERIAL_CODE[s.kind], s.sample, s.pdf, s.kind in LOBE_CHOICE_KINDS, s.fingerprint)
               for s in samplers_of(strategy) if s.kind in kinds]
    taken = {p[0] for p in out}
    for code, m, *_ in models:
        if code not in taken:
            sample, pdf, tag = _model_sampling(m, strategy)
            out.append((code, sample, pdf, code in LOBE_CHOICE_CODES, tag))
    return tuple(out)


def _delta_models(models: tuple) -> tuple:
    """((kind code, delta_reflection), ...) of the model kinds with a mirror lobe beside their
    density (smooth_plastic.py): sample_bsdf picks it with its probability (1/2 under the uniform
    strategy), and pdf_bsdf is the density of the rest times one minus that."""
    return tuple((code, m.delta_reflection) for code, m, *_ in models if hasattr(m, "delta_reflection"))


def _sphere_codes(models: tuple) -> tuple:
    """The codes of the transmitting model kinds: a uniform proposal draws them over the sphere."""
    return tuple(code for code, _, transmits, _ in models if transmits)


def _make_eval(models: tuple, tabled: tuple):
    """eval_bsdf (f|cos|) of the model kinds `models` and `tabled` (0 for the others)."""
    MODELS = models
    TABLED = tabled

    @wp.func
    def eval_bsdf(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> wp.vec3:
        """f(wo, wi) * |cos(theta_i)| for the non-delta kinds; zero for delta kinds."""
        kind = mat.kind
        r = wp.vec3(0.0)
        _variant = wp.static(variant_tag(MODELS))  # noqa: F841 (the loop table, hashed: static_tag.py)
        for i in range(wp.static(len(MODELS))):
            if kind == wp.static(MODELS[i][0]):
                r = wp.static(MODELS[i][1].eval_bsdf)(mat.albedo, mat.shape, mat.ior, n, wo, wi)
                if wp.static(MODELS[i][3]):
                    r = wp.cw_mul(r, half_fresnel(mat.eta, mat.k, wo, wi))
        _tabled = wp.static(variant_tag(TABLED))  # noqa: F841 (static_tag.py)
        for i in range(wp.static(len(TABLED))):
            if kind == wp.static(TABLED[i][0]):
                r = wp.static(TABLED[i][1].eval_bsdf)(mat.albedo, mat.shape, mat.ior, mat.table, mat.row, n, wo, wi)
        return r

    return eval_bsdf


def _make_pdf(lobe: bool, plug: tuple, models: tuple, tabled: tuple):
    """pdf_bsdf (the density sample_bsdf proposes with) of the model kinds."""
    SPHERE_MODELS = _sphere_codes(models)
    DELTA_MODELS = _delta_models(models)
    TABLED = tabled
    LOBE = lobe
    PLUG = plug

    @wp.func
    def pdf_bsdf(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> float:
        """Solid-angle density with which `sample_bsdf` proposes wi (non-delta kinds)."""
        kind = mat.kind
        p = float(0.0)
        _variant = wp.static(variant_tag((PLUG, SPHERE_MODELS, DELTA_MODELS)))  # noqa: F841 (static_tag.py)
        if wp.static(not LOBE):
            if wp.dot(n, wo) * wp.dot(n, wi) > 0.0:
                p = 0.5 * INV_PI
            for i in range(wp.static(len(SPHERE_MODELS))):
                if kind == wp.static(SPHERE_MODELS[i]):
                    p = INV_4PI
        if wp.static(LOBE):
            for i in range(wp.static(len(PLUG))):
                if kind == wp.static(PLUG[i][0]):
                    p = wp.static(PLUG[i][2])(mat.shape, mat.ior, n, wo, wi)
            _tabled = wp.static(variant_tag(TABLED))  # noqa: F841 (static_tag.py)
            for i in range(wp.static(len(TABLED))):
                if kind == wp.static(TABLED[i][0]):
                    p = wp.static(TABLED[i][1].pdf)(mat.shape, mat.ior, mat.table, mat.row, n, wo, wi)
        for i in range(wp.static(len(DELTA_MODELS))):
            if kind == wp.static(DELTA_MODELS[i][0]):
                pd = float(0.5)
                if wp.static(LOBE):
                    pd = wp.static(DELTA_MODELS[i][1])(mat.shape, mat.ior, n, wo)[0]
                p = p * (1.0 - pd)
        return p

    return pdf_bsdf


def _make_sampler(lobe: bool, eval_bsdf, pdf_bsdf, plug: tuple, models: tuple, tabled: tuple, deltas: tuple):
    """sample_bsdf: the delta kinds `deltas` by their sample_delta, the others by proposal (a model
    kind's own, or a plugged lobe sampler's) and eval_bsdf / pdf_bsdf."""
    DELTAS = deltas
    PLUG = plug
    SPHERE_MODELS = _sphere_codes(models)
    DELTA_MODELS = _delta_models(models)
    TABLED = tabled
    LOBE = lobe

    @wp.func
    def sample_bsdf(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, u_lobe: float, u: wp.vec2) -> Scatter:
        kind = mat.kind
        s = Scatter()
        s.valid = 0
        _variant = wp.static(variant_tag((PLUG, SPHERE_MODELS, DELTA_MODELS, DELTAS)))  # noqa: F841 (static_tag.py)
        s.delta = 0
        for i in range(wp.static(len(DELTAS))):
            if kind == wp.static(DELTAS[i][0]):
                return wp.static(DELTAS[i][1].sample_delta)(mat, n, wo, u_lobe, wp.static(0 if LOBE else 1))
        cos_o = wp.dot(n, wo)
        nf = n
        if cos_o < 0.0:
            nf = -n
        co = wp.abs(cos_o)
        if kind == EMITTER:
            return s
        for i in range(wp.static(len(DELTA_MODELS))):
            if kind == wp.static(DELTA_MODELS[i][0]):
                dr = wp.static(DELTA_MODELS[i][1])(mat.shape, mat.ior, n, wo)
                pd = float(0.5)
                if wp.static(LOBE):
                    pd = dr[0]
                if u_lobe < pd:
                    s.wi = 2.0 * co * nf - wo
                    s.weight = wp.vec3(dr[1] / pd)
                    s.delta = 1
                    s.valid = 1
                    return s
        # Non-delta kinds: propose a direction, then weight = f|cos| / pdf evaluated separately.
        wi = wp.vec3(0.0)
        if wp.static(not LOBE):
            wi = frame_to_world(square_to_uniform_hemisphere(u), nf)
            for i in range(wp.static(len(SPHERE_MODELS))):
                if kind == wp.static(SPHERE_MODELS[i]):
                    wi = square_to_uniform_sphere(u)
        if wp.static(LOBE):
            for i in range(wp.static(len(PLUG))):
                if kind == wp.static(PLUG[i][0]):
                    ul = float(0.0)
                    if wp.static(PLUG[i][3]):
                        ul = u_lobe
                    wi = wp.static(PLUG[i][1])(mat.albedo, mat.shape, mat.ior, n, wo, ul, u)
            _tabled = wp.static(variant_tag(TABLED))  # noqa: F841 (static_tag.py)
            for i in range(wp.static(len(TABLED))):
                if kind == wp.static(TABLED[i][0]):
                    wi = wp.static(TABLED[i][1].sample)(mat.albedo, mat.shape, mat.ior, mat.table, mat.row, n, wo,
                                                        u_lobe, u)
        pdf = pdf_bsdf(mat, n, wo, wi)
        if pdf > 0.0:
            fc = eval_bsdf(mat, n, wo, wi)
            if fc[0] > 0.0 or fc[1] > 0.0 or fc[2] > 0.0:
                s.wi = wi
                s.pdf = pdf
                s.weight = fc / pdf
                s.valid = 1
        return s

    return sample_bsdf
