"""Materials per kernel variant: kind codes (`kinds.py`), one model module per kind that scatters,
named by its kind-table row's `model` (`diffuse.py`, `phong.py`, `mirror.py`, `dielectric.py` (also
Fresnel and refraction), `conductor.py` (also a metal's Fresnel), `glossy_dielectric.py`,
`plastic.py`, `ggx.py`, `ggx_dielectric.py`, `beckmann.py`, `beckmann_conductor.py`, `principled.py`, ...), a
variant's composition of them (`bsdf.py`; `Scatter` in `scatter.py`; the uniform strategy's
proposals in `uniform.py`), the material at a hit as one record (`material_at.py`),
(checkered) albedo and emission (`surface.py`).

Every kind that scatters is a model module (`MaterialKind.model`) with one interface on the material
at a hit, `mat` a MaterialAt (`material_at_hit(sd, h)`: kind, albedo, shape, ior, a conductor's
complex index (eta, k), the material's row of the flat per-material table and a `params` kind's
parameters at the hit, `param`):
    eval(mat, n, wo, wi)          -> f(wo, wi) |cos theta_i| (0 for a delta lobe)
    pdf(mat, n, wo, wi)           -> the solid-angle density with which sample proposes wi (it
                                     reads no albedo; 0 for a delta kind)
    sample(mat, n, wo, u_lobe, u) -> Scatter: `proposal(wi)`, a direction of density pdf, or
                                     `delta_scatter(wi, weight)`, a delta lobe (scatter.py)
`n` is the shading normal as the surface has it (outward), `u_lobe` a uniform number for a kind that
chooses between lobes (`MaterialKind.lobe_choice`; 0 for the others), `u` two more. A lobe sampler
(kernels/lobe_samplers.py) is a sample / pdf pair of the same signatures. `mat.shape` is the lobe's
one shape parameter (MaterialKind.shape): the Phong exponent, the microfacet alpha or the albedo's
mean. A kind whose row sets `strategy_sampling` also has `sampling(strategy)` -> (sample, pdf) as the
strategy says (GGX normals by `microfacet`; a delta lobe chosen with probability 1/2 under the
uniform strategy); a `table` kind has `table_row` (its row, built on the host).

`mat.opacity` and `mat.one_sided` are not the kind's to read: mask.py wraps every kind's eval, pdf
and sample in them (Mitsuba's `mask` and one-sided BSDFs) where the variant has them.

`make_bsdf(features, strategy)` composes the features' kinds (bsdf.py) into Bsdf, Warp functions
that can be called on their own (the tracer, MIS and the chi-square tests use the same ones):
    eval_bsdf(mat, n, wo, wi)          -> the kind's eval
    pdf_bsdf(mat, n, wo, wi)           -> the density of sample_bsdf (its non-delta part)
    sample_bsdf(mat, n, wo, u_lobe, u) -> Scatter (a proposal weighed by eval / pdf)
`strategy.lobe` True samples each kind by its own sample (or the strategy's lobe sampler for it),
False by the uniform hemisphere (sphere for a kind that transmits; uniform.py), a kind with a delta
lobe picking it with probability 1/2.
`surface_albedo(sd, m, uv)` is the (checkered) albedo, `emitted(sd, h, wo)` a hit's emission.
"""
from drtlab.kernels.materials.bsdf import Bsdf, Scatter, make_bsdf  # noqa: F401
from drtlab.kernels.materials.kinds import DIFFUSE, EMITTER, LOBE_CHOICE_KINDS  # noqa: F401
from drtlab.kernels.materials.surface import checkered, emitted, surface_albedo  # noqa: F401
