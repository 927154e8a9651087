"""Materials per kernel variant: kind codes (`kinds.py`), one model module per kind that scatters,
named by its kind-table row's `model` (`diffuse.py`, `phong.py`, `mirror.py`, `dielectric.py` (also
Fresnel and refraction), `conductor.py` (also a metal's Fresnel), `glossy_dielectric.py`,
`plastic.py`, `ggx.py`, `ggx_dielectric.py`, `beckmann.py`, ...), a variant's composition of them
(`bsdf.py`; `Scatter` in `scatter.py`), the material at a hit as one record (`material_at.py`),
(checkered) albedo and emission (`surface.py`).

`make_bsdf(features, strategy)` returns Bsdf, Warp functions of the features' material kinds that
can be called on their own (the tracer, MIS and the chi-square tests use the same ones):
    eval_bsdf(mat, n, wo, wi)          -> f(wo, wi) |cos theta_i| (non-delta kinds)
    pdf_bsdf(mat, n, wo, wi)           -> solid-angle density of sample_bsdf (it reads no albedo)
    sample_bsdf(mat, n, wo, u_lobe, u) -> Scatter (weight = f|cos|/pdf)
`mat` is a MaterialAt (`material_at(sd, m, uv)`): kind, albedo, shape, ior, a conductor's complex
index (eta, k) and the material's row of the flat per-material table (MaterialKind.table kinds).
`strategy.lobe` True samples cosine / Phong lobes / Fresnel, False samples uniform hemisphere
(sphere for glossy transmission) and picks reflect/refract with probability 1/2.
`plastic` is a diffuse base under a glossy dielectric coat; its model is `eval_plastic`'s docstring.
`mat.shape` is the material's lobe shape (MaterialKind.shape_key): the Phong exponent, or GGX's alpha
for `ggx` (a rough conductor whose facets reflect `albedo`) and `ggx_dielectric` (Walter et al. 2007
rough reflection and transmission); their model is ggx.py's comment. `strategy.microfacet`
picks how the lobe strategy draws their microfacet normals (visible normals or D cos).
`surface_albedo(sd, m, uv)` is the (checkered) albedo, `emitted(sd, h, wo)` a hit's emission.
"""
from drtlab.kernels.materials.bsdf import Bsdf, Scatter, make_bsdf  # noqa: F401
from drtlab.kernels.materials.kinds import DIFFUSE, EMITTER, LOBE_CHOICE_KINDS  # noqa: F401
from drtlab.kernels.materials.surface import checkered, emitted, surface_albedo  # noqa: F401
