"""Target specifications -> per-vertex lux (invrad_wb.core.model.targets), without FreeCAD."""
import math

import numpy as np
import pytest

from invrad_wb.core.model import targets as T
from invrad_wb.core.synthetic.generate import box_room, sloped_room
from invrad_wb.core.model.luminaires import Luminaire
from invrad_wb.core.model.scene import Scene
from invrad_wb.errors import InvradError, SceneError


@pytest.fixture
def room():
    """A 4 x 3 x 2.7 m box; surfaces are its planes (vertices are split per plane)."""
    s = box_room((4.0, 3.0, 2.7), cell=0.25)
    return s.vertices, s.faces, s.face_plane, s


def surface_facing(scene, normal):
    n = np.asarray(normal, float)
    return next(p.index for p in scene.planes if p.normal @ n > 0.99)


def test_uniform_target_stays_on_its_surface(room):
    v, f, ts, scene = room
    floor = surface_facing(scene, [0, 0, 1])
    lux = T.evaluate(v, f, ts, [T.UniformTarget([floor], 500.0)])
    on_floor = scene.vertex_plane == floor
    assert np.all(lux[on_floor] == 500.0)
    assert np.all(np.isnan(lux[~on_floor]))     # corners shared with walls do not leak


def test_later_uniform_replaces_earlier(room):
    v, f, ts, scene = room
    floor = surface_facing(scene, [0, 0, 1])
    lux = T.evaluate(v, f, ts, [T.UniformTarget([floor], 500.0), T.UniformTarget([floor], 0.0)])
    assert np.all(lux[scene.vertex_plane == floor] == 0.0)


def test_shared_vertices_are_refused_and_split_fixes_it():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    f = np.array([[0, 1, 2], [0, 3, 1]])
    ts = np.array([0, 1])
    with pytest.raises(SceneError, match="shared by"):
        T.evaluate(v, f, ts, [T.UniformTarget([0], 100.0)])
    v2, f2, src = T.split_surfaces(v, f, ts)
    assert len(v2) == 6 and np.allclose(v2[f2], v[f])
    lux = T.evaluate(v2, f2, ts, [T.UniformTarget([0], 100.0)])
    assert np.nansum(lux) == 300.0


@pytest.mark.parametrize("falloff, at_half, at_rim", [
    ("cosine", 0.5, 0.0),
    ("gaussian", math.exp(-0.5 * 1.5 ** 2), math.exp(-4.5)),
    ("flat", 1.0, 1.0),
])
def test_spot_falloff_profiles(falloff, at_half, at_rim):
    x = np.array([0.0, 0.5, 1.0, 1.0001])
    w = T.falloff_weight(x, falloff)
    assert w[0] == pytest.approx(1.0)
    assert w[1] == pytest.approx(at_half)
    assert w[2] == pytest.approx(at_rim, abs=1e-12)
    assert w[3] == 0.0


def test_spot_on_floor(room):
    v, f, ts, scene = room
    floor = surface_facing(scene, [0, 0, 1])
    spot = T.SpotTarget(floor, centre=[2.0, 1.5, 0.0], radius_m=1.0, peak_lux=800.0)
    lux = T.evaluate(v, f, ts, [spot])
    d = np.linalg.norm(v - [2.0, 1.5, 0.0], axis=1)
    on = (scene.vertex_plane == floor) & (d <= 1.0)
    assert np.allclose(lux[on], 800.0 * 0.5 * (1 + np.cos(np.pi * d[on])))
    assert np.all(np.isnan(lux[~on]))
    centre = np.argmin(np.where(scene.vertex_plane == floor, d, np.inf))
    assert lux[centre] == pytest.approx(800.0 * 0.5 * (1 + np.cos(np.pi * d[centre])))


def test_spot_over_uniform_takes_the_maximum(room):
    v, f, ts, scene = room
    floor = surface_facing(scene, [0, 0, 1])
    lux = T.evaluate(v, f, ts, [T.UniformTarget([floor], 100.0),
                                T.SpotTarget(floor, [2.0, 1.5, 0.0], 1.0, 800.0)])
    on_floor = scene.vertex_plane == floor
    assert np.nanmin(lux[on_floor]) == 100.0
    assert np.nanmax(lux[on_floor]) > 700.0


def test_spot_spills_only_onto_listed_surfaces(room):
    v, f, ts, scene = room
    floor = surface_facing(scene, [0, 0, 1])
    wall = surface_facing(scene, [1, 0, 0])        # the wall at x = 0
    spot = T.SpotTarget(floor, [0.2, 1.5, 0.0], 1.0, 500.0)
    lux = T.evaluate(v, f, ts, [spot])
    assert np.all(np.isnan(lux[scene.vertex_plane == wall]))
    spot.surfaces = [floor, wall]
    lux = T.evaluate(v, f, ts, [spot])
    assert np.nanmax(lux[scene.vertex_plane == wall]) > 100.0


def test_shade_wins_and_shade_disk(room):
    v, f, ts, scene = room
    floor = surface_facing(scene, [0, 0, 1])
    wall = surface_facing(scene, [1, 0, 0])
    lux = T.evaluate(v, f, ts, [T.ShadeTarget([wall]), T.UniformTarget([wall, floor], 300.0),
                                T.ShadeTarget([floor], centre=[1.0, 1.0, 0.0], radius_m=0.5)])
    assert np.all(lux[scene.vertex_plane == wall] == 0.0)
    on_floor = scene.vertex_plane == floor
    d = np.linalg.norm(v - [1.0, 1.0, 0.0], axis=1)
    assert np.all(lux[on_floor & (d <= 0.5)] == 0.0)
    assert np.all(lux[on_floor & (d > 0.5)] == 300.0)


def write_image(path, pixels):
    import OpenImageIO as oiio
    pixels = np.ascontiguousarray(pixels, dtype=np.float32)
    if pixels.ndim == 2:
        pixels = pixels[..., None]
    h, w, c = pixels.shape
    out = oiio.ImageOutput.create(str(path))
    assert out is not None, oiio.geterror()
    fmt = oiio.FLOAT if str(path).endswith(".exr") else oiio.UINT8
    spec = oiio.ImageSpec(w, h, c, fmt)
    if c == 4:
        spec.alpha_channel = 3
    assert out.open(str(path), spec)
    assert out.write_image(pixels)
    out.close()


def test_texture_on_floor_is_a_plan_view(room, tmp_path):
    v, f, ts, scene = room
    floor = surface_facing(scene, [0, 0, 1])
    img = np.zeros((2, 2))
    img[0, :] = 400.0       # top row: +Y half of the floor
    img[1, :] = 100.0
    img[:, 1] += 50.0       # right column: +X half
    path = tmp_path / "floor.exr"
    write_image(path, img)
    lux = T.evaluate(v, f, ts, [T.TextureTarget(floor, str(path), lux_scale=2.0)])
    on = scene.vertex_plane == floor
    corner = lambda x, y: np.flatnonzero(on & np.all(np.isclose(v, [x, y, 0.0]), axis=1))[0]
    assert lux[corner(0.0, 0.0)] == pytest.approx(200.0)
    assert lux[corner(4.0, 0.0)] == pytest.approx(300.0)
    assert lux[corner(0.0, 3.0)] == pytest.approx(800.0)
    assert lux[corner(4.0, 3.0)] == pytest.approx(900.0)
    assert np.all(np.isnan(lux[~on]))


def test_texture_on_wall_reads_left_to_right_top_down(room, tmp_path):
    v, f, ts, scene = room
    wall = surface_facing(scene, [0, 1, 0])        # the wall at y = 0, seen from inside
    img = np.array([[10.0, 20.0], [30.0, 40.0]])   # top-left, top-right / bottom-left, -right
    path = tmp_path / "wall.exr"
    write_image(path, img)
    lux = T.evaluate(v, f, ts, [T.TextureTarget(wall, str(path))])
    on = scene.vertex_plane == wall
    at = lambda x, z: lux[np.flatnonzero(on & np.all(np.isclose(v, [x, 0.0, z]), axis=1))[0]]
    # facing the wall y = 0 from inside (looking towards -Y), +X is on the left
    assert at(4.0, 2.7) == pytest.approx(10.0)
    assert at(0.0, 2.7) == pytest.approx(20.0)
    assert at(4.0, 0.0) == pytest.approx(30.0)
    assert at(0.0, 0.0) == pytest.approx(40.0)


def test_texture_8bit_colour_with_alpha(room, tmp_path):
    v, f, ts, scene = room
    floor = surface_facing(scene, [0, 0, 1])
    img = np.ones((4, 4, 4))
    img[..., 3] = 1.0
    img[:, :2, 3] = 0.0          # left half transparent: no target
    path = tmp_path / "floor.png"
    write_image(path, img)
    lux = T.evaluate(v, f, ts, [T.UniformTarget([floor], 7.0),
                                T.TextureTarget(floor, str(path), lux_scale=500.0)])
    on = scene.vertex_plane == floor
    right = on & (v[:, 0] > 2.5)
    left = on & (v[:, 0] < 1.5)
    assert np.allclose(lux[right], 500.0)
    assert np.all(lux[left] == 7.0)              # transparent pixels keep what was there


def test_texture_from_array_and_relative_path(room, tmp_path):
    v, f, ts, scene = room
    floor = surface_facing(scene, [0, 0, 1])
    lux = T.evaluate(v, f, ts, [T.TextureTarget(floor, np.full((3, 5), 42.0))])
    assert np.allclose(lux[scene.vertex_plane == floor], 42.0)
    write_image(tmp_path / "rel.exr", np.full((2, 2), 5.0))
    lux = T.evaluate(v, f, ts, [T.TextureTarget(floor, "rel.exr")], base_dir=str(tmp_path))
    assert np.allclose(lux[scene.vertex_plane == floor], 5.0)


@pytest.mark.parametrize("target, message", [
    (T.UniformTarget([99], 100.0, name="desk"), r"desk: surface 99 does not exist"),
    (T.UniformTarget([0], float("nan"), name="desk"), r"desk: lux is nan lx"),
    (T.UniformTarget([0], -5.0, name="desk"), r"cannot be negative"),
    (T.UniformTarget([0], "bright", name="desk"), r"must be a number of lux"),
    (T.SpotTarget(0, [1, 1, 0], 0.0, 100.0, name="sp"), r"sp: radius is 0.0 m"),
    (T.SpotTarget(0, [1, 1, 0], 1.0, 100.0, falloff="linear", name="sp"), r"unknown falloff"),
    (T.SpotTarget(0, [1, float("inf"), 0], 1.0, 100.0, name="sp"), r"three finite coordinates"),
    (T.ShadeTarget([0], centre=[1, 1, 0], name="sh"), r"needs both a centre and a radius"),
    (T.TextureTarget(0, "/nonexistent/lux.exr", name="tex"), r"tex: illuminance image"
                                                              r" /nonexistent/lux.exr does not"),
    (T.TextureTarget(0, np.array([[1.0, -2.0]]), name="tex"), r"negative or infinite"),
])
def test_bad_targets_give_clear_errors(room, target, message):
    v, f, ts, scene = room
    with pytest.raises(SceneError, match=message) as info:
        T.evaluate(v, f, ts, [target], source="Office")
    assert str(info.value).startswith("Office: ")
    assert isinstance(info.value, InvradError)


def test_surface_labels_in_messages(room):
    v, f, ts, scene = room
    with pytest.raises(SceneError, match=r"Face12 does not exist; the room has 6 surfaces"
                                         r" \(Face1 .. Face6\)"):
        T.evaluate(v, f, ts, [T.UniformTarget([11], 1.0)], label=lambda i: f"Face{i + 1}")


def floor_mask(scene):
    return scene.face_normals[:, 2] > 0.9


def test_work_plane_is_the_floor_lifted(room):
    v, f, ts, scene = room
    wv, wt, wl = T.work_plane(v, f, floor_mask(scene), T.WorkPlaneTarget(300.0))
    assert np.allclose(wv[:, 2], 0.75)
    p = wv[wt]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    assert np.all(n[:, 2] > 0)                         # faces up
    assert 0.5 * np.linalg.norm(n, axis=1).sum() == pytest.approx(12.0)
    assert np.all(wl == 300.0)


def test_work_plane_margin(room):
    v, f, ts, scene = room
    wv, wt, wl = T.work_plane(v, f, floor_mask(scene), T.WorkPlaneTarget(300.0, margin_m=0.5))
    inner = ((wv[:, 0] > 0.5 + 1e-9) & (wv[:, 0] < 3.5 - 1e-9)
             & (wv[:, 1] > 0.5 + 1e-9) & (wv[:, 1] < 2.5 - 1e-9))
    assert np.all(wl[inner] == 300.0)
    assert np.all(np.isnan(wl[~inner & ((wv[:, 0] < 0.49) | (wv[:, 1] < 0.49))]))


def test_work_plane_is_clipped_by_a_low_sloped_ceiling():
    s = sloped_room(size=(6.0, 4.0), low=0.5, high=3.5, cell=0.25)
    wv, wt, wl = T.work_plane(s.vertices, s.faces, floor_mask(s), T.WorkPlaneTarget(200.0))
    # ceiling height 0.5 + 0.5 x: the plane at 0.75 m starts at x = 0.5 m
    assert wv[:, 0].min() > 0.25
    assert wv[:, 0].max() == pytest.approx(6.0)


def test_work_plane_inside_test_on_a_coarse_surface():
    fine = sloped_room(size=(6.0, 4.0), low=0.5, high=3.5, cell=0.25)
    coarse = sloped_room(size=(6.0, 4.0), low=0.5, high=3.5, cell=10.0)
    target = T.WorkPlaneTarget(200.0)
    a = T.work_plane(fine.vertices, fine.faces, floor_mask(fine), target)
    b = T.work_plane(fine.vertices, fine.faces, floor_mask(fine), target,
                     surface=(coarse.vertices, coarse.faces))
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)


@pytest.mark.parametrize("kw, message", [
    (dict(lux=300.0, height_m=3.0), r"not below the ceiling"),
    (dict(lux=float("nan")), r"lux is nan"),
    (dict(lux=300.0, height_m=-1.0), r"height is -1.0 m"),
    (dict(lux=300.0, margin_m=5.0), r"leaves no work plane"),
])
def test_work_plane_errors(room, kw, message):
    v, f, ts, scene = room
    with pytest.raises(SceneError, match=message):
        T.work_plane(v, f, floor_mask(scene), T.WorkPlaneTarget(**kw), source="Office")


def test_work_plane_needs_a_floor(room):
    v, f, ts, scene = room
    with pytest.raises(SceneError, match="no floor"):
        T.work_plane(v, f, np.zeros(len(f), bool), T.WorkPlaneTarget(300.0))


def test_work_plane_receives_light_through_a_virtual_scene(room):
    """The work plane joins the scene as virtual faces and receives the analytic direct light."""
    v, f, ts, scene = room
    wv, wt, wl = T.work_plane(v, f, floor_mask(scene), T.WorkPlaneTarget(300.0))
    verts = np.concatenate([v, wv])
    faces = np.concatenate([f, wt + len(v)])
    virtual = np.r_[np.zeros(len(f), bool), np.ones(len(wt), bool)]
    lux = np.r_[np.full(len(v), np.nan), wl]
    sc = Scene(verts, faces, vertex_lux=lux, face_virtual=virtual)
    from invrad_wb.core.forward.render import render
    lum = Luminaire([2.0, 1.5, 2.7], [0, 0, -1], 1000.0)
    got = render(sc, [lum], interreflection=False, backend="numpy")
    on_wp = sc.face_virtual[np.repeat(np.arange(len(sc.faces)), 3)]
    wp_vertices = np.unique(sc.faces[sc.face_virtual].reshape(-1))
    p = sc.vertices[wp_vertices]
    d = lum.position - p
    r2 = np.einsum("ij,ij->i", d, d)
    cos = d[:, 2] / np.sqrt(r2)
    expected = 1000.0 * cos * cos / (math.pi * r2)
    assert np.allclose(got[wp_vertices], expected, rtol=1e-6)
    assert on_wp.any()
