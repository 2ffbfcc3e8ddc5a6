"""Scene input/output: PLY round trips, polygons, sidecars, lux textures, units, bad input."""
import glob
import json
import os

import numpy as np
import pytest

from invrad_wb.core.synthetic import generate; from invrad_wb.core.io import sceneio
from invrad_wb.core.model.scene import Scene
from invrad_wb.errors import SceneError, SettingsError

trimesh = pytest.importorskip("trimesh")

NP_TYPES = {"char": "i1", "uchar": "u1", "short": "i2", "ushort": "u2", "int": "i4",
            "uint": "u4", "float": "f4", "double": "f8"}


# ---------------------------------------------------------------- helpers
def make_ply(path, vprops, vrows, fprops=(), frows=(), fmt="ascii", count_type="uchar",
             index_type="int", vertex_count=None, index_name="vertex_indices"):
    """Hand-write a PLY independently of the module under test.

    vprops: [(name, type)], vrows: rows of values; fprops: extra scalar face properties,
    frows: [(indices, *extra values)]. In ASCII files a str value is written verbatim.
    """
    lines = ["ply", f"format {fmt} 1.0", "comment test file"]
    lines.append(f"element vertex {len(vrows) if vertex_count is None else vertex_count}")
    lines += [f"property {t} {n}" for n, t in vprops]
    lines.append(f"element face {len(frows)}")
    lines.append(f"property list {count_type} {index_type} {index_name}")
    lines += [f"property {t} {n}" for n, t in fprops]
    lines.append("end_header")
    head = ("\n".join(lines) + "\n").encode("ascii")
    if fmt == "ascii":
        def txt(v):
            return v if isinstance(v, str) else repr(float(v)) if isinstance(v, float) \
                else str(v)
        body = [" ".join(txt(v) for v in row) for row in vrows]
        body += [" ".join([str(len(r[0]))] + [str(i) for i in r[0]] + [txt(v) for v in r[1:]])
                 for r in frows]
        data = head + ("\n".join(body) + "\n").encode("ascii")
    else:
        e = "<" if fmt == "binary_little_endian" else ">"

        def pack(v, t):
            return np.array(v, dtype=e + NP_TYPES[t]).tobytes()
        data = head
        for row in vrows:
            data += b"".join(pack(v, t) for v, (_, t) in zip(row, vprops))
        for r in frows:
            data += pack(len(r[0]), count_type) + pack(list(r[0]), index_type)
            data += b"".join(pack(v, t) for v, (_, t) in zip(r[1:], fprops))
    with open(path, "wb") as fh:
        fh.write(data)
    return str(path)


XYZ = [("x", "double"), ("y", "double"), ("z", "double")]
TRIANGLE = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)]


def quad_box(size=(4.0, 3.0, 2.5)):
    """A closed box room of 8 corners: 5 quads facing inward plus a floor of 2 triangles."""
    sx, sy, sz = size
    verts = np.array([(x * sx, y * sy, z * sz) for z in (0, 1) for y in (0, 1) for x in (0, 1)])
    centre = verts.mean(0)
    polys = [[0, 1, 3], [0, 3, 2],                       # floor as two triangles
             [4, 5, 7, 6], [0, 1, 5, 4], [2, 3, 7, 6], [0, 2, 6, 4], [1, 3, 7, 5]]
    out = []
    for p in polys:
        pts = verts[p]
        n = np.cross(pts[1] - pts[0], pts[2] - pts[0])
        out.append(p if n @ (centre - pts.mean(0)) > 0 else p[::-1])
    return verts, out


def write_image(path, pixels, fmt):
    oiio = pytest.importorskip("OpenImageIO")
    pixels = np.asarray(pixels)
    if pixels.ndim == 2:  # OIIO's write_image misreads 2-D arrays: give (h, w, 1)
        pixels = pixels[:, :, None]
    pixels = np.ascontiguousarray(pixels)
    h, w, nc = pixels.shape
    out = oiio.ImageOutput.create(str(path))
    assert out is not None, oiio.geterror()
    assert out.open(str(path), oiio.ImageSpec(w, h, nc, fmt)), out.geterror()
    assert out.write_image(pixels), out.geterror()
    out.close()
    return str(path)


def rich_scene():
    """Two rooms, varied reflectance, per-vertex targets with NaN (no target) and 0 (dark)."""
    base, _ = generate.floor_of_rooms(rooms=((3.0, 2.0), (2.0, 2.0)), cell=0.7)
    rng = np.random.default_rng(1)
    rho = rng.uniform(0.05, 0.95, len(base.faces))
    lux = rng.uniform(0, 800, len(base.vertices))
    lux[::7] = np.nan
    lux[3::11] = 0.0
    return Scene(base.vertices, base.faces, vertex_lux=lux, face_room=base.face_room,
                 face_reflectance=rho)


def assert_same_scene(a, b):
    np.testing.assert_array_equal(a.vertices, b.vertices)
    np.testing.assert_array_equal(a.faces, b.faces)
    np.testing.assert_array_equal(a.face_room, b.face_room)
    np.testing.assert_array_equal(a.face_reflectance, b.face_reflectance)


def no_temp_files(folder):
    return not glob.glob(os.path.join(str(folder), ".invrad-*"))


def bary_of(tri2d, p):
    a, b, c = tri2d
    m = np.array([b - a, c - a]).T
    s, t = np.linalg.solve(m, p - a)
    return np.array([1 - s - t, s, t])


# ---------------------------------------------------------------- PLY round trips
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


# ---------------------------------------------------------------- polygons
@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian", "binary_big_endian"])
def test_quads_are_triangulated_with_their_properties(tmp_path, fmt):
    verts, polys = quad_box()
    rho = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7]
    lux = [0.0, 10.0, 20.0, float("nan"), 40.0, 50.0, 60.0]
    path = make_ply(tmp_path / "box.ply", XYZ, [tuple(v) for v in verts],
                    [("room", "int"), ("reflectance", "double"), ("lux", "double")],
                    [(p, 3, r, x) for p, r, x in zip(polys, rho, lux)], fmt=fmt)
    scene = sceneio.read_scene(path)
    assert len(scene.faces) == 12 and scene.polygons_triangulated == 5
    src = scene.face_source
    np.testing.assert_array_equal(src, [0, 1, 2, 2, 3, 3, 4, 4, 5, 5, 6, 6])
    np.testing.assert_array_equal(scene.face_reflectance, np.array(rho)[src])
    np.testing.assert_array_equal(scene.face_lux, np.array(lux)[src])
    assert np.all(scene.face_room == 3)
    # the triangles cover each polygon exactly and keep its winding (normals inward)
    sx, sy, sz = 4.0, 3.0, 2.5
    poly_area = np.bincount(src, weights=scene.face_areas)
    np.testing.assert_allclose(poly_area, [sx * sy / 2, sx * sy / 2, sx * sy, sx * sz, sx * sz,
                                           sy * sz, sy * sz])
    inward = np.array([2.0, 1.5, 1.25]) - scene.face_centroids
    assert np.all(np.einsum("ij,ij->i", scene.face_normals, inward) > 0)
    assert len(scene.planes) == 6


def test_concave_polygon_is_ear_clipped(tmp_path):
    # L-shaped floor; starting at (2, 0) a fan would cover the missing corner
    outline = [(2, 0), (2, 1), (1, 1), (1, 2), (0, 2), (0, 0)]
    path = make_ply(tmp_path / "l.ply", XYZ, [(x, y, 0.0) for x, y in outline],
                    [("reflectance", "float")], [(list(range(6)), 0.5)])
    scene = sceneio.read_scene(path)
    assert scene.polygons_triangulated == 1 and len(scene.faces) == 4
    np.testing.assert_allclose(scene.face_areas.sum(), 3.0)
    assert np.all(scene.face_normals[:, 2] > 0.999)
    # no triangle reaches into the missing corner [1, 2] x [1, 2]
    c = scene.face_centroids
    assert not np.any((c[:, 0] > 1) & (c[:, 1] > 1))


def test_triangulate_polygons_keeps_order_and_winding():
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0], [2, 1, 0.0]])
    faces, src, n = sceneio.triangulate_polygons(v, [[1, 4, 5, 2], [0, 1, 2], [0, 1, 2, 3]])
    np.testing.assert_array_equal(src, [0, 0, 1, 2, 2])
    assert n == 2
    t = v[faces]
    nz = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])[:, 2]
    np.testing.assert_allclose(nz, 1.0)


def test_mixed_polygon_binary_ply_trimesh_cannot_read(tmp_path):
    """trimesh refuses binary PLY mixing triangles and quads; our reader must not."""
    verts, polys = quad_box()
    path = make_ply(tmp_path / "mixed.ply", XYZ, [tuple(v) for v in verts], (),
                    [(p,) for p in polys], fmt="binary_little_endian")
    scene = sceneio.read_scene(path, reflectance=0.3, room=1)
    assert len(scene.faces) == 12
    assert np.all(scene.face_reflectance == 0.3) and np.all(scene.face_room == 1)


# ---------------------------------------------------------------- sidecars
def export_obj(scene, path):
    trimesh.Trimesh(scene.vertices, scene.faces, process=False).export(str(path))
    return str(path)


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
    side.write_text("# target lux\n" + "\n".join("nan" if np.isnan(x) else repr(x)
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


# ---------------------------------------------------------------- textures
def floor_with_uv(tmp_path, name="floor.obj"):
    """A 4 m x 2 m floor with u = x / 4, v = y / 2 (glTF files are written Y-up)."""
    v = np.array([[0, 0, 0], [4, 0, 0], [4, 2, 0], [0, 2, 0.0]])
    f = np.array([[0, 1, 2], [0, 2, 3]])
    uv = v[:, :2] / [4.0, 2.0]
    if name.endswith(".glb"):
        v = np.stack([v[:, 0], v[:, 2], -v[:, 1]], axis=1)
    mesh = trimesh.Trimesh(v, f, process=False, visual=trimesh.visual.TextureVisuals(uv=uv))
    path = str(tmp_path / name)
    mesh.export(path)
    return path


@pytest.mark.parametrize("mesh_name", ["floor.obj", "floor.glb"])
def test_exr_texture_gives_target_lux_at_uv(tmp_path, mesh_name):
    w, h = 8, 4
    col, row = np.meshgrid(np.arange(w), np.arange(h))
    img = (100.0 + 10.0 * col + 3.0 * row).astype(np.float32)
    tex = write_image(tmp_path / "lux.exr", img, "float")
    scene = sceneio.read_scene(floor_with_uv(tmp_path, mesh_name), texture=tex)
    np.testing.assert_array_equal(scene.lux_texture, img)
    np.testing.assert_allclose(scene.bounds, [[0, 0, 0], [4, 2, 0]], atol=1e-6)
    rng = np.random.default_rng(3)
    # points whose u, v stay between pixel centres (bilinear = exact for this ramp)
    pts = np.stack([rng.uniform(0.5 / w, 1 - 0.5 / w, 50) * 4,
                    rng.uniform(0.5 / h, 1 - 0.5 / h, 50) * 2], axis=1)
    faces, barys = [], []
    for p in pts:
        for fi, tri in enumerate(scene.vertices[scene.faces][:, :, :2]):
            b = bary_of(tri, p)
            if np.all(b >= -1e-12):
                faces.append(fi)
                barys.append(b)
                break
    got = scene.target_lux(faces, barys)
    u, v = pts[:, 0] / 4, pts[:, 1] / 2
    expected = 100 + 10 * (u * w - 0.5) + 3 * ((1 - v) * h - 0.5)  # row 0 is v = 1
    np.testing.assert_allclose(got, expected, rtol=1e-6)  # GLB stores float32


def test_rgb_texture_uses_rec709_luminance_and_alpha_marks_no_target(tmp_path):
    # one image rule for every reader (core/io/oiio.py): alpha < 0.5 is "no target"
    img = np.zeros((2, 3, 4), np.float32)
    img[..., 0], img[..., 1], img[..., 2], img[..., 3] = 100, 200, 50, 1
    img[0, 1, 3] = 0.2
    lux = sceneio.read_lux_texture(write_image(tmp_path / "rgba.exr", img, "float"))
    expected = np.full((2, 3), 0.2126 * 100 + 0.7152 * 200 + 0.0722 * 50)
    expected[0, 1] = np.nan
    np.testing.assert_allclose(lux, expected, rtol=1e-12)


def test_8bit_texture_needs_and_uses_max_lux(tmp_path):
    png = write_image(tmp_path / "lux.png", np.array([[255, 51]], np.uint8), "uint8")
    with pytest.raises(SceneError, match=r"lux\.png.*texture_max_lux"):
        sceneio.read_lux_texture(png)
    np.testing.assert_allclose(sceneio.read_lux_texture(png, 1000.0), [[1000.0, 200.0]])
    png16 = write_image(tmp_path / "lux16.png", np.array([[65535, 0]], np.uint16), "uint16")
    np.testing.assert_allclose(sceneio.read_lux_texture(png16, 500.0), [[500.0, 0.0]])
    exr = write_image(tmp_path / "lux.exr", np.ones((1, 2), np.float32), "float")
    with pytest.raises(SceneError, match=r"lux\.exr.*holds lux already"):
        sceneio.read_lux_texture(exr, 1000.0)
    with pytest.raises(SettingsError):
        sceneio.read_lux_texture(png, -1.0)


def test_texture_on_mesh_without_uv_is_refused(tmp_path):
    obj = export_obj(generate.box_room(cell=1.5), tmp_path / "room.obj")
    tex = write_image(tmp_path / "t.exr", np.ones((2, 2), np.float32), "float")
    with pytest.raises(SceneError, match=r"room\.obj.*texture coordinates"):
        sceneio.read_scene(obj, texture=tex)


@pytest.mark.parametrize("bad, what", [(-3.0, "negative"), (np.inf, "finite")])
def test_bad_texture_pixel_named(tmp_path, bad, what):
    img = np.full((2, 3), 5.0, np.float32)
    img[1, 2] = bad
    tex = write_image(tmp_path / "bad.exr", img, "float")
    with pytest.raises(SceneError) as err:
        sceneio.read_scene(floor_with_uv(tmp_path), texture=tex)
    msg = str(err.value)
    assert "bad.exr" in msg and "x=2, y=1" in msg and str(bad) in msg
    assert ("negative" in msg) or ("infinite" in msg)


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


# ---------------------------------------------------------------- units
@pytest.mark.parametrize("unit, factor", [("mm", 1000.0), ("cm", 100.0)])
def test_unit_scaling(tmp_path, unit, factor):
    verts, polys = quad_box()
    path = make_ply(tmp_path / f"box_{unit}.ply", XYZ, [tuple(v * factor) for v in verts], (),
                    [(p,) for p in polys])
    scene = sceneio.read_scene(path, unit=unit)
    np.testing.assert_allclose(scene.vertices, verts[scene.vertex_source], rtol=1e-15)
    np.testing.assert_allclose(scene.bounds[1], [4.0, 3.0, 2.5])


def test_millimetres_without_unit_hint(tmp_path):
    verts, polys = quad_box()
    path = make_ply(tmp_path / "box_mm.ply", XYZ, [tuple(v * 1000) for v in verts], (),
                    [(p,) for p in polys])
    with pytest.raises(SceneError, match=r"box_mm\.ply.*--unit mm"):
        sceneio.read_scene(path)
    with pytest.raises(SettingsError, match="unit"):
        sceneio.read_scene(path, unit="inch")


# ---------------------------------------------------------------- bad input
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
             "count_mismatch_ascii", "not_a_number", "no_faces"]


@pytest.mark.parametrize("case", BAD_CASES)
def test_bad_ply_is_refused_naming_file_and_value(tmp_path, case):
    path, fragments = bad_ply(tmp_path, case)
    with pytest.raises(SceneError) as err:
        sceneio.read_scene(path)
    msg = str(err.value)
    for frag in fragments:
        assert frag in msg, (frag, msg)


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


def test_other_bad_inputs_name_the_file(tmp_path):
    junk = tmp_path / "junk.obj"
    junk.write_text("this is not a mesh\n")
    with pytest.raises(SceneError, match=r"junk\.obj.*no triangles"):
        sceneio.read_scene(junk)
    odd = tmp_path / "room.xyz123"
    odd.write_text("1 2 3\n")
    with pytest.raises(SceneError, match=r"room\.xyz123.*unknown mesh format"):
        sceneio.read_scene(odd)
    notimg = tmp_path / "lux.exr"
    notimg.write_text("not an image")
    with pytest.raises(SceneError, match=r"lux\.exr"):
        sceneio.read_lux_texture(notimg)
    with pytest.raises(SceneError, match=r"out\.obj.*only \.ply"):
        sceneio.write_scene(tmp_path / "out.obj", generate.box_room(cell=1.5))


def test_polygon_with_straight_corner(tmp_path):
    # corners 0-1-2 lie on a line: a fan from corner 0 would make a zero-area triangle
    path = make_ply(tmp_path / "straight.ply", XYZ,
                    [(0, 0, 0), (1, 0, 0), (2, 0, 0), (1, 1, 0)], (), [((0, 1, 2, 3),)])
    scene = sceneio.read_scene(path)
    assert len(scene.faces) == 2 and np.all(scene.face_areas > 0.49)
    np.testing.assert_allclose(scene.face_areas.sum(), 1.0)


def test_scene_errors_after_splitting_explain_triangle_numbers(tmp_path):
    # two quads sharing an edge in the same direction: the Scene names triangles
    path = make_ply(tmp_path / "winding.ply", XYZ,
                    [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (2, 0, 0), (2, 1, 0)], (),
                    [((0, 1, 2, 3),), ((1, 2, 5, 4),)])
    with pytest.raises(SceneError) as err:
        sceneio.read_scene(path)
    msg = str(err.value)
    assert msg.startswith(str(path)) and "winding" in msg and "count triangles" in msg


# ---------------------------------------------------------------- atomic writes
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
