"""A fake renderer with a known error law, for testing the experiment machinery without Warp.

`fake_backend()` renders truth + Gaussian noise of standard deviation `sigma * spp ** -beta`, with
beta = 0.75 for the stratified point set and 0.5 otherwise, so convergence slopes are known exactly
(-0.5 and -0.75). Images are a pure function of (scene, spp, sampler, seed, resolution), and the
reported render time is a deterministic function of the work, so whole sweeps are reproducible to
the byte.
"""
from __future__ import annotations

import hashlib
from dataclasses import dataclass, field

import numpy as np

from drtlab.experiments.study.backend import Backend, RenderResult
from drtlab.errors import InputError

FAKE_SCENES = ("aa-edges", "soft-shadows", "glossy", "translucency", "dof", "motion-blur",
               "cornell-box", "veach-mis", "drt-showcase", "tiny")


@dataclass
class FakeScene:
    name: str
    width: int = 16
    height: int = 12
    integrator: str = "drt"
    text: str = ""

    def content_hash(self) -> str:
        return hashlib.sha256(self.text.encode()).hexdigest()[:16]


@dataclass
class FakeRenderer:
    sigma: float = 0.2
    versions: dict = field(default_factory=dict)     # scene name -> version string (changes hash)
    calls: int = 0
    fail_after: int | None = None                    # raise KeyboardInterrupt on call N+1
    log: list = field(default_factory=list)

    def load_scene(self, name, overrides=None):
        if name not in FAKE_SCENES:
            raise InputError("scene", f"unknown scene '{name}'; built-in: {', '.join(FAKE_SCENES)}")
        text = f"{name}|{self.versions.get(name, 'v1')}|{sorted((overrides or {}).items())}"
        return FakeScene(name=name, text=text)

    @staticmethod
    def truth(name: str, w: int, h: int) -> np.ndarray:
        k = int(hashlib.blake2b(name.encode(), digest_size=2).hexdigest(), 16) % 7
        y, x = np.mgrid[0:h, 0:w]
        base = 0.25 + 0.5 * ((x + k) * 3 > (y * 4 + w // 2))      # an edge
        ramp = 0.2 * x / max(w - 1, 1)
        img = np.stack([base + ramp, base * 0.8 + 0.1, 0.3 + ramp * (k + 1) / 8], axis=-1)
        return img.astype(np.float64)

    def render(self, scene, *, spp, sampler, integrator, seed, res, threads=None):
        if self.fail_after is not None and self.calls >= self.fail_after:
            raise KeyboardInterrupt("fake renderer: simulated kill")
        self.calls += 1
        name = scene.name if hasattr(scene, "name") else str(scene)
        w, h = res if res else (16, 12)
        beta = 0.75 if sampler.startswith("stratified") else 0.5
        rng = np.random.default_rng(seed)
        img = self.truth(name, w, h) + self.sigma * spp ** -beta * rng.standard_normal((h, w, 3))
        self.log.append((name, sampler, spp, seed))
        return RenderResult(image=img, render_seconds=1e-7 * spp * w * h + 1e-4,
                            compile_seconds=0.0, samples_per_second=0.0)

    def backend(self) -> Backend:
        return Backend(load_scene=self.load_scene, render=self.render, code_version="fake-1",
                       name="fake")


def fake_backend(**kw) -> tuple[Backend, FakeRenderer]:
    r = FakeRenderer(**kw)
    return r.backend(), r


def tiny_real_experiment(description: str, scenes: list[str]) -> str:
    """A TOML experiment small enough for the real renderer in a test: 16x12 pixels, spp 1 and 4,
    2 repetitions, 256-spp references in 64-spp batches, `uniform` against `stratified`."""
    return (f'[experiment]\ndescription = "{description}"\nseed = 5\nspp = [1, 4]\n'
            f'repetitions = 2\nresolution = [16, 12]\ngt_spp = 256\ngt_batch_spp = 64\n\n'
            f'[[study]]\nname = "real"\nscenes = {scenes!r}\n'
            f'samplers = ["uniform", "stratified"]\n').replace("'", '"')

