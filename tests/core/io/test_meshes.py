"""Meshes trimesh reads (OBJ, glTF) with lux sidecars (JSON, CSV) next to them."""
import json

import numpy as np
import pytest

from invrad_wb.core.synthetic import generate
from invrad_wb.core.io import sceneio
from invrad_wb.errors import SceneError
from scene_file_helpers import make_ply, XYZ, TRIANGLE, export_obj, trimesh


def test_json_sidecar_per_vertex_with_obj(tmp_path):
    scene = generate.box_room(cell=1.0)
    obj = export_obj(scene, tmp_path / "room.obj")
    v = scene.vertices
    lux = 100 * v[:, 0] + 10 * v[:, 1]
    lux[v[:, 2] > 2.9] = np.nan  # no target on the ceiling
    doc = {"vertex_lux": [None if np.isnan(x) else float(x) for x in lux],
           "face_reflectance": 0.7, "comment": "test"}
    (tmp_path / "room.lux.json").write_text(json.dumps(doc))
    back = sceneio.read_scene(obj)  # the sidecar next to the mesh is found by itself
    np.testing.assert_allclose(back.vertices, v, atol=1e-8)  # OBJ keeps 8 decimals
    expected = 100 * back.vertices[:, 0] + 10 * back.vertices[:, 1]
    expected[back.vertices[:, 2] > 2.9] = np.nan
    np.testing.assert_allclose(back.vertex_lux, expected, atol=1e-5)
    assert np.all(back.face_reflectance == 0.7)


def test_json_sidecar_per_face_with_rooms(tmp_path):
    scene = generate.box_room(cell=1.5)
    obj = export_obj(scene, tmp_path / "room.obj")
    m = len(scene.faces)
    side = tmp_path / "targets.json"
    side.write_text(json.dumps({"face_lux": [float(i) for i in range(m)],
                                "face_room": [4] * m,
                                "face_reflectance": [0.2 + 0.5 * (i % 2) for i in range(m)]}))
    back = sceneio.read_scene(obj, lux=side)
    np.testing.assert_array_equal(back.face_lux, np.arange(m))
    assert back.rooms.tolist() == [4]
    np.testing.assert_allclose(back.face_reflectance, 0.2 + 0.5 * (np.arange(m) % 2))
    np.testing.assert_array_equal(back.faces, scene.faces)


@pytest.mark.parametrize("per", ["vertex", "face"])
def test_csv_sidecar(tmp_path, per):
    scene = generate.box_room(cell=1.5)
    obj = export_obj(scene, tmp_path / "room.obj")
    n = len(scene.vertices) if per == "vertex" else len(scene.faces)
    vals = np.arange(n) * 2.5
    vals[1] = np.nan
    side = tmp_path / "lux.csv"
    side.write_text("# target lux\n" + "\n".join("nan" if np.isnan(x) else repr(float(x))
                                                  for x in vals) + "\n\n")
    back = sceneio.read_scene(obj, lux=side)
    got = back.vertex_lux if per == "vertex" else back.face_lux
    other = back.face_lux if per == "vertex" else back.vertex_lux
    np.testing.assert_array_equal(got, vals)
    assert other is None


def test_sidecar_count_must_match(tmp_path):
    scene = generate.box_room(cell=1.5)
    obj = export_obj(scene, tmp_path / "room.obj")
    side = tmp_path / "short.txt"
    side.write_text("1\n2\n3\n")
    with pytest.raises(SceneError) as err:
        sceneio.read_scene(obj, lux=side)
    msg = str(err.value)
    assert "short.txt" in msg and "3 values" in msg and "room.obj" in msg
    assert f"{len(scene.vertices)} vertices" in msg and f"{len(scene.faces)} faces" in msg


def test_sidecar_ambiguous_when_as_many_vertices_as_faces(tmp_path):
    # a tetrahedral room has 4 vertices and 4 faces
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    f = np.array([[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]])
    obj = str(tmp_path / "tet.obj")
    trimesh.Trimesh(v, f, process=False).export(obj)
    (tmp_path / "tet.lux.csv").write_text("1\n2\n3\n4\n")
    with pytest.raises(SceneError, match=r"tet\.lux\.csv.*unclear"):
        sceneio.read_scene(obj)
    (tmp_path / "tet.lux.csv").unlink()
    (tmp_path / "tet.lux.json").write_text('{"face_lux": [1, 2, 3, 4]}')
    np.testing.assert_array_equal(sceneio.read_scene(obj).face_lux, [1, 2, 3, 4])


def test_obj_keeps_unreferenced_vertices_for_vertex_sidecar(tmp_path):
    """trimesh drops unreferenced OBJ vertices unless asked to keep the order."""
    obj = tmp_path / "t.obj"
    obj.write_text("v 0 0 0\nv 9 9 9\nv 1 0 0\nv 0 1 0\nf 1 3 4\n")
    (tmp_path / "t.lux.json").write_text('{"vertex_lux": [1, 99, 2, 3]}')
    scene = sceneio.read_scene(obj)
    got = scene.vertex_lux[scene.faces[0]]
    np.testing.assert_array_equal(got, [1, 2, 3])


def test_multi_material_obj_refuses_ordered_sidecar(tmp_path):
    """trimesh splits an OBJ by material and reorders faces: per-face values can't match."""
    obj = tmp_path / "two.obj"
    obj.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                   "usemtl a\nf 1 2 3\nusemtl b\nf 1 3 4\n")
    assert len(sceneio.read_scene(obj).faces) == 2  # fine without per-face values
    (tmp_path / "two.lux.csv").write_text("10\n20\n")
    with pytest.raises(SceneError, match=r"two\.obj.*2 separate meshes"):
        sceneio.read_scene(obj)


def test_gltf_is_turned_to_z_up(tmp_path):
    scene = generate.box_room(cell=1.0)
    v = scene.vertices
    y_up = np.stack([v[:, 0], v[:, 2], -v[:, 1]], axis=1)
    path = str(tmp_path / "room.glb")
    trimesh.Trimesh(y_up, scene.faces, process=False).export(path)
    back = sceneio.read_scene(path)
    np.testing.assert_allclose(back.vertices, v, atol=1e-6)  # GLB stores float32
    floor = back.face_centroids[:, 2] < 1e-6
    np.testing.assert_allclose(back.face_normals[floor], [[0, 0, 1]] * floor.sum(), atol=1e-6)


@pytest.mark.parametrize("name, text, fragments", [
    ("bad_value.json", '{"vertex_lux": [1, 2, "x"]}', ["vertex_lux[2]", "'x'"]),
    ("typo.json", '{"vertex_Lux": [1, 2, 3]}', ["vertex_Lux", "allowed"]),
    ("both.json", '{"vertex_lux": [1, 2, 3], "face_lux": [1]}', ["exactly one"]),
    ("broken.json", '{"vertex_lux": [1, 2,', ["not valid JSON"]),
    ("negative.json", '{"vertex_lux": [1, -2, 3]}', ["vertex 1", "-2.0 lx"]),
    ("room.json", '{"face_lux": [1], "face_room": [0.5]}', ["face 0", "0.5"]),
    ("bad_line.csv", "1\n2\nabc\n", ["line 3", "abc"]),
    ("two_columns.csv", "1,2\n", ["line 1", "1,2"]),
])
def test_bad_sidecar_is_refused_naming_file(tmp_path, name, text, fragments):
    path = make_ply(tmp_path / "tri.ply", XYZ, TRIANGLE, (), [((0, 1, 2),)])
    side = tmp_path / name
    side.write_text(text)
    with pytest.raises(SceneError) as err:
        sceneio.read_scene(path, lux=side)
    msg = str(err.value)
    assert name in msg, msg
    for frag in fragments:
        assert frag in msg, (frag, msg)
