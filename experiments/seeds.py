"""Seed derivation: every seed is a hash of what it is for, so any single run can be reproduced alone.

Study runs and ground-truth batches draw from disjoint halves of the uint32 range (the top bit is 0
for runs and 1 for ground truth), so a ground-truth batch can never reuse the samples of a run it is
compared against, whatever the hashes happen to be.
"""
from __future__ import annotations

import hashlib
import json

RUN_MASK = 0x7FFF_FFFF
GT_BIT = 0x8000_0000


def _digest(parts) -> int:
    text = json.dumps([str(p) for p in parts], separators=(",", ":"))
    return int.from_bytes(hashlib.blake2b(text.encode(), digest_size=4).digest(), "little")


def run_seed(root: int, scene: str, sampler: str, integrator: str, resolution, spp: int, rep: int) -> int:
    """Seed of one study run (top bit 0)."""
    return _digest(("run", root, scene, sampler, integrator, resolution, spp, rep)) & RUN_MASK


def gt_seed(scene_key: str, integrator: str, resolution, batch: int) -> int:
    """Seed of one ground-truth batch (top bit 1): never equal to any run seed."""
    return (_digest(("ground-truth", scene_key, integrator, resolution, batch)) & RUN_MASK) | GT_BIT


def short_hash(obj, n: int = 10) -> str:
    text = json.dumps(obj, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.blake2b(text.encode(), digest_size=16).hexdigest()[:n]
