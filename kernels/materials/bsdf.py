"""The kind switches of one kernel variant: eval, pdf and sample of every material kind the scene has
(the package docstring describes them)."""
from types import SimpleNamespace
from typing import NamedTuple

import warp as wp

from drtlab.estimators.domain_maps import (INV_4PI, INV_PI, frame_to_world, phong_lobe_pdf,
                                           square_to_cosine_hemisphere, square_to_phong_lobe,
                                           square_to_uniform_hemisphere, square_to_uniform_sphere)
from drtlab.estimators.strategies import Strategy
from drtlab.kernels.features import Features
from drtlab.kernels.scene_model.material_kinds import KINDS, MATERIAL_CODE, kinds_where
from drtlab.kernels.static_tag import variant_tag
from drtlab.kernels.materials.dielectric import (eval_glossy_dielectric, fresnel, glossy_dielectric_lobes,
                                                 interface, refract_dir)
from drtlab.kernels.materials.ggx import eval_ggx, ggx_half, make_ggx_normals
from drtlab.kernels.materials.conductor import fresnel_conductor, half_fresnel
from drtlab.kernels.materials.kinds import (CONDUCTOR, DIELECTRIC, DIFFUSE, EMITTER, GGX, GGX_DIELECTRIC,
                                            GLOSSY, GLOSSY_DIELECTRIC, MIRROR, PLASTIC)
from drtlab.kernels.materials.plastic import eval_plastic, plastic_coat_probability


@wp.struct
class Scatter:
    wi: wp.vec3
    weight: wp.vec3     # f * |cos| / pdf, or the delta lobe's weight
    pdf: float          # solid-angle pdf; 0 for delta lobes
    delta: int
    valid: int



# The material kinds whose sample_bsdf reads u_lobe; every other kind samples one lobe.
LOBE_CHOICE_KINDS = frozenset(kinds_where(lambda k: k.lobe_choice))
LOBE_CHOICE_CODES = frozenset(MATERIAL_CODE[k] for k in LOBE_CHOICE_KINDS)
# The kinds whose code is in this module's switches (a kind with a `model` brings its own module).
SWITCH_KINDS = kinds_where(lambda k: not k.model and not k.emitter)


class Bsdf(NamedTuple):
    eval_bsdf: wp.Function      # (kind, albedo, exponent, ior, cond_eta, cond_k, table, row, n, wo, wi)
                                # -> f|cos|
    pdf_bsdf: wp.Function       # (kind, exponent, ior, table, row, n, wo, wi) -> sample_bsdf's density
    sample_bsdf: wp.Function    # (kind, albedo, exponent, ior, cond_eta, cond_k, table, row, n, wo, u_lobe,
                                # u) -> Scatter


def make_bsdf(f: Features, strategy: Strategy) -> Bsdf:
    normals = make_ggx_normals(strategy.microfacet == "vndf")
    models = _models(f.kinds)
    plug = _plugged(f.kinds, strategy, models)
    eval_bsdf = _make_eval(f.kinds, models)
    pdf_bsdf = _make_pdf(f.kinds, strategy.lobe, normals[1], plug, models)
    sample_bsdf = _make_sampler(f.kinds, strategy.lobe, eval_bsdf, pdf_bsdf, normals[0], plug, models)
    return Bsdf(eval_bsdf=eval_bsdf, pdf_bsdf=pdf_bsdf, sample_bsdf=sample_bsdf)


def _models(kinds: frozenset) -> tuple:
    """((kind code, module, transmits, conductor), ...) of the present kinds the kind table gives a
    model module (MaterialKind.model): their eval_bsdf (times the conductor Fresnel for a conductor
    kind), and their lobe sampling unless a strategy's lobe sampler replaces it."""
    import importlib
    return tuple((MATERIAL_CODE[k.name], importlib.import_module(f"drtlab.kernels.materials.{k.model}"),
                  k.transmits, k.conductor) for k in KINDS if k.model and not k.table and k.name in kinds)


def _table_models(kinds: frozenset) -> tuple:
    """((kind code, module), ...) of the present kinds whose model reads its material's row of the
    flat per-material table (MaterialKind.table): their eval_bsdf, sample and pdf take the table and
    the row's offset after `ior` (rough_plastic.py)."""
    import importlib
    return tuple((MATERIAL_CODE[k.name], importlib.import_module(f"drtlab.kernels.materials.{k.model}"))
                 for k in KINDS if k.table and k.name in kinds)


def _plugged(kinds: frozenset, strategy: Strategy, models: tuple) -> tuple:
    """((kind code, sample, pdf, reads u_lobe), ...): the strategy's lobe samplers
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
    out += [(code, m.sample, m.pdf, code in LOBE_CHOICE_CODES, m) for code, m, *_ in models if code not in taken]
    return tuple(out)


def _built_in(kinds: frozenset, plug: tuple) -> frozenset:
    """The kinds whose lobes the built-in code samples (those no plugged sampler replaces)."""
    return frozenset(kinds) - {k for k, code in MATERIAL_CODE.items() if any(p[0] == code for p in plug)}


def _present(kinds: frozenset) -> SimpleNamespace:
    """Which of the switch-coded kinds a variant compiles in, as attributes its functions read with
    wp.static (K.diffuse, K.ggx_dielectric, ...)."""
    return SimpleNamespace(**{k: k in kinds for k in SWITCH_KINDS})


def _delta_models(models: tuple) -> tuple:
    """((kind code, delta_reflection), ...) of the model kinds with a mirror lobe beside their
    density (smooth_plastic.py): sample_bsdf picks it with its probability (1/2 under the uniform
    strategy), and pdf_bsdf is the density of the rest times one minus that."""
    return tuple((code, m.delta_reflection) for code, m, *_ in models if hasattr(m, "delta_reflection"))


def _sphere_codes(models: tuple) -> tuple:
    """The codes of the transmitting model kinds: a uniform proposal draws them over the sphere."""
    return tuple(code for code, _, transmits, _ in models if transmits)


def _make_eval(kinds: frozenset, models: tuple):
    """eval_bsdf (f|cos|) of `kinds`."""
    MODELS = models
    TABLED = _table_models(kinds)
    K = _present(kinds)

    @wp.func
    def eval_bsdf(kind: int, albedo: wp.vec3, exponent: float, ior: float, cond_eta: wp.vec3, cond_k: wp.vec3,
                  table: wp.array(dtype=float), row: int, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> wp.vec3:
        """f(wo, wi) * |cos(theta_i)| for the non-delta kinds; zero for delta kinds."""
        r = wp.vec3(0.0)
        cos_o = wp.dot(n, wo)
        cos_i = wp.dot(n, wi)
        if wp.static(K.diffuse):
            if kind == DIFFUSE:
                if cos_o * cos_i > 0.0:
                    r = albedo * (wp.abs(cos_i) * INV_PI)
        if wp.static(K.glossy):
            if kind == GLOSSY:
                if cos_o * cos_i > 0.0:
                    refl = 2.0 * cos_o * n - wo
                    ca = wp.dot(refl, wi)
                    if ca > 0.0:
                        r = albedo * ((exponent + 2.0) * 0.5 * INV_PI * wp.pow(ca, exponent)
                                      * wp.abs(cos_i))
        if wp.static(K.glossy_dielectric):
            if kind == GLOSSY_DIELECTRIC:
                r = eval_glossy_dielectric(albedo, exponent, ior, n, wo, wi)
        if wp.static(K.plastic):
            if kind == PLASTIC:
                r = eval_plastic(albedo, exponent, ior, n, wo, wi)
        if wp.static(K.ggx):
            if kind == GGX:
                r = eval_ggx(albedo, exponent, ior, n, wo, wi, 0)
        if wp.static(K.ggx_dielectric):
            if kind == GGX_DIELECTRIC:
                r = eval_ggx(albedo, exponent, ior, n, wo, wi, 1)
        _variant = wp.static(variant_tag(MODELS))  # noqa: F841 (the loop table, hashed: static_tag.py)
        for i in range(wp.static(len(MODELS))):
            if kind == wp.static(MODELS[i][0]):
                r = wp.static(MODELS[i][1].eval_bsdf)(albedo, exponent, ior, n, wo, wi)
                if wp.static(MODELS[i][3]):
                    r = wp.cw_mul(r, half_fresnel(cond_eta, cond_k, wo, wi))
        _tabled = wp.static(variant_tag(TABLED))  # noqa: F841 (static_tag.py)
        for i in range(wp.static(len(TABLED))):
            if kind == wp.static(TABLED[i][0]):
                r = wp.static(TABLED[i][1].eval_bsdf)(albedo, exponent, ior, table, row, n, wo, wi)
        return r

    return eval_bsdf


def _make_pdf(all_kinds: frozenset, lobe: bool, ggx_normal_pdf, plug: tuple, models: tuple):
    """pdf_bsdf (the density sample_bsdf proposes with) of `all_kinds`."""
    K = _present(_built_in(all_kinds, plug))
    SPHERE_MODELS = _sphere_codes(models)
    DELTA_MODELS = _delta_models(models)
    TABLED = _table_models(all_kinds)
    LOBE = lobe
    PLUG = plug

    @wp.func
    def pdf_bsdf(kind: int, exponent: float, ior: float, table: wp.array(dtype=float), row: int, n: wp.vec3,
                 wo: wp.vec3, wi: wp.vec3) -> float:
        """Solid-angle density with which `sample_bsdf` proposes wi (non-delta kinds)."""
        cos_o = wp.dot(n, wo)
        cos_i = wp.dot(n, wi)
        p = float(0.0)
        _variant = wp.static(variant_tag((PLUG, SPHERE_MODELS, DELTA_MODELS)))  # noqa: F841 (static_tag.py)
        if wp.static(not LOBE):
            if kind == GLOSSY_DIELECTRIC or kind == GGX_DIELECTRIC:
                p = INV_4PI
            elif cos_o * cos_i > 0.0:
                p = 0.5 * INV_PI
            for i in range(wp.static(len(SPHERE_MODELS))):
                if kind == wp.static(SPHERE_MODELS[i]):
                    p = INV_4PI
        if wp.static(LOBE):
            if wp.static(K.diffuse):
                if kind == DIFFUSE:
                    if cos_o * cos_i > 0.0:
                        p = wp.abs(cos_i) * INV_PI
            if wp.static(K.glossy):
                if kind == GLOSSY:
                    if cos_o * cos_i > 0.0:
                        nf = n
                        if cos_o < 0.0:
                            nf = -n
                        refl = 2.0 * wp.abs(cos_o) * nf - wo
                        p = phong_lobe_pdf(wp.dot(refl, wi), exponent)
            if wp.static(K.glossy_dielectric):
                if kind == GLOSSY_DIELECTRIC:
                    it = interface(n, wo, ior)
                    lobes = glossy_dielectric_lobes(it, wo, wi, exponent)
                    # The proposal is the Fresnel-weighted mixture of both lobes wherever wi lies.
                    p = it.F * lobes[0] + (1.0 - it.F) * lobes[1]
            if wp.static(K.plastic):
                if kind == PLASTIC:
                    if cos_o * cos_i > 0.0:
                        # The mixture of the coat's Phong lobe and the base's cosine lobe.
                        pc = plastic_coat_probability(wp.abs(cos_o), ior)
                        refl = 2.0 * cos_o * n - wo
                        p = (pc * phong_lobe_pdf(wp.dot(refl, wi), exponent)
                             + (1.0 - pc) * wp.abs(cos_i) * INV_PI)
            if wp.static(K.ggx):
                if kind == GGX:
                    nf = n
                    if cos_o < 0.0:
                        nf = -n
                    mf = ggx_half(nf, 1.0, wo, wi, 0)
                    if mf.valid == 1:
                        p = ggx_normal_pdf(exponent, nf, wp.abs(cos_o), mf.wm, mf.om) * mf.dwm
            if wp.static(K.ggx_dielectric):
                if kind == GGX_DIELECTRIC:
                    it = interface(n, wo, ior)
                    mf = ggx_half(it.nf, it.eta, wo, wi, 1)
                    if mf.valid == 1:
                        # The lobe chosen with probability F(wo.wm), then its Jacobian.
                        pl = mf.F
                        if mf.reflect == 0:
                            pl = 1.0 - mf.F
                        p = ggx_normal_pdf(exponent, it.nf, it.co, mf.wm, mf.om) * mf.dwm * pl
            for i in range(wp.static(len(PLUG))):
                if kind == wp.static(PLUG[i][0]):
                    p = wp.static(PLUG[i][2])(exponent, ior, n, wo, wi)
            _tabled = wp.static(variant_tag(TABLED))  # noqa: F841 (static_tag.py)
            for i in range(wp.static(len(TABLED))):
                if kind == wp.static(TABLED[i][0]):
                    p = wp.static(TABLED[i][1].pdf)(exponent, ior, table, row, n, wo, wi)
        for i in range(wp.static(len(DELTA_MODELS))):
            if kind == wp.static(DELTA_MODELS[i][0]):
                pd = float(0.5)
                if wp.static(LOBE):
                    pd = wp.static(DELTA_MODELS[i][1])(exponent, ior, n, wo)[0]
                p = p * (1.0 - pd)
        return p

    return pdf_bsdf


def _make_sampler(all_kinds: frozenset, lobe: bool, eval_bsdf, pdf_bsdf, sample_ggx_normal, plug: tuple,
                  models: tuple):
    """sample_bsdf of `all_kinds`: delta lobes directly, the others by proposal and eval_bsdf /
    pdf_bsdf (a plugged kind by its lobe sampler)."""
    K = _present(_built_in(all_kinds, plug))
    PLUG = plug
    SPHERE_MODELS = _sphere_codes(models)
    DELTA_MODELS = _delta_models(models)
    TABLED = _table_models(all_kinds)
    LOBE = lobe

    @wp.func
    def sample_bsdf(kind: int, albedo: wp.vec3, exponent: float, ior: float, cond_eta: wp.vec3, cond_k: wp.vec3,
                    table: wp.array(dtype=float), row: int, n: wp.vec3, wo: wp.vec3, u_lobe: float,
                    u: wp.vec2) -> Scatter:
        s = Scatter()
        s.valid = 0
        _variant = wp.static(variant_tag((PLUG, SPHERE_MODELS, DELTA_MODELS)))  # noqa: F841 (static_tag.py)
        s.delta = 0
        cos_o = wp.dot(n, wo)
        nf = n
        if cos_o < 0.0:
            nf = -n
        co = wp.abs(cos_o)
        if wp.static(K.mirror):
            if kind == MIRROR:
                s.wi = 2.0 * co * nf - wo
                s.weight = albedo
                s.delta = 1
                s.valid = 1
                return s
        if wp.static(K.conductor):
            if kind == CONDUCTOR:
                s.wi = 2.0 * co * nf - wo
                s.weight = wp.cw_mul(albedo, fresnel_conductor(co, cond_eta, cond_k))
                s.delta = 1
                s.valid = 1
                return s
        if wp.static(K.dielectric):
            if kind == DIELECTRIC:
                it = interface(n, wo, ior)
                eta = it.eta
                F = it.F
                p_reflect = F
                if wp.static(not LOBE):
                    p_reflect = 0.5
                if F >= 1.0:
                    p_reflect = 1.0
                s.delta = 1
                s.valid = 1
                if u_lobe < p_reflect:
                    s.wi = 2.0 * co * nf - wo
                    s.weight = wp.vec3(F / p_reflect)
                else:
                    s.wi = refract_dir(wo, nf, co, eta)
                    s.weight = albedo * ((1.0 - F) / ((1.0 - p_reflect) * eta * eta))
                return s
        if kind == EMITTER:
            return s
        for i in range(wp.static(len(DELTA_MODELS))):
            if kind == wp.static(DELTA_MODELS[i][0]):
                dr = wp.static(DELTA_MODELS[i][1])(exponent, ior, n, wo)
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
            if kind == GLOSSY_DIELECTRIC or kind == GGX_DIELECTRIC:
                wi = square_to_uniform_sphere(u)
            else:
                wi = frame_to_world(square_to_uniform_hemisphere(u), nf)
            for i in range(wp.static(len(SPHERE_MODELS))):
                if kind == wp.static(SPHERE_MODELS[i]):
                    wi = square_to_uniform_sphere(u)
        if wp.static(LOBE):
            if wp.static(K.diffuse):
                if kind == DIFFUSE:
                    wi = frame_to_world(square_to_cosine_hemisphere(u), nf)
            if wp.static(K.glossy):
                if kind == GLOSSY:
                    wi = frame_to_world(square_to_phong_lobe(u, exponent), 2.0 * co * nf - wo)
            if wp.static(K.glossy_dielectric):
                if kind == GLOSSY_DIELECTRIC:
                    it = interface(n, wo, ior)
                    axis = 2.0 * co * nf - wo
                    if u_lobe >= it.F:
                        axis = refract_dir(wo, nf, co, it.eta)
                    wi = frame_to_world(square_to_phong_lobe(u, exponent), axis)
            if wp.static(K.plastic):
                if kind == PLASTIC:
                    if u_lobe < plastic_coat_probability(co, ior):
                        wi = frame_to_world(square_to_phong_lobe(u, exponent), 2.0 * co * nf - wo)
                    else:
                        wi = frame_to_world(square_to_cosine_hemisphere(u), nf)
            if wp.static(K.ggx):
                if kind == GGX:
                    if co <= 0.0:
                        return s
                    wm = sample_ggx_normal(nf, wo, co, exponent, u)
                    wi = 2.0 * wp.dot(wo, wm) * wm - wo
            if wp.static(K.ggx_dielectric):
                if kind == GGX_DIELECTRIC:
                    it = interface(n, wo, ior)
                    if it.co <= 0.0:
                        return s
                    wm = sample_ggx_normal(it.nf, wo, it.co, exponent, u)
                    om = wp.dot(wo, wm)
                    if om <= 0.0:
                        return s
                    if u_lobe < fresnel(om, it.eta):
                        wi = 2.0 * om * wm - wo
                        if wp.dot(it.nf, wi) <= 0.0:
                            return s        # reflected below: pdf_bsdf would read it as refracted
                    else:
                        wi = refract_dir(wo, wm, om, it.eta)
                        if wp.dot(it.nf, wi) >= 0.0:
                            return s        # refracted above: pdf_bsdf would read it as reflected
            for i in range(wp.static(len(PLUG))):
                if kind == wp.static(PLUG[i][0]):
                    ul = float(0.0)
                    if wp.static(PLUG[i][3]):
                        ul = u_lobe
                    wi = wp.static(PLUG[i][1])(albedo, exponent, ior, n, wo, ul, u)
            _tabled = wp.static(variant_tag(TABLED))  # noqa: F841 (static_tag.py)
            for i in range(wp.static(len(TABLED))):
                if kind == wp.static(TABLED[i][0]):
                    wi = wp.static(TABLED[i][1].sample)(albedo, exponent, ior, table, row, n, wo, u_lobe, u)
        pdf = pdf_bsdf(kind, exponent, ior, table, row, n, wo, wi)
        if pdf > 0.0:
            fc = eval_bsdf(kind, albedo, exponent, ior, cond_eta, cond_k, table, row, n, wo, wi)
            if fc[0] > 0.0 or fc[1] > 0.0 or fc[2] > 0.0:
                s.wi = wi
                s.pdf = pdf
                s.weight = fc / pdf
                s.valid = 1
        return s

    return sample_bsdf

