"""Scene model: planes, vertex splitting, winding, and clear errors on bad input."""
import numpy as np
import pytest

from invrad_wb.core.synthetic import generate as g
from invrad_wb.core.model.scene import Scene, winding_number
from invrad_wb.errors import SceneError


def test_box_planes_face_into_room():
    s = g.box_room((6, 4, 3), cell=0.5)
    assert len(s.planes) == 6
    centre = np.array([3.0, 2.0, 1.5])
    for p in s.planes:
        assert p.signed_distance(centre[None])[0] > 0  # the room is in front of every plane
    assert sum(p.area for p in s.planes) == pytest.approx(2 * (24 + 18 + 12))


def test_corner_vertices_are_split_per_plane():
    s = g.box_room((2, 2, 2), cell=1.0)
    # a corner vertex is shared by 3 planes: after splitting each vertex has one plane
    for vi in range(len(s.vertices)):
        faces = np.flatnonzero((s.faces == vi).any(axis=1))
        assert len(set(s.face_plane[faces])) == 1
    assert np.allclose(np.linalg.norm(s.vertex_normals, axis=1), 1.0)


def test_winding_number_inside_outside():
    s = g.box_room((2, 2, 2), cell=1.0)
    w = winding_number(s.triangles, np.array([[1, 1, 1], [5, 5, 5]], float))
    assert w[0] == pytest.approx(-1.0, abs=1e-9)  # inward faces: -1 inside
    assert w[1] == pytest.approx(0.0, abs=1e-9)


def test_outward_room_is_refused():
    s = g.box_room((3, 3, 3), cell=1.0)
    with pytest.raises(SceneError, match="point out of the room"):
        Scene(s.vertices, s.faces[:, ::-1])


def test_single_flipped_face_is_refused():
    s = g.box_room((3, 3, 3), cell=1.0)
    f = s.faces.copy()
    f[5] = f[5][::-1]
    with pytest.raises(SceneError, match="inconsistent winding: faces .*5"):
        Scene(s.vertices, f)


@pytest.mark.parametrize("bad,msg", [
    (dict(vertex_lux="nan_coord"), "non-finite coordinate"),
    (dict(vertex_lux=-5.0), "cannot be negative"),
    (dict(vertex_lux=np.inf), "must be finite"),
    (dict(face_reflectance=50.0), "reflectance of face 0 is 50"),
    (dict(face_room=-1), "room id of face 0"),
])
def test_bad_values_name_the_item(bad, msg):
    s = g.box_room((3, 3, 3), cell=1.0)
    v = s.vertices.copy()
    kw = {}
    if bad.get("vertex_lux") == "nan_coord":
        v[0, 1] = np.nan
    elif "vertex_lux" in bad:
        lux = np.full(len(v), 100.0)
        lux[0] = bad["vertex_lux"]
        kw["vertex_lux"] = lux
    if "face_reflectance" in bad:
        rho = np.full(len(s.faces), 0.5)
        rho[0] = bad["face_reflectance"]
        kw["face_reflectance"] = rho
    if "face_room" in bad:
        r = np.zeros(len(s.faces))
        r[0] = bad["face_room"]
        kw["face_room"] = r
    with pytest.raises(SceneError, match=msg):
        Scene(v, s.faces, source="room.ply", **kw)


def test_millimetre_scene_is_refused_with_hint():
    s = g.box_room((6, 4, 3), cell=2.0)
    with pytest.raises(SceneError, match="millimetres.*--unit mm"):
        Scene(s.vertices * 1000, s.faces)


def test_degenerate_and_out_of_range_faces():
    v = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 1, 0]], float)
    with pytest.raises(SceneError, match="face 0 .* degenerate"):
        Scene(v, [[0, 1, 2], [0, 1, 3]], check_winding=False)
    with pytest.raises(SceneError, match="face 1 refers to vertex"):
        Scene(v, [[0, 1, 3], [0, 1, 9]], check_winding=False)
    with pytest.raises(SceneError, match="triangles"):
        Scene(v, [[0, 1, 2, 3]], check_winding=False)


def test_target_interpolation_and_nan():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
    s = Scene(v, [[0, 1, 2]], vertex_lux=[100, 200, 300], check_winding=False)
    val = s.target_lux([0], [[1 / 3, 1 / 3, 1 / 3]])
    assert val[0] == pytest.approx(200)
    s2 = Scene(v, [[0, 1, 2]], vertex_lux=[100, np.nan, 300], check_winding=False)
    assert np.isnan(s2.target_lux([0], [[0.5, 0.25, 0.25]])[0])


def test_room_subset_keeps_geometry():
    s, _ = g.floor_of_rooms(((3, 3), (4, 3)), cell=1.0)
    r1 = s.room_subset(1)
    assert set(r1.rooms.tolist()) == {1}
    assert r1.bounds[0][0] >= 3.0
    assert np.all(s.face_room[r1.face_source] == 1)
