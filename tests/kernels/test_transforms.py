"""Shape transforms (kernels/scene_model/transforms.py, the `transform` table of SCENE_FORMAT.md): composition
order, what each shape kind accepts, bad input (one InputError naming the field), and the
cornell-box boxes written as transformed boxes. No renders: the cornell-box rewrite was checked to
give bit-identical images (the uploaded float32 quads are identical)."""
from __future__ import annotations

import copy
import math

import numpy as np
import pytest

from drtlab.errors import InputError
from drtlab.kernels.intersection.quad_records import quad_groups
from drtlab.kernels.scene_model.scene_file import load_scene, scene_from_dict
from drtlab.kernels.scene_model.transforms import apply_transform, compose, mirrors, rotation, transform_vectors

NAN = float("nan")


def scene_with(*shapes) -> dict:
    return {"scene": {"description": "t", "resolution": [8, 6], "spp": 1},
            "camera": {"position": [0, 1, 8], "look_at": [0, 1, 0]},
            "materials": {"m": {"kind": "diffuse"}, "lamp": {"kind": "emitter", "emission": [1, 1, 1]}},
            "shapes": list(shapes)}


SPHERE = {"kind": "sphere", "material": "m", "center": [1, 0, 0], "radius": 0.5}
QUAD = {"kind": "quad", "material": "lamp", "origin": [0, 2, 0], "edge_u": [1, 0, 0],
        "edge_v": [0, 0, 1]}                                                      # normal -y
BOX = {"kind": "box", "material": "m", "name": "b", "min": [-1, 0, -1], "max": [1, 2, 1]}


def shapes_of(shape: dict, transform: dict) -> list:
    return scene_from_dict(scene_with({**shape, "transform": transform})).shapes


def normal(q) -> np.ndarray:
    n = np.cross(q.edge_u, q.edge_v)
    return n / np.linalg.norm(n)


def test_composition_is_scale_then_rotate_then_translate():
    m = compose(2.0, [((0, 0, 1), 90.0)], (1.0, 1.0, 1.0))
    np.testing.assert_allclose(apply_transform(m, [1.0, 0.0, 0.0]), [1.0, 3.0, 1.0], atol=1e-12)
    # Right-handed: +x about +z by 90 degrees goes to +y; rotations apply in the order listed.
    np.testing.assert_allclose(apply_transform(rotation((0, 0, 5), 90.0), [1, 0, 0]), [0, 1, 0],
                               atol=1e-12)
    xy = compose(rotations=[((1, 0, 0), 90.0), ((0, 1, 0), 90.0)])
    np.testing.assert_allclose(xy, rotation((0, 1, 0), 90.0) @ rotation((1, 0, 0), 90.0))
    assert not np.allclose(xy, compose(rotations=[((0, 1, 0), 90.0), ((1, 0, 0), 90.0)]))
    # The table spells the same composition, and `matrix` alone gives it directly.
    m = compose(2.0, [((1, 0, 0), 90.0), ((0, 1, 0), 90.0)], (1, 2, 3))
    t = {"scale": 2.0, "rotate": [{"axis": [1, 0, 0], "degrees": 90}, {"axis": [0, 1, 0], "degrees": 90}],
         "translate": [1, 2, 3]}
    a = shapes_of(SPHERE, t)[0]
    b = shapes_of(SPHERE, {"matrix": m.tolist()})[0]
    np.testing.assert_allclose(a.center, apply_transform(m, [1, 0, 0]), atol=1e-12)
    np.testing.assert_allclose(a.center, b.center, atol=1e-12)
    assert a.radius == b.radius == pytest.approx(1.0)


def test_sphere_accepts_similarities_only():
    s = shapes_of(SPHERE, {"scale": -3.0, "rotate": {"axis": [0, 1, 1], "degrees": 33}})[0]
    assert s.radius == pytest.approx(1.5)
    np.testing.assert_allclose(np.linalg.norm(s.center), 3.0)
    for transform, field in [({"scale": [1, 2, 1]}, "shapes[0].transform.scale"),
                             ({"matrix": [[1, 0.5, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]},
                              "shapes[0].transform.matrix")]:
        with pytest.raises(InputError) as err:
            shapes_of(SPHERE, transform)
        assert err.value.field == field and "ellipsoid" in err.value.message
        assert "\n" not in str(err.value)


def test_quad_keeps_its_lit_side_under_mirrors_and_shear():
    for transform in ({"scale": [-1, 1, 1]}, {"scale": [1, -2, 1]},
                      {"matrix": [[1, 0.3, 0, 0], [0, 1, 0, 0], [0.2, 0, -1, 1], [0, 0, 0, 1]]}):
        q = shapes_of(QUAD, transform)[0]
        spelled = transform.get("matrix")
        m = np.array(spelled, float) if spelled else compose(transform["scale"])
        # The lit side is the inverse transpose of the original normal (-y).
        _, n = apply_transform(m, [0, 0, 0], np.array([[0.0, -1.0, 0.0]]))
        np.testing.assert_allclose(normal(q), n[0], atol=1e-12)
        assert mirrors(m) == (np.linalg.det(m[:3, :3]) < 0)
        corners = {tuple(np.round(q.origin + a * q.edge_u + b * q.edge_v, 9)) for a in (0, 1)
                   for b in (0, 1)}
        expected = {tuple(np.round(apply_transform(m, np.array([x, 2.0, z])), 9)) for x in (0, 1)
                    for z in (0, 1)}
        assert corners == expected


@pytest.mark.parametrize("transform", [{"rotate": {"axis": [1, 2, 3], "degrees": 25}, "translate": [3, 0, 0]},
                                       {"scale": [-1, 0.5, 2], "rotate": {"axis": [0, 1, 0], "degrees": 60}},
                                       {"matrix": [[1, 0.2, 0, 0], [0, 1, 0, 0], [0, 0.4, 1, 0], [0, 0, 0, 1]]}])
def test_transformed_box_is_six_outward_faces_detected_as_one_box(transform):
    faces = shapes_of({**BOX, "velocity": [1, 2, 3]}, transform)
    assert [f.name for f in faces] == ["b.px", "b.nx", "b.py", "b.ny", "b.pz", "b.nz"]
    middle = np.mean([f.origin + 0.5 * (f.edge_u + f.edge_v) for f in faces], axis=0)
    for f in faces:
        assert np.dot(normal(f), f.origin + 0.5 * (f.edge_u + f.edge_v) - middle) > 0
        np.testing.assert_array_equal(f.velocity, [1, 2, 3])        # velocity stays world-space
    groups = quad_groups(faces, 0.0)
    assert groups.quad == [-1] and sorted(groups.faces) == list(range(6))


def test_normals_map_by_the_inverse_transpose():
    m = compose([1.0, 3.0, 0.5], [((1, 1, 0), 40.0)], (0, 1, 0))
    tangents = np.array([[1.0, 0, 0], [0, 1.0, 1.0]])
    n0 = np.cross(*tangents)
    _, n = apply_transform(m, np.zeros(3), n0[None])
    t = transform_vectors(m, tangents)
    np.testing.assert_allclose(t @ n[0], 0.0, atol=1e-12)
    assert np.linalg.norm(n[0]) == pytest.approx(1.0)


BAD = [
    ("not a table", [1, 2], "shapes[0].transform", ["table"]),
    ("unknown key", {"shift": [1, 0, 0]}, "shapes[0].transform.shift", ["allowed keys", "translate"]),
    ("matrix with translate", {"matrix": np.eye(4).tolist(), "translate": [1, 0, 0]},
     "shapes[0].transform.matrix", ["matrix alone", "translate"]),
    ("singular matrix", {"matrix": [[1, 0, 0, 0], [0, 0, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]},
     "shapes[0].transform.matrix", ["singular", "invertible"]),
    ("projective matrix", {"matrix": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 1, 1]]},
     "shapes[0].transform.matrix[3]", ["[0, 0, 0, 1]"]),
    ("matrix of 3 rows", {"matrix": [[1, 0, 0, 0]] * 3}, "shapes[0].transform.matrix", ["4 rows"]),
    ("NaN in matrix", {"matrix": [[1, 0, 0, 0], [0, NAN, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]},
     "shapes[0].transform.matrix[1]", ["finite"]),
    ("NaN translate", {"translate": [0, NAN, 0]}, "shapes[0].transform.translate", ["finite"]),
    ("NaN degrees", {"rotate": {"axis": [0, 1, 0], "degrees": NAN}}, "shapes[0].transform.rotate.degrees",
     ["finite"]),
    ("zero scale", {"scale": [1, 0, 1]}, "shapes[0].transform.scale", ["non-zero"]),
    ("zero axis", {"rotate": {"axis": [0, 0, 0], "degrees": 10}}, "shapes[0].transform.rotate.axis",
     ["non-zero"]),
    ("missing degrees", {"rotate": [{"axis": [0, 1, 0]}]}, "shapes[0].transform.rotate[0].degrees",
     ["required"]),
    ("rotate not a table", {"rotate": 30}, "shapes[0].transform.rotate", ["axis", "degrees"]),
    # Beyond float32 tracing (fields.SCENE_LIMIT): refused at the value, before it overflows the shape.
    ("overflowing scale", {"scale": 1e300, "translate": [1e300, 0, 0],
                           "rotate": {"axis": [1, 1, 0], "degrees": 45}}, "shapes[0].transform.scale",
     ["magnitude at most 1e+15"]),
]


@pytest.mark.parametrize("transform,field,fragments", [c[1:] for c in BAD], ids=[c[0] for c in BAD])
def test_bad_transform_raises_one_input_error(transform, field, fragments):
    with pytest.raises(InputError) as err:
        shapes_of(QUAD, transform)
    assert err.value.field == field, err.value
    for fragment in fragments:
        assert fragment in err.value.message, (fragment, err.value.message)


# ---------------------------------------------------------------------------------------------------
# cornell-box: Mitsuba's cubes as boxes with Mitsuba's to_world
# ---------------------------------------------------------------------------------------------------

# Two of the 9-decimal quads cornell-box.toml listed before it used transforms (computed then from
# Mitsuba's to_world of the cube faces).
HAND_WRITTEN = {
    "small-box.px": ([0.709602938, -1.0, 0.180820085], [0.0, 0.6, 0.0], [-0.175423023, 0.0, 0.573782854]),
    "large-box.py": ([-0.70885888, 0.21, -0.470960596], [0.187898284, 0.0, 0.569819476],
                     [0.569819476, 0.0, -0.187898284]),
}


def test_cornell_boxes_are_mitsubas_transformed_cubes():
    scene = load_scene("cornell-box")
    by_name = {s.name: s for s in scene.shapes}
    for name, (o, u, v) in HAND_WRITTEN.items():
        q = by_name[name]
        for got, want in ((q.origin, o), (q.edge_u, u), (q.edge_v, v)):
            np.testing.assert_allclose(got, want, atol=1e-6)
    # Every face's corners are Mitsuba's to_world (T R S) of the cube [-1, 1]^3's corners.
    for box, (s, deg, t) in {"small-box": (0.3, -17.0, [0.335, -0.7, 0.38]),
                             "large-box": ([0.3, 0.61, 0.3], 18.25, [-0.33, -0.4, -0.28])}.items():
        c, sn = math.cos(math.radians(deg)), math.sin(math.radians(deg))
        r = np.array([[c, 0, sn], [0, 1, 0], [-sn, 0, c]])
        cube = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
        world = {tuple(np.round(r @ (np.broadcast_to(s, 3) * p) + t, 9)) for p in cube}
        faces = [f for f in scene.shapes if f.name.startswith(box + ".")]
        corners = {tuple(np.round(f.origin + a * f.edge_u + b * f.edge_v, 9)) for f in faces
                   for a in (0, 1) for b in (0, 1)}
        assert corners == world
    # The ray tests still see a light, the open room and the two boxes as groups.
    groups = quad_groups(scene.shapes, 0.0)
    assert groups.quad == [0, -1, -1, -1]


def test_transform_does_not_touch_the_input_dict():
    d = scene_with({**BOX, "transform": {"scale": 2.0}})
    before = copy.deepcopy(d)
    scene_from_dict(d)
    assert d == before
