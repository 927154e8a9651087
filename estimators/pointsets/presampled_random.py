"""Cook's pre-sampled table randomised per pixel and seed (unbiased): see presampled.py."""
from drtlab.estimators.pointsets.presampled import RANDOM_POINTSET as POINTSET

__all__ = ["POINTSET"]
