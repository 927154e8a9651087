"""Material kind codes (MaterialData.kind), defined by material_kinds.KINDS, as Warp constants."""
import warp as wp

from drtlab.kernels.scene_model.material_kinds import MATERIAL_CODE, kinds_where

# Material kind codes (MaterialData.kind), defined by material_kinds.KINDS.
DIFFUSE = wp.constant(MATERIAL_CODE["diffuse"])
GLOSSY = wp.constant(MATERIAL_CODE["glossy"])
MIRROR = wp.constant(MATERIAL_CODE["mirror"])
DIELECTRIC = wp.constant(MATERIAL_CODE["dielectric"])
GLOSSY_DIELECTRIC = wp.constant(MATERIAL_CODE["glossy_dielectric"])
EMITTER = wp.constant(MATERIAL_CODE["emitter"])
PLASTIC = wp.constant(MATERIAL_CODE["plastic"])
GGX = wp.constant(MATERIAL_CODE["ggx"])
GGX_DIELECTRIC = wp.constant(MATERIAL_CODE["ggx_dielectric"])
CONDUCTOR = wp.constant(MATERIAL_CODE["conductor"])

# The material kinds whose sample_bsdf reads u_lobe; every other kind samples one lobe.
LOBE_CHOICE_KINDS = frozenset(kinds_where(lambda k: k.lobe_choice))
