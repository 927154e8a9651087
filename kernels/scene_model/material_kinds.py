"""One descriptor per material kind: what every layer reads of a kind, in one table.

The scene loader reads which keys a kind takes (`MaterialKind.keys`), the kernels its integer code
(`MATERIAL_CODE`) and which of their code paths it needs (features.SPLITTING_KINDS,
materials.LOBE_CHOICE_KINDS), the lobe tool which kinds have a lobe to plot and how
(experiments/tools/lobes.py). A new kind is one row here naming its `model`, a module of
kernels/materials/ with the one BSDF interface on the material at a hit (`MaterialAt`):
eval(mat, n, wo, wi), pdf(mat, n, wo, wi) and sample(mat, n, wo, u_lobe, u) -> Scatter
(kernels/materials/__init__.py states the contract; a lobe sampler, kernels/lobe_samplers.py, has
the same sample and pdf): two files. The built-in kinds register the same way (diffuse.py,
phong.py, mirror.py, rough_plastic.py, ...). What a module has beyond the three is declared here:
`strategy_sampling` (its `sampling(strategy)`), `table` (its `table_row`). Only the emitter, which
scatters nothing, has no module.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from drtlab.kernels.scene_model.principled_params import PARAM_BY_NAME, PRINCIPLED, PRINCIPLED_THIN


# GGX alpha in [ROUGHNESS_MIN, 1]: below 1e-3 the surface is a mirror to float32 (the lobe's peak
# density 1 / (pi alpha^2) passes 3e5 and its width the precision of a direction near the normal).
ROUGHNESS_MIN = 1e-3


@dataclass(frozen=True)
class MaterialKind:
    name: str
    delta: bool = False         # light leaves in one or two directions only: no density to sample
    phong: bool = False         # a modified-Phong lobe of the material's `exponent`
    microfacet: bool = False    # a microfacet surface of the material's `roughness` (isotropic
                                # alpha) with Smith masking-shadowing (GGX unless `model` says)
    transmits: bool = False     # light crosses the surface, refracted at the material's `ior`
    coat: bool = False          # a dielectric coat of index `ior` (> 1) over a diffuse base
    checker: bool = False       # may alternate two albedos (`albedo2`, `checker`)
    emitter: bool = False       # black: it only emits, and scatters nothing
    model: str = ""             # its module in kernels/materials/ (eval, pdf, sample on MaterialAt;
                                # the package docstring); "" for the emitter
    albedo_shape: bool = False  # its lobe shape (MaterialAt.shape) is the albedo's mean (Mitsuba's
                                # plastics weigh their lobe choice by it, and pdf reads no albedo)
    conductor: bool = False     # a metal of complex index `eta` + i `k` (per channel): its facets
                                # reflect albedo times the conductor Fresnel (conductor.py, applied
                                # by its model)
    table: bool = False         # its model reads a row of the flat per-material table
                                # (MaterialData.table), built on the host by the model's `table_row`
    delta_lobe: bool = False    # a delta (mirror) lobe beside its density: its `sample` may return
                                # a delta Scatter, so a uniform proposal cannot stand in for it
    anisotropic: bool = False   # a microfacet surface rougher along the tangent dp/du (`alpha_u`)
                                # than across it (`alpha_v`), either a float or a texture
    strategy_sampling: bool = False  # its module's `sampling(strategy)` gives (sample, pdf) as the
                                # strategy says (GGX normals by `microfacet`; a delta lobe chosen
                                # with probability 1/2 under the uniform strategy)
    params: tuple = ()          # the names of its parameter vector (principled_params.py) it reads
                                # (MaterialAt.param; its table row), each a scene-file key, the
                                # texturable ones also `<name>_texture`; light may cross it

    @property
    def ior(self) -> bool:
        """It has a Fresnel interface (the material's `ior`)."""
        return self.transmits or self.coat or bool(self.params)

    @property
    def lobe_choice(self) -> bool:
        """sample_bsdf reads u_lobe: a Fresnel interface splits light between two lobes
        (reflection and transmission, or coat and base)."""
        return self.ior

    @property
    def keys(self) -> tuple[str, ...]:
        """The keys its scene-file table may have: a key the kind ignores is an error, not a silent
        no-op."""
        return (("kind",) + (() if self.emitter else ("albedo",))
                + (("albedo2", "checker", "albedo_texture") if self.checker else ())
                + ((("albedo_texture",) + self.params
                    + tuple(f"{p}_texture" for p in self.params if PARAM_BY_NAME[p].texturable))
                   if self.params else ())
                # a blend of two albedos by a texture (Mitsuba's blendbsdf of two diffuse BSDFs)
                + (("weight_texture", "blend_albedo") if self.name == "diffuse" else ())
                + (("exponent",) if self.phong else ()) + (("roughness",) if self.microfacet else ())
                + (("ior",) if self.ior else ()) + (("eta", "k") if self.conductor else ())
                + (ANISOTROPIC_KEYS if self.anisotropic else ())
                + (() if self.emitter else ("opacity", "opacity_texture"))
                + (() if self.emitter or self.transmits else ("one_sided",))
                + ("emission", "emission_texture")
                + (() if self.emitter else ("normal_texture", "bump_texture", "bump_scale")))

    @property
    def shape_key(self) -> str | None:
        """The scene-file key that gives the lobe's one shape parameter (`shape`: MaterialData.shape,
        MaterialAt.shape): the Phong `exponent`, the microfacet `roughness` (alpha); None for kinds
        whose shape is not a key (the albedo's mean, `albedo_shape`) or that have none."""
        return ("exponent" if self.phong else "roughness" if self.microfacet
                else "alpha_u" if self.anisotropic else None)

    def shape(self, material) -> float:
        """The lobe's shape parameter of `material` (a scene_model Material of this kind): the value
        of its `shape_key`, the albedo's mean for an `albedo_shape` kind, else 0."""
        if self.albedo_shape:
            return float(np.mean(material.albedo))
        return float(getattr(material, self.shape_key)) if self.shape_key else 0.0

    def shape_v(self, material) -> float:
        """The second shape parameter (MaterialData.shape_v): an anisotropic kind's alpha_v, else 0."""
        return float(material.alpha_v) if self.anisotropic else 0.0


# An anisotropic kind's keys: its two alphas and their textures (texture.slot_key of the slots).
ANISOTROPIC_KEYS = ("alpha_u", "alpha_v", "alpha_u_texture", "alpha_v_texture")


# New kinds go at the end: a kind's code is its place here, and the codes of the existing ones stay
# what compiled kernels and caches saw.
KINDS = (
    MaterialKind("diffuse", checker=True, model="diffuse"),
    MaterialKind("glossy", phong=True, checker=True, model="phong"),
    MaterialKind("mirror", delta=True, model="mirror"),
    MaterialKind("dielectric", delta=True, transmits=True, model="dielectric", strategy_sampling=True),
    MaterialKind("glossy_dielectric", phong=True, transmits=True, model="glossy_dielectric"),
    MaterialKind("emitter", emitter=True),
    MaterialKind("plastic", phong=True, coat=True, checker=True, model="plastic"),
    MaterialKind("ggx", microfacet=True, checker=True, model="ggx", strategy_sampling=True),
    MaterialKind("ggx_dielectric", microfacet=True, transmits=True, model="ggx_dielectric",
                 strategy_sampling=True),
    MaterialKind("beckmann", microfacet=True, checker=True, model="beckmann"),
    MaterialKind("ggx_separable", microfacet=True, checker=True, model="ggx_separable"),
    MaterialKind("ggx_dielectric_separable", microfacet=True, transmits=True, model="ggx_dielectric_separable"),
    MaterialKind("smooth_plastic", coat=True, albedo_shape=True, model="smooth_plastic", delta_lobe=True,
                 strategy_sampling=True),
    MaterialKind("smooth_plastic_nonlinear", coat=True, albedo_shape=True, model="smooth_plastic_nonlinear",
                 delta_lobe=True, strategy_sampling=True),
    MaterialKind("beckmann_dielectric", microfacet=True, transmits=True, model="beckmann_dielectric"),
    MaterialKind("conductor", delta=True, conductor=True, model="conductor"),
    MaterialKind("beckmann_conductor", microfacet=True, conductor=True, model="beckmann_conductor"),
    MaterialKind("ggx_conductor", microfacet=True, conductor=True, model="ggx_conductor"),
    MaterialKind("beckmann_plastic", microfacet=True, coat=True, table=True, model="rough_plastic"),
    MaterialKind("ggx_plastic", microfacet=True, coat=True, table=True, model="rough_plastic"),
    MaterialKind("beckmann_plastic_nonlinear", microfacet=True, coat=True, table=True, model="rough_plastic"),
    MaterialKind("ggx_plastic_nonlinear", microfacet=True, coat=True, table=True, model="rough_plastic"),
    MaterialKind("principled", table=True, model="principled", params=PRINCIPLED),
    MaterialKind("principled_thin", table=True, model="principled_thin", params=PRINCIPLED_THIN),
    MaterialKind("ggx_anisotropic", anisotropic=True, conductor=True, model="ggx_anisotropic"),
    MaterialKind("beckmann_conductor_anisotropic", anisotropic=True, conductor=True,
                 model="beckmann_anisotropic"),
)
KIND_BY_NAME = {k.name: k for k in KINDS}
MATERIAL_KINDS = tuple(KIND_BY_NAME)
# The integer code of each material kind, as the kernels see it (SceneData's material kind).
MATERIAL_CODE = {k.name: code for code, k in enumerate(KINDS)}


def kinds_where(test) -> tuple[str, ...]:
    """The names of the kinds whose descriptor passes `test`, in code order."""
    return tuple(k.name for k in KINDS if test(k))
