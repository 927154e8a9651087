"""`drtlab check INTEGRATOR` on integrators a user writes as plugins (docs/plugins.md), with the bugs
written the way a user writes them, in the plugin's own Warp code rather than compiled in as a
fault: the built-in path tracer copied into a plugin (as the docs say to start), its Russian
roulette hand-written without dividing the survivors by their probability, must fail
`unbiased: indirect` (the one check scene deep enough for roulette to act). A plugin is told the
scene's roulette (`api.features.roulette`) as path is; were it not, the copy would never roulette
and the check could not see the bug. Level: the scorecard's 0.01, Sidak over its p-valued lines;
fixed seeds (the check's seed 0)."""
from drtlab.estimators import plugins
from drtlab.experiments.checks import integrator_scenes as S
from drtlab.experiments.checks.integrator import check
from drtlab.kernels.features import ROULETTE_FREE, features_of
from drtlab.kernels.scene_model.scene_file import scene_from_dict

from repo_paths import REPO

ROULETTE = """                    beta = roulette(beta, get1d(seed, pix, idx, ROULETTE(depth), spp))
                    if beta[0] == 0.0 and beta[1] == 0.0 and beta[2] == 0.0:
                        break
"""
# The user's roulette: kills with probability 1 - q, and forgets to divide the survivor by q.
NO_REWEIGHT = """                    q = wp.min(wp.max(beta[0], wp.max(beta[1], beta[2])), 0.95)
                    if get1d(seed, pix, idx, ROULETTE(depth), spp) >= q:
                        break
"""
REGISTER = """

import drtlab

drtlab.register_integrator("{name}", make, "a copy of path", unbiased=True,
                           handles=("direct", "indirect"))
"""


def _path_copy(tmp_path, name: str, roulette: str):
    src = (REPO / "kernels" / "integrators" / "path.py").read_text()
    assert ROULETTE in src
    path = tmp_path / f"{name.replace('-', '_')}.py"
    path.write_text(src.replace(ROULETTE, roulette) + REGISTER.format(name=name))
    plugins.load_plugin(path)
    return name


def test_a_plugin_integrator_is_told_the_scenes_roulette(tmp_path, clean_registry):
    name = _path_copy(tmp_path, "my-path", ROULETTE)
    scene = scene_from_dict(S.effect_scene("indirect"))
    assert scene.russian_roulette
    assert features_of(scene, name).roulette and features_of(scene, "path").roulette
    assert not any(features_of(scene, i).roulette for i in ROULETTE_FREE)


def test_a_users_roulette_without_reweighting_fails_the_check(tmp_path, clean_registry):
    name = _path_copy(tmp_path, "rr-no-reweight", NO_REWEIGHT)
    card = check(name)
    v = {x.name: x.passed for x in card.lines}
    assert not card.passed and v["unbiased: indirect"] is False, "\n".join(card.text())
    # what roulette does not reach still holds: the direct light (depth 2), determinism, finite values
    assert v["unbiased: direct"] and v["threads and tiles"] and v["hard cases"]
