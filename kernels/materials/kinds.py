"""The kind codes (MaterialData.kind) the tracers name, defined by material_kinds.KINDS, as Warp
constants: the emitter (scatters nothing) and diffuse (where Cook's drt stops a path). Every other
kind is reached through the kind table's flags and its model module (bsdf.py)."""
import importlib

import warp as wp

from drtlab.kernels.scene_model.material_kinds import MATERIAL_CODE, MaterialKind, kinds_where

DIFFUSE = wp.constant(MATERIAL_CODE["diffuse"])
EMITTER = wp.constant(MATERIAL_CODE["emitter"])

# The material kinds whose sample_bsdf reads u_lobe; every other kind samples one lobe.
LOBE_CHOICE_KINDS = frozenset(kinds_where(lambda k: k.lobe_choice))


def model_module(kind: MaterialKind):
    """The module of kernels/materials/ a kind's row names (MaterialKind.model)."""
    return importlib.import_module(f"drtlab.kernels.materials.{kind.model}")
