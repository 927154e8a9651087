"""The parameters of the Disney (2015) kinds `principled` and `principled_thin` (Mitsuba 3's
`principled` and `principledthin`, src/bsdfs/principled*.cpp): names, Mitsuba's defaults, the
ranges drtlab accepts, and their place in a material's parameter vector.

Both kinds read one vector of PARAM_COUNT floats per hit (MaterialAt.param): a material's values,
in PARAMS order (its row of MaterialData.table), with a textured parameter (`<name>_texture`, a
TEXTURE_SLOTS slot of the same name) looked up at the hit. A kind reads the names its row lists
(MaterialKind.params) and leaves the others at their defaults. `albedo` is Mitsuba's `base_color`,
`ior` its `eta` (principled: also `specular`, converted by the importer).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Param:
    name: str
    default: float
    lo: float
    hi: float
    texturable: bool = True


PARAMS = (
    Param("roughness", 0.5, 0.0, 1.0),
    Param("anisotropic", 0.0, 0.0, 1.0),
    Param("metallic", 0.0, 0.0, 1.0),
    Param("spec_trans", 0.0, 0.0, 1.0),
    Param("spec_tint", 0.0, 0.0, 1.0),
    Param("sheen", 0.0, 0.0, 1.0),
    Param("sheen_tint", 0.0, 0.0, 1.0),
    Param("clearcoat", 0.0, 0.0, 1.0),
    Param("clearcoat_gloss", 0.0, 0.0, 1.0),
    Param("flatness", 0.0, 0.0, 1.0),
    Param("diff_trans", 0.0, 0.0, 2.0),        # Mitsuba's range: 0 all reflection, 2 all transmission
    # Lobe-sampling rates (Mitsuba's; they change the proposal, not the estimate's expectation).
    Param("main_specular_sampling_rate", 1.0, 0.0, 1e3, False),
    Param("clearcoat_sampling_rate", 1.0, 0.0, 1e3, False),
    Param("diffuse_reflectance_sampling_rate", 1.0, 0.0, 1e3, False),
    Param("specular_reflectance_sampling_rate", 1.0, 0.0, 1e3, False),
    Param("specular_transmittance_sampling_rate", 1.0, 0.0, 1e3, False),
    Param("diffuse_transmittance_sampling_rate", 1.0, 0.0, 1e3, False),
)
PARAM_INDEX = {p.name: i for i, p in enumerate(PARAMS)}
PARAM_BY_NAME = {p.name: p for p in PARAMS}
PARAM_COUNT = len(PARAMS)

_COMMON = ("roughness", "anisotropic", "spec_trans", "spec_tint", "sheen", "sheen_tint", "flatness")
# Each kind's parameters (its MaterialKind.params).
PRINCIPLED = _COMMON + ("metallic", "clearcoat", "clearcoat_gloss", "main_specular_sampling_rate",
                        "clearcoat_sampling_rate", "diffuse_reflectance_sampling_rate")
PRINCIPLED_THIN = _COMMON + ("diff_trans", "specular_reflectance_sampling_rate",
                             "specular_transmittance_sampling_rate", "diffuse_transmittance_sampling_rate",
                             "diffuse_reflectance_sampling_rate")
IOR_DEFAULT = 1.5       # principled: specular 0.5; principledthin: eta 1.5


def eta_of_specular(specular: float) -> float:
    """Mitsuba's principled `specular` as an index: 2 / (1 - sqrt(0.08 specular)) - 1 (its R0 is
    0.08 specular)."""
    return 2.0 / (1.0 - float(np.sqrt(0.08 * specular))) - 1.0


def param_row(params: dict | None = None) -> np.ndarray:
    """A material's parameter vector (float32, PARAMS order): `params`' values, else defaults."""
    params = params or {}
    unknown = set(params) - set(PARAM_INDEX)
    if unknown:
        raise KeyError(f"unknown principled parameters {sorted(unknown)}")
    return np.array([params.get(p.name, p.default) for p in PARAMS], dtype=np.float32)
