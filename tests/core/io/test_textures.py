"""UV illuminance textures read through the one image reader (core/io/oiio.py)."""
import sys

import numpy as np
import pytest

from invrad_wb.core.synthetic import generate
from invrad_wb.core.io import sceneio
from invrad_wb.errors import InvradError, SceneError, SettingsError
from scene_file_helpers import write_image, bary_of, export_obj, floor_with_uv


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


def test_every_image_reader_gives_the_same_pixels(tmp_path):
    # the report's read-back and the lux reader share core/io/oiio.read_pixels
    from invrad_wb.core.output import images
    from invrad_wb.core.model.targets import load_lux_image
    img = np.array([[0.0, 1.5], [250.0, 7.25]], np.float32)
    exr = write_image(tmp_path / "grey.exr", img, "float")
    np.testing.assert_array_equal(images.read_image(exr)[..., 0], img)
    np.testing.assert_array_equal(load_lux_image(exr), img)
    np.testing.assert_array_equal(sceneio.read_lux_texture(exr), img)


def test_missing_openimageio_is_one_clear_error(tmp_path, monkeypatch):
    exr = write_image(tmp_path / "lux.exr", np.ones((2, 2), np.float32), "float")
    monkeypatch.setitem(sys.modules, "OpenImageIO", None)  # import now fails
    with pytest.raises(InvradError, match=r"reading images needs OpenImageIO \(pip install"):
        sceneio.read_lux_texture(exr)
