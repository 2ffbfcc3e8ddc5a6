"""PLY files: exact round trips, both endians and small types, ragged face lists,
malformed files refused with one line naming the file and the value, atomic writes."""
import numpy as np
import pytest

from invrad_wb.core.synthetic import generate
from invrad_wb.core.io import sceneio
from invrad_wb.core.model.scene import Scene
from invrad_wb.errors import SceneError
from scene_file_helpers import (make_ply, XYZ, TRIANGLE, quad_box, rich_scene,
                                assert_same_scene, no_temp_files, trimesh)


@pytest.mark.parametrize("binary", [True, False])
def test_ply_round_trip_is_exact(tmp_path, binary):
    scene = rich_scene()
    path = tmp_path / "rooms.ply"
    sceneio.write_ply(path, scene, binary=binary)
    back = sceneio.read_scene(path)
    assert_same_scene(back, scene)
    np.testing.assert_array_equal(back.vertex_lux, scene.vertex_lux)  # NaN == NaN here
    assert back.rooms.tolist() == [0, 1]
    assert back.polygons_triangulated == 0
    np.testing.assert_array_equal(back.face_source, np.arange(len(scene.faces)))
    head = path.read_bytes()[:200]
    assert (b"binary_little_endian" in head) == binary


@pytest.mark.parametrize("binary", [True, False])
def test_ply_writes_given_lux_and_comments(tmp_path, binary):
    scene = generate.box_room(cell=1.0)
    lux = np.linspace(0.0, 1.0, len(scene.vertices)) ** 3 * 1234.5678901234567
    lux[5] = np.nan
    path = tmp_path / "render.ply"
    sceneio.write_scene(path, scene, lux=lux, binary=binary, comments=["invrad render",
                                                                       "two\nlines"])
    back = sceneio.read_scene(path)
    assert_same_scene(back, scene)
    np.testing.assert_array_equal(back.vertex_lux, lux)
    _, comments = sceneio.read_ply_elements(path)
    assert "invrad render" in comments and "two lines" in comments
    # other tools read it too
    tm = trimesh.load(str(path), process=False)
    np.testing.assert_array_equal(tm.vertices, scene.vertices)


def test_ply_face_lux_round_trip(tmp_path):
    base = generate.box_room(cell=1.5)
    face_lux = np.arange(len(base.faces), dtype=float) * 10.0
    face_lux[2] = np.nan
    scene = Scene(base.vertices, base.faces, face_lux=face_lux,
                  face_reflectance=base.face_reflectance)
    path = tmp_path / "faces.ply"
    sceneio.write_ply(path, scene)
    back = sceneio.read_scene(path)
    assert back.vertex_lux is None
    np.testing.assert_array_equal(back.face_lux, face_lux)
    assert back.target_lux([7], [[1 / 3, 1 / 3, 1 / 3]])[0] == 70.0


def test_wrong_number_of_lux_values_to_write(tmp_path):
    scene = generate.box_room(cell=1.5)
    with pytest.raises(SceneError, match=r"out\.ply.*3 lux values to write"):
        sceneio.write_ply(tmp_path / "out.ply", scene, lux=[1.0, 2.0, 3.0])


def test_big_endian_float32_and_small_types(tmp_path):
    verts, polys = quad_box()
    path = make_ply(tmp_path / "be.ply", [("x", "float"), ("y", "float"), ("z", "float"),
                                          ("lux", "float")],
                    [(*v, 10.0 * i) for i, v in enumerate(verts)],
                    [("room", "uchar"), ("reflectance", "float")],
                    [(p, 2, 0.25) for p in polys], fmt="binary_big_endian",
                    count_type="uchar", index_type="uint")
    scene = sceneio.read_scene(path)
    np.testing.assert_array_equal(scene.vertices, verts[scene.vertex_source])
    np.testing.assert_array_equal(scene.vertex_lux, 10.0 * scene.vertex_source)
    assert set(scene.face_room.tolist()) == {2}
    assert np.all(scene.face_reflectance == 0.25)


def test_mixed_polygon_binary_ply_trimesh_cannot_read(tmp_path):
    """trimesh refuses binary PLY mixing triangles and quads; our reader must not."""
    verts, polys = quad_box()
    path = make_ply(tmp_path / "mixed.ply", XYZ, [tuple(v) for v in verts], (),
                    [(p,) for p in polys], fmt="binary_little_endian")
    scene = sceneio.read_scene(path, reflectance=0.3, room=1)
    assert len(scene.faces) == 12
    assert np.all(scene.face_reflectance == 0.3) and np.all(scene.face_room == 1)


def bad_ply(tmp_path, case):
    """Write a malformed PLY; return (path, fragments its error message must contain)."""
    p = tmp_path / f"{case}.ply"
    tri = [(0, 1, 2)]
    if case == "missing":
        return str(p), ["missing.ply", "not found"]
    if case == "not_ply":
        p.write_text("solid cube\nfacet normal 0 0 1\n")
        return str(p), ["not_ply.ply", "not a PLY"]
    if case == "no_end_header":
        p.write_text("ply\nformat ascii 1.0\nelement vertex 0\n")
        return str(p), ["no_end_header.ply", "end_header"]
    if case == "missing_z":
        make_ply(p, XYZ[:2], [(0, 0), (1, 0), (0, 1)], (), [tri])
        return str(p), ["missing_z.ply", "no z"]
    if case == "two_vertex_face":
        make_ply(p, XYZ, TRIANGLE, (), [tri, ((0, 1),)])
        return str(p), ["two_vertex_face.ply", "face 1", "2 vertices"]
    if case == "index_out_of_range":
        make_ply(p, XYZ, TRIANGLE, (), [tri, ((0, 2, 9),)])
        return str(p), ["index_out_of_range.ply", "face 1", "vertex 9", "3 vertices"]
    if case == "negative_index":
        make_ply(p, XYZ, TRIANGLE, (), [((0, -1, 2),)], fmt="binary_little_endian")
        return str(p), ["negative_index.ply", "face 0", "vertex -1"]
    if case == "non_planar":
        make_ply(p, XYZ, [(0, 0, 0), (1, 0, 0), (1, 1, 0.1), (0, 1, 0)], (),
                 [((0, 1, 2, 3),)])
        return str(p), ["non_planar.ply", "face 0", "not planar", "off the polygon's plane"]
    if case == "self_intersecting":
        # a bow-tie whose lobes differ in size (so its signed area is not zero)
        make_ply(p, XYZ, [(0, 0, 0), (2, 2, 0), (2, 0, 0), (0, 1, 0)], (), [((0, 1, 2, 3),)])
        return str(p), ["self_intersecting.ply", "face 0", "cannot be triangulated"]
    if case == "pentagram":
        ang = np.pi / 2 + np.arange(5) * 4 * np.pi / 5
        make_ply(p, XYZ, [(np.cos(a), np.sin(a), 0.0) for a in ang], (),
                 [((0, 1, 2, 3, 4),)])
        return str(p), ["pentagram.ply", "face 0", "cannot be triangulated"]
    if case == "crossed_edges":
        # edge (3, 1)-(3, 4) crosses edge (4, 3)-(1, 3); ear clipping alone accepts it
        hook = [(0, 0), (4, 0), (4, 3), (1, 3), (1, 1), (3, 1), (3, 4), (0, 4)]
        make_ply(p, XYZ, [(x, y, 0.0) for x, y in hook], (), [(tuple(range(8)),)])
        return str(p), ["crossed_edges.ply", "face 0", "intersects itself"]
    if case == "zero_area_polygon":
        make_ply(p, XYZ, [(0, 0, 0), (1, 1, 0), (1, 0, 0), (0, 1, 0)], (), [((0, 1, 2, 3),)])
        return str(p), ["zero_area_polygon.ply", "face 0", "zero area"]
    if case == "nan_coordinate":
        make_ply(p, XYZ, TRIANGLE + [(0.5, "nan", 0)], (), [tri])
        return str(p), ["nan_coordinate.ply", "vertex 3", "nan"]
    if case == "negative_vertex_lux":
        make_ply(p, XYZ + [("lux", "float")], [(*v, x) for v, x in zip(TRIANGLE, (1, -5, 2))],
                 (), [tri])
        return str(p), ["negative_vertex_lux.ply", "vertex 1", "-5.0 lx", "negative"]
    if case == "infinite_face_lux":
        make_ply(p, XYZ, TRIANGLE + [(1, 1, 0)], [("lux", "double")], [(tri[0], 3.0),
                                                                      ((1, 3, 2), "inf")])
        return str(p), ["infinite_face_lux.ply", "face 1", "inf"]
    if case == "reflectance_percent":
        make_ply(p, XYZ, TRIANGLE + [(1, 1, 0)], [("reflectance", "float")],
                 [(tri[0], 0.5), ((1, 3, 2), 50.0)], fmt="binary_little_endian")
        return str(p), ["reflectance_percent.ply", "face 1", "50.0", "percentage"]
    if case == "reflectance_of_quad":
        # face numbers are the file's, not the triangles' (face 1 is a quad: 2 triangles)
        make_ply(p, XYZ, [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (2, 0, 0), (2, 1, 0)],
                 [("reflectance", "double")],
                 [((0, 1, 2, 3), 0.5), ((1, 4, 5, 2), 0.5), ((0, 1, 2), 0.4),
                  ((1, 4, 5), -0.1)])
        return str(p), ["reflectance_of_quad.ply", "face 3", "-0.1"]
    if case == "fractional_room_float":
        make_ply(p, XYZ, TRIANGLE, [("room", "float")], [(tri[0], 1.5)])
        return str(p), ["fractional_room_float.ply", "face 0", "1.5", "integer"]
    if case == "fractional_room_ascii_int":
        make_ply(p, XYZ, TRIANGLE, [("room", "int")], [(tri[0], "1.5")])
        return str(p), ["fractional_room_ascii_int.ply", "face 0", "1.5", "integer"]
    if case == "negative_room":
        make_ply(p, XYZ, TRIANGLE, [("room", "int")], [(tri[0], -2)])
        return str(p), ["negative_room.ply", "face 0", "-2"]
    if case == "truncated_binary":
        make_ply(p, XYZ, TRIANGLE, (), [tri], fmt="binary_little_endian")
        p.write_bytes(p.read_bytes()[:-5])
        return str(p), ["truncated_binary.ply", "ends early"]
    if case == "count_mismatch_ascii":
        make_ply(p, XYZ, TRIANGLE, (), [tri], vertex_count=2)
        return str(p), ["count_mismatch_ascii.ply"]
    if case == "not_a_number":
        make_ply(p, XYZ, TRIANGLE[:2] + [(0, "one", 0)], (), [tri])
        return str(p), ["not_a_number.ply", "'one'", "not a number"]
    if case in ("extra_face_binary", "extra_face_ascii"):
        # the header counts one face, the data holds two (plyfile 1.1.3 drops the second)
        make_ply(p, XYZ, TRIANGLE, (), [tri, ((0, 2, 1),)],
                 fmt="binary_little_endian" if case.endswith("binary") else "ascii")
        p.write_bytes(p.read_bytes().replace(b"element face 2", b"element face 1", 1))
        unit = "bytes" if case.endswith("binary") else "values"
        return str(p), [f"{case}.ply", f"{unit} after the last element", "counts"]
    if case == "no_faces":
        make_ply(p, XYZ, TRIANGLE, (), [])
        return str(p), ["no_faces.ply", "no faces"]
    raise AssertionError(case)


BAD_CASES = ["missing", "not_ply", "no_end_header", "missing_z", "two_vertex_face",
             "index_out_of_range", "negative_index", "non_planar", "self_intersecting",
             "pentagram", "crossed_edges", "zero_area_polygon",
             "nan_coordinate", "negative_vertex_lux", "infinite_face_lux",
             "reflectance_percent", "reflectance_of_quad", "fractional_room_float",
             "fractional_room_ascii_int", "negative_room", "truncated_binary",
             "count_mismatch_ascii", "extra_face_binary", "extra_face_ascii",
             "not_a_number", "no_faces"]


@pytest.mark.parametrize("case", BAD_CASES)
def test_bad_ply_is_refused_naming_file_and_value(tmp_path, case):
    path, fragments = bad_ply(tmp_path, case)
    with pytest.raises(SceneError) as err:
        sceneio.read_scene(path)
    msg = str(err.value)
    for frag in fragments:
        assert frag in msg, (frag, msg)


@pytest.mark.parametrize("failure", ["mid_write", "fsync", "interrupt"])
def test_failed_write_keeps_previous_file(tmp_path, monkeypatch, failure):
    path = tmp_path / "scene.ply"
    sceneio.write_ply(path, generate.box_room(cell=1.5))
    before = path.read_bytes()
    calls = []
    from invrad_wb.core.io import ply
    real_block = ply._write_block

    def failing_block(fh, records, binary):
        calls.append(1)
        if len(calls) == 2:  # vertices written, faces half written
            fh.write(records.tobytes()[: len(records.tobytes()) // 2])
            raise (KeyboardInterrupt if failure == "interrupt" else RuntimeError)("boom")
        real_block(fh, records, binary)

    def failing_fsync(fd):
        raise OSError(28, "No space left on device")

    if failure == "fsync":
        monkeypatch.setattr(ply.os, "fsync", failing_fsync)
    else:
        monkeypatch.setattr(ply, "_write_block", failing_block)
    other = rich_scene()
    with pytest.raises((RuntimeError, OSError, KeyboardInterrupt)):
        sceneio.write_ply(path, other)
    assert path.read_bytes() == before
    assert no_temp_files(tmp_path)
    monkeypatch.undo()
    sceneio.write_ply(path, other)
    assert_same_scene(sceneio.read_scene(path), other)
    assert no_temp_files(tmp_path)
