"""`drtlab check INTEGRATOR` on integrators a user writes as plugins (docs/plugins.md), with the bugs
written the way a user writes them, in the plugin's own Warp code rather than compiled in as a
fault: the built-in path tracer copied into a plugin (as the docs say to start), its Russian
roulette hand-written without dividing the survivors by their probability, must fail
`unbiased: indirect` (the one check scene deep enough for roulette to act). A plugin is told the
scene's roulette (`api.features.roulette`) as path is; were it not, the copy would never roulette
and the check could not see the bug. Every effect a registration may claim has its scene: a
next-event-only integrator that ignores point lights passes the direct-light lines and fails its
claim to handle point lights. Level: the scorecard's 0.01, Sidak over its p-valued lines; fixed
seeds (the check's seed 0)."""
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


def test_every_effect_a_registration_may_claim_has_a_scene_showing_it():
    from drtlab.estimators.integrators import EFFECTS
    assert S.EFFECTS is EFFECTS
    shows = {"direct": "area_lights", "environment": "environment", "point_lights": "delta_lights",
             "lens": "lens", "motion": "motion", "meshes": "meshes", "indirect": "roulette"}
    for effect in EFFECTS:
        f = features_of(scene_from_dict(S.effect_scene(effect)), "path")
        assert getattr(f, shows.get(effect, "area_lights")), effect
    kinds = {e: features_of(scene_from_dict(S.effect_scene(e)), "path").kinds for e in EFFECTS}
    assert "mirror" in kinds["specular"] and "dielectric" in kinds["transmission"]


# A next-event-only integrator written from the docs: what the camera sees emitting, plus one
# area-light sample at the first hit. Unbiased for direct light from area lights; it never looks
# at point or directional lights, so a claim to handle them is false and must fail.
NEXT_EVENT_ONLY = '''
import warp as wp
import drtlab
from drtlab.kernels.device_scene import SceneData


def make(api):
    intersect, emitted, kind_of, material_at = api.intersect, api.emitted, api.kind, api.material_at
    is_delta, shading_normal, eval_bsdf = api.is_delta, api.shading_normal, api.eval_bsdf
    pick_light, sample_light, light_visible = api.pick_light, api.sample_light, api.light_visible
    get1d, get2d = api.get1d, api.get2d
    CHOICE, POSITION, EMITTER = api.dim("light_choice"), api.dim("light_position"), api.emitter

    @wp.func
    def trace(sd: SceneData, seed: wp.uint32, pix: wp.uint32, idx: wp.uint32, spp: wp.uint32,
              o: wp.vec3, d: wp.vec3, dt: float) -> wp.vec3:
        h = intersect(sd, o, d, 1.0e30, dt)
        if h.index < 0:
            return sd.background
        wo = -d
        L = wp.vec3(0.0)
        if h.light >= 0:
            L += emitted(sd, h, wo)
        kind = kind_of(sd, h.material)
        if kind == wp.static(EMITTER) or is_delta(kind) or sd.lights.n_area == 0:
            return L
        mat = material_at(sd, h.material, h.uv)
        li = pick_light(sd, h.p, get1d(seed, pix, idx, CHOICE(0), spp))
        ls = sample_light(sd, li, h.p, get2d(seed, pix, idx, POSITION(0), spp), 0, dt)
        if ls.valid == 1 and ls.pdf > 0.0:
            if light_visible(sd, h, li, ls, dt) == 1:
                L += wp.cw_mul(eval_bsdf(mat, shading_normal(h), wo, ls.wi), ls.radiance) / ls.pdf
        return L

    return trace


drtlab.register_integrator("next-event-only", make, "one light sample", unbiased=True,
                           handles=("direct", "point_lights"))
'''


def test_a_false_claim_to_handle_point_lights_fails_its_scene(tmp_path, clean_registry):
    path = tmp_path / "next_event_only.py"
    path.write_text(NEXT_EVENT_ONLY)
    plugins.load_plugin(path)
    v = {x.name: x.passed for x in check("next-event-only").lines}
    assert v["unbiased: direct"] and v["white furnace"] and v["convergence"], v
    assert v["unbiased: point_lights"] is False, v
