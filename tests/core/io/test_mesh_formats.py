"""Every mesh format the command line accepts is read with what the set-up installs.

trimesh decodes text (ASCII STL, OBJ, OFF, a binary STL's 80-byte header) as UTF-8 and,
when that fails, guesses the encoding with charset_normalizer: a module trimesh does not
require, which the set-up once lacked ("No module named 'charset_normalizer'" on an STL
whose header a CAD program filled with Latin-1). Each format here is read end to end."""
import json

import numpy as np
import pytest

from invrad_wb.core.io import sceneio
from invrad_wb.core.synthetic import generate
from scene_file_helpers import trimesh


def _room():
    return generate.box_room((4, 3, 2.5), cell=1.25)


def _write(scene, path, kind):
    mesh = trimesh.Trimesh(scene.vertices, scene.faces, process=False)
    if kind == "stl-latin1":
        data = bytearray(mesh.export(file_type="stl"))
        data[:80] = "Pièce 1 — façade, exporté".encode("latin-1", "replace").ljust(80, b" ")
        path.write_bytes(bytes(data))
    elif kind == "stl-ascii":
        path.write_text(mesh.export(file_type="stl_ascii"))
    elif kind == "obj-latin1":
        text = mesh.export(file_type="obj")
        path.write_bytes("# pièce éclairée\n".encode("latin-1") + text.encode("ascii"))
    else:
        mesh.export(str(path))
    return path


@pytest.mark.parametrize("name,kind", [
    ("room.stl", "stl"), ("header.stl", "stl-latin1"), ("ascii.stl", "stl-ascii"),
    ("room.obj", "obj"), ("latin1.obj", "obj-latin1"), ("room.off", "off"),
    ("room.glb", "glb"), ("room.ply", "ply")])
def test_each_mesh_format_reads_with_a_sidecar(tmp_path, name, kind):
    scene = _room()
    path = _write(scene, tmp_path / name, kind)
    side = tmp_path / "targets.json"
    side.write_text(json.dumps({"face_lux": [300.0] * len(scene.faces)}))
    back = sceneio.read_scene(path, lux=side)
    assert len(back.faces) == len(scene.faces)
    lo, hi = back.bounds
    if kind == "glb":           # glTF is Y-up: the reader turns it back to Z-up
        np.testing.assert_allclose(sorted(hi - lo), sorted([4, 3, 2.5]), atol=1e-6)
    else:
        np.testing.assert_allclose(hi - lo, [4, 3, 2.5], atol=1e-6)
    np.testing.assert_array_equal(back.face_lux, 300.0)


def test_charset_normalizer_is_installed():
    """The set-up installs it (requirements.txt): trimesh imports it only on a non-UTF-8
    file, so nothing else would notice it missing."""
    import charset_normalizer
    assert charset_normalizer.detect("façade".encode("latin-1") * 20)["encoding"]
