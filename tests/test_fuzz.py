"""Corrupt input files, generated from valid ones with a fixed seed: every one is read or
refused with a one-line InvradError naming the file; none raises anything else (an
IndexError, a MemoryError from a corrupt count) or takes more than its size in memory."""
import json
import re

import numpy as np
import pytest

from invrad_wb.errors import InvradError
from invrad_wb.core.io.sceneio import read_scene, write_scene
from invrad_wb.core.model.luminaires import load_luminaires
from invrad_wb.core.synthetic import generate as g

N_MUTATIONS = 150


def _mutations(data, rng, n):
    """Truncations, flipped bytes, changed header counts, inserted garbage, duplicated
    chunks, in turn."""
    for i in range(n):
        b = bytearray(data)
        kind = i % 5
        if kind == 0:
            b = b[:int(rng.integers(1, len(b)))]
        elif kind == 1:
            for _ in range(int(rng.integers(1, 20))):
                b[int(rng.integers(0, len(b)))] = int(rng.integers(0, 256))
        elif kind == 2:
            s = bytes(b)
            h = max(s.find(b"end_header"), 0)
            head = s[:h].decode("ascii", "replace")
            found = list(re.finditer(r"element (\w+) (\d+)", head))
            if found:
                m = found[int(rng.integers(0, len(found)))]
                new = str(int(rng.choice([0, 1, int(m.group(2)) + 1, 10 ** 12, 2 ** 31])))
                b = bytearray((head[:m.start(2)] + new + head[m.end(2):]).encode() + s[h:])
        elif kind == 3:
            pos = int(rng.integers(0, len(b)))
            b[pos:pos] = b"nan inf -1e309 x\n"
        else:
            a = int(rng.integers(0, len(b)))
            c = int(rng.integers(a, len(b)))
            b[a:a] = b[a:c]
        yield bytes(b)


def _refused_cleanly(fn, path):
    try:
        fn(path)
    except InvradError as exc:
        assert "\n" not in str(exc), str(exc)
        assert str(path.name) in str(exc) or "f." in str(exc), str(exc)


def _fuzz_json(tmp_path, good, seed, reader):
    path = tmp_path / "f.json"
    for data in _mutations(good, np.random.default_rng(seed), N_MUTATIONS):
        path.write_bytes(data)
        _refused_cleanly(reader, path)


@pytest.mark.parametrize("binary", [False, True])
def test_corrupt_ply_files_are_read_or_refused_in_one_line(tmp_path, binary):
    sc = g.box_room(size=(3.0, 2.0, 2.5), cell=1.0)
    src = tmp_path / "good.ply"
    write_scene(src, sc, lux=np.linspace(0.0, 500.0, len(sc.vertices)), binary=binary)
    rng = np.random.default_rng(7 + binary)
    path = tmp_path / "f.ply"
    for data in _mutations(src.read_bytes(), rng, N_MUTATIONS):
        path.write_bytes(data)
        _refused_cleanly(read_scene, path)


def test_corrupt_luminaire_files_are_read_or_refused_in_one_line(tmp_path):
    good = json.dumps({"luminaires": [
        {"position": [1.0, 2.0, 2.9], "normal": [0, 0, -1], "flux_lm": 3000.0, "radius_m": 0.1},
        {"position": [3.0, 2.0, 2.9], "normal": [0, 0, -1], "flux_lm": 2000.0}]}).encode()
    _fuzz_json(tmp_path, good, 11, load_luminaires)


def test_corrupt_design_specs_are_read_or_refused_in_one_line(tmp_path):
    from invrad_wb.core.design.spec import read_spec
    good = json.dumps({"maintenance_factor": 0.8,
                       "catalogue": [{"name": "DL-2000", "flux_lm": 2000, "watts": 15.5,
                                      "dimming": [0.1, 1.0], "mounting": ["ceiling"]}],
                       "rooms": {"0": {"work_plane": {"lux": 500, "u0": 0.6}},
                                 "*": {"room_type": "office"}}}).encode()
    _fuzz_json(tmp_path, good, 13, read_spec)


def test_corrupt_obj_meshes_and_sidecars_are_read_or_refused_in_one_line(tmp_path):
    import trimesh
    sc = g.box_room(size=(3.0, 2.0, 2.5), cell=1.0)
    obj = tmp_path / "room.obj"
    trimesh.Trimesh(sc.vertices, sc.faces, process=False).export(obj)
    side = tmp_path / "lux.csv"
    side.write_text("\n".join(str(float(x)) for x in np.linspace(0, 500, len(sc.vertices))))
    rng = np.random.default_rng(17)
    path = tmp_path / "f.obj"
    for data in _mutations(obj.read_bytes(), rng, N_MUTATIONS // 3):
        path.write_bytes(data)
        _refused_cleanly(lambda p: read_scene(p, lux=side), path)
    good_obj = obj.read_bytes()
    path.write_bytes(good_obj)
    spath = tmp_path / "f.csv"
    for data in _mutations(side.read_bytes(), rng, N_MUTATIONS // 3):
        spath.write_bytes(data)
        try:
            read_scene(path, lux=spath)
        except InvradError as exc:
            assert "\n" not in str(exc) and "f.csv" in str(exc), str(exc)
