"""The front, read_scene/write_scene: units, and inputs no format reader accepts."""
import numpy as np
import pytest

from invrad_wb.core.synthetic import generate
from invrad_wb.core.io import sceneio
from invrad_wb.errors import SceneError, SettingsError
from scene_file_helpers import make_ply, XYZ, quad_box


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
