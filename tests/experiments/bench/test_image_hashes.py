"""The refactoring check `python -m drtlab.experiments.bench.image_hashes` covers what it says: every
built-in scene, every kind that scatters, and a hash that tells images apart (renders are left to
the tool: their bit identity is tested elsewhere)."""
import numpy as np

from drtlab.experiments.bench import image_hashes as ih
from drtlab.kernels.scene_model.material_kinds import KINDS
from drtlab.kernels.scene_model.scene_file import builtin_names


def test_every_builtin_scene_and_every_scattering_kind_is_hashed():
    labels = [label for label, _ in ih._renders()]
    assert len(labels) == len(set(labels))
    first = {label.split()[0] for label in labels}
    assert set(builtin_names()) <= first
    assert {f"kind:{k.name}" for k in KINDS if not k.emitter} <= first
    assert not any(f"kind:{k.name}" in first for k in KINDS if k.emitter)
    assert sum(label.endswith(" whitted") for label in labels) == len(builtin_names()) + len(
        [k for k in KINDS if not k.emitter])


def test_the_hash_sees_one_ulp_and_not_the_memory_layout():
    img = np.linspace(0.0, 1.0, 48, dtype=np.float32).reshape(4, 4, 3)
    bumped = img.copy()
    bumped[2, 1, 0] = np.nextafter(bumped[2, 1, 0], np.float32(2.0))
    assert ih._hash(img) != ih._hash(bumped)
    assert ih._hash(img) == ih._hash(np.asfortranarray(img))
