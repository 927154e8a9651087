"""The kernel-variant cache: one compiled kernel per (features, point set, strategy, device), built by
the kernel factory once per process (one lock per variant: different variants compile at once) and
loaded from Warp's disk cache when it has it; the splatting gather kernel per filter."""
from __future__ import annotations

import os
import threading
import time

from drtlab.estimators.integrators import integrator_fingerprint
from drtlab.estimators.registry import SamplerSpec, parse_sampler
from drtlab.kernels.features import Features
from drtlab.warp_runtime import warp as _wp

_lock = threading.Lock()
_kernels: dict = {}
_compiling: dict = {}        # variant key -> the lock its one compile holds
# Building a variant's Warp functions (the kernel factory) registers them in their Python module's
# Warp module: one factory at a time, or two variants can pick up each other's closures.
_factory_lock = threading.Lock()


def _after_fork_in_child() -> None:
    # A forked child inherits the pools but not their worker threads (and maybe a held lock).
    global _lock, _factory_lock
    _lock = threading.Lock()
    _factory_lock = threading.Lock()
    _compiling.clear()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_after_fork_in_child)


def variant_key(features: Features, spec: SamplerSpec, device: str) -> tuple:
    """What tells two compiled kernels apart (features as Features.code_key() gives them; a plugin's
    point set and a plugin's integrator by their fingerprints too, so an edited one recompiles; a
    strategy by all its fields)."""
    return (features, spec.pointset.name, spec.pointset.fingerprint, spec.strategy,
            integrator_fingerprint(features.integrator), device)


def get_kernel(features: Features, spec: SamplerSpec, device: str):
    """The compiled kernel for (features, sampler); compiled once per process, cached on disk."""
    if features.whitted:
        # Whitted reads no sampler: one variant serves every sampler name.
        spec = parse_sampler("uniform")
    features = features.code_key()

    def build():
        from drtlab.kernels.render_kernel import build_kernel
        return build_kernel(features, spec.pointset, spec.strategy)

    return _compiled_once(variant_key(features, spec, device), build, device)


def _compiled_once(key, build, device: str):
    """(kernel, compile seconds) of `key`, built by `build()` and loaded once per process (0.0
    seconds when it was already): one lock per key, so a kernel compiles once and different ones
    at once (Warp runs its codegen under its own lock and the native compile, mostly, unlocked)."""
    wp = _wp()
    with _lock:
        entry = _kernels.get(key)
        if entry is not None:
            return entry[0], 0.0
        variant_lock = _compiling.setdefault(key, threading.Lock())
    with variant_lock:
        with _lock:
            entry = _kernels.get(key)
        if entry is not None:
            return entry[0], 0.0
        with _factory_lock:
            kernel = build()
        t0 = time.perf_counter()
        wp.load_module(kernel.module, device=device)
        entry = (kernel, time.perf_counter() - t0)
        with _lock:
            _kernels[key] = entry
        return entry


def get_gather(features: Features, device: str):
    """The splatting gather kernel of `features.filter` (kernels/splat.py); one per filter (its stddev
    and whether it is cut at the film's edge)."""
    def build():
        from drtlab.kernels.splat import make_gather
        return make_gather(features)

    return _compiled_once(("gather", features.filter, features.filter_stddev, features.filter_clip, device),
                          build, device)
