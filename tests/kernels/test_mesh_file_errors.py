"""Mesh-file index errors name the file, the line, the face and the index as the user wrote it
(issue 20: `f 0 1 2` came out as a degenerate triangle, an index past the vertices as numpy's
0-based message without a face number)."""
from __future__ import annotations

import pytest

from drtlab.errors import InputError
from drtlab.kernels.scene_model.scene_file import scene_from_dict

from mesh_util import mesh
from scene_pieces import camera_dict, scene_dict

HEAD = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n# a comment\nf 1 2 3\n"


def _error(tmp_path, name: str, text: str) -> InputError:
    path = tmp_path / name
    path.write_text(text)
    scene = scene_dict("bad obj", camera_dict((0, 0, 5), (0, 0, 0), 40.0), {"m": {"kind": "diffuse"}},
                       [mesh("m", file=str(path))])
    with pytest.raises(InputError) as exc:
        scene_from_dict(scene)
    return exc.value


@pytest.mark.parametrize("face,words", [
    ("f 0 1 2", ["line 7", "face 2", "index 0 is not an OBJ index"]),
    ("f 1 2 9", ["line 7", "face 2", "vertex index 9 is out of range: 4 vertices in the file (1 ... 4 or -1 ... -4)"]),
    ("f 1 2 -5", ["line 7", "face 2", "vertex index -5", "defined before this line"]),
    ("f 1//3 2//1 3//1", ["line 7", "face 2", "normal index 3", "0 normals in the file"]),
    ("f 1 x 3", ["line 7", "face 2", "'x' is not an integer"]),
])
def test_obj_index_errors_name_file_line_face_and_index(face, words, tmp_path):
    e = _error(tmp_path, "bad.obj", HEAD + face + "\n")
    assert e.field == "shapes[0].file"
    assert "bad.obj" in e.message and "\n" not in e.message
    for w in words:
        assert w in e.message, e.message


def test_valid_relative_and_slashed_indices_load(tmp_path):
    path = tmp_path / "ok.obj"
    path.write_text(HEAD + "vn 0 0 1\nvt 0 0\nf -4 -3 -1\nf 1/1/1 2/1/1 4/1/1\nf 2//1 3//1 4//1\n")
    scene = scene_from_dict(scene_dict("ok", camera_dict((0, 0, 5), (0, 0, 0), 40.0),
                                       {"m": {"kind": "diffuse"}}, [mesh("m", file=str(path))]))
    assert scene.shapes[0].mesh.faces.tolist() == [[0, 1, 2], [0, 1, 3], [0, 1, 3], [1, 2, 3]]


def test_ply_index_past_the_vertices_names_the_triangle(tmp_path):
    e = _error(tmp_path, "bad.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
               "property float y\nproperty float z\nelement face 2\n"
               "property list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n"
               "3 0 1 2\n3 0 1 7\n")
    assert "triangle 2" in e.message and "[0, 1, 7] (counting from 0)" in e.message, e.message
    assert "3 vertices" in e.message
