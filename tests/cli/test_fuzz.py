"""Corrupt input files, generated from valid ones with a fixed seed: every one is read or
refused with a one-line InvradError naming the file; none raises anything else (an
IndexError, a MemoryError from a corrupt count) or takes more than its size in memory.

Readers: PLY (ASCII, binary), OBJ + CSV sidecar, LUMS.json, design specs, locate settings
files (``locate --settings`` and ``freecad --settings``), illuminance textures (PNG, EXR
through OpenImageIO, with their declared image sizes changed) and IFC files as the
``freecad`` command reads them before FreeCAD starts. Each loop has a fixed seed and stops
after ``N_MUTATIONS`` inputs or ``SECONDS`` (whichever comes first), so CI time is bounded.
"""
import json
import re
import struct
import time
import zlib

import numpy as np
import pytest

from invrad_wb.errors import InvradError
from invrad_wb.core.io.sceneio import read_scene, write_scene
from invrad_wb.core.model.luminaires import load_luminaires
from invrad_wb.core.synthetic import generate as g

N_MUTATIONS = 150
#: time bound of one loop (seconds); the seeds make the first inputs the same every run
SECONDS = 40.0


def _bounded(inputs, seconds=SECONDS):
    """The inputs until ``seconds`` have passed (at least one)."""
    t0 = time.monotonic()
    for x in inputs:
        yield x
        if time.monotonic() - t0 > seconds:
            return


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
    for data in _bounded(_mutations(good, np.random.default_rng(seed), N_MUTATIONS)):
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


# --------------------------------------------------------------------------- settings
GOOD_SETTINGS = json.dumps({"vote_model": "exact", "pixel_m": 0.1, "votes_per_m2": 400.0,
                            "threshold": 24, "dummy_planes": True, "dummy_count": 4,
                            "refine": True, "optimiser": "lm",
                            "neighbourhood_m": 0.3}).encode()


def test_corrupt_locate_settings_files_are_read_or_refused_in_one_line(tmp_path):
    from invrad_wb import cli
    from invrad_wb.cli.locate import _settings_from_args

    def read(path):
        args = cli.build_parser().parse_args(["locate", "s.ply", "--flux", "3000", "-o",
                                              "r.json", "--settings", str(path)])
        return _settings_from_args(args)
    read_good = tmp_path / "good.json"
    read_good.write_bytes(GOOD_SETTINGS)
    assert read(read_good).threshold == 24
    _fuzz_json(tmp_path, GOOD_SETTINGS, 19, read)


def test_corrupt_freecad_settings_files_are_read_or_refused_in_one_line(tmp_path):
    freecad_cli = pytest.importorskip("invrad_wb.cli.freecad_cmd")
    good = tmp_path / "good.json"
    good.write_bytes(GOOD_SETTINGS)
    assert freecad_cli.read_settings_file(good)["threshold"] == 24
    _fuzz_json(tmp_path, GOOD_SETTINGS, 23, freecad_cli.read_settings_file)


# --------------------------------------------------------------------------- textures
def _write_image(path, pixels, fmt):
    import OpenImageIO as oiio
    pixels = np.ascontiguousarray(pixels, dtype=np.float32)
    h, w, c = pixels.shape
    out = oiio.ImageOutput.create(str(path))
    assert out is not None, oiio.geterror()
    assert out.open(str(path), oiio.ImageSpec(w, h, c, fmt))
    assert out.write_image(pixels)
    out.close()


def _png_sizes(data, rng):
    """The PNG with other declared sizes in IHDR (CRC fixed half of the time)."""
    b = bytearray(data)
    i = data.find(b"IHDR")
    if i < 0 or len(b) < i + 17:
        return bytes(b)
    w, h = (int(rng.choice([0, 1, 7, 20000, 65535, 2 ** 31 - 1, 2 ** 32 - 1]))
            for _ in range(2))
    b[i + 4:i + 12] = struct.pack(">II", w, h)
    if rng.random() < 0.5:
        b[i + 17:i + 21] = struct.pack(">I", zlib.crc32(bytes(b[i:i + 17])) & 0xFFFFFFFF)
    return bytes(b)


def _exr_sizes(data, rng):
    """The EXR with another dataWindow (and displayWindow) in its header."""
    b = bytearray(data)
    for name in (b"dataWindow\0box2i\0", b"displayWindow\0box2i\0"):
        i = data.find(name)
        if i >= 0 and rng.random() < 0.8:
            j = i + len(name) + 4          # after the attribute's size
            box = [int(rng.choice([-2 ** 31, -1, 0, 1, 15, 20000, 2 ** 31 - 1]))
                   for _ in range(4)]
            b[j:j + 16] = struct.pack("<4i", *box)
    return bytes(b)


@pytest.mark.parametrize("kind", ["png", "exr"])
def test_corrupt_textures_are_read_or_refused_in_one_line(tmp_path, monkeypatch, kind):
    oiio = pytest.importorskip("OpenImageIO")
    from invrad_wb.core.io.textures import read_lux_texture
    from invrad_wb.core.model import memory
    # a header may declare 2^31 x 2^31 pixels: the budget refuses it; never allocate GBs
    monkeypatch.setenv(memory.ENV, "512M")
    rng = np.random.default_rng(29 if kind == "png" else 31)
    pixels = rng.uniform(0.0, 1.0, (12, 16, 3))
    good = tmp_path / f"good.{kind}"
    _write_image(good, pixels * (1.0 if kind == "png" else 500.0),
                 oiio.UINT8 if kind == "png" else oiio.HALF)
    max_lux = 500.0 if kind == "png" else None
    assert read_lux_texture(good, max_lux).shape == (12, 16)
    data = good.read_bytes()
    sizes = _png_sizes if kind == "png" else _exr_sizes

    def inputs():
        for k, d in enumerate(_mutations(data, rng, N_MUTATIONS)):
            yield sizes(data, rng) if k % 5 == 2 else d   # kind 2: the declared sizes
    path = tmp_path / f"f.{kind}"
    read = 0
    for d in _bounded(inputs()):
        path.write_bytes(d)
        try:
            lux = read_lux_texture(path, max_lux)
        except InvradError as exc:
            assert "\n" not in str(exc) and f"f.{kind}" in str(exc), str(exc)
        else:
            read += 1
            assert lux.ndim == 2 and lux.size <= 2 ** 26
            assert not np.any(np.isinf(lux)) and not np.any(lux < 0)
    assert read > 0            # some mutations leave a readable image (flipped pixels)


# --------------------------------------------------------------------------- IFC
def _small_ifc(path):
    """Two IfcSpaces in a storey, one with a lighting requirement (ifcopenshell.api)."""
    api = pytest.importorskip("ifcopenshell.api")
    f = api.run("project.create_file", version="IFC4")
    proj = api.run("root.create_entity", f, ifc_class="IfcProject", name="P")
    api.run("unit.assign_unit", f)
    ctx = api.run("context.add_context", f, context_type="Model")
    body = api.run("context.add_context", f, context_type="Model", context_identifier="Body",
                   target_view="MODEL_VIEW", parent=ctx)
    site = api.run("root.create_entity", f, ifc_class="IfcSite", name="S")
    bld = api.run("root.create_entity", f, ifc_class="IfcBuilding", name="B")
    st = api.run("root.create_entity", f, ifc_class="IfcBuildingStorey", name="Ground")
    api.run("aggregate.assign_object", f, relating_object=proj, products=[site])
    api.run("aggregate.assign_object", f, relating_object=site, products=[bld])
    api.run("aggregate.assign_object", f, relating_object=bld, products=[st])
    for i, name in enumerate(["Office", "Store"]):
        sp = api.run("root.create_entity", f, ifc_class="IfcSpace", name=str(i + 1))
        sp.LongName = name
        api.run("aggregate.assign_object", f, relating_object=st, products=[sp])
        rep = api.run("geometry.add_wall_representation", f, context=body, length=4000.0,
                      height=3000.0, thickness=3000.0)
        api.run("geometry.assign_representation", f, product=sp, representation=rep)
        if i == 0:
            ps = api.run("pset.add_pset", f, product=sp, name="Pset_SpaceLightingRequirements")
            api.run("pset.edit_pset", f, pset=ps, properties={"Illuminance": 500.0})
    f.write(str(path))


def _ifc_mutations(data, rng, n):
    """Byte mutations, and STEP-aware ones: an entity's reference, number or string
    replaced, a line dropped or its entity type changed."""
    lines = data.split(b"\n")
    data_lines = [i for i, l in enumerate(lines) if l.startswith(b"#")]
    for k, d in enumerate(_mutations(data, rng, n)):
        if k % 2 == 0:
            yield d
            continue
        ls = list(lines)
        i = data_lines[int(rng.integers(0, len(data_lines)))]
        what = int(rng.integers(0, 4))
        if what == 0:
            ls[i] = re.sub(rb"#\d+", lambda m: b"#%d" % int(rng.integers(0, 10 ** 6)), ls[i],
                           count=1)
        elif what == 1:
            ls[i] = re.sub(rb"-?\d+\.\d*", lambda m: rng.choice(
                [b"1E400", b"-0.", b"$", b"'x'", b"()"]), ls[i], count=1)
        elif what == 2:
            del ls[i]
        else:
            ls[i] = re.sub(rb"=IFC\w+\(", lambda m: rng.choice(
                [b"=IFCSPACE(", b"=IFCWALL(", b"=IFCBUILDINGSTOREY(", b"=IFCNOSUCH("]),
                ls[i], count=1)
        yield b"\n".join(ls)


def test_corrupt_ifc_files_are_checked_or_refused_in_one_line_before_freecad(tmp_path):
    freecad_cli = pytest.importorskip("invrad_wb.cli.freecad_cmd")
    pytest.importorskip("ifcopenshell")
    good = tmp_path / "good.ifc"
    _small_ifc(good)
    assert freecad_cli.check_ifc(str(good)) == 2
    path = tmp_path / "f.ifc"
    rng = np.random.default_rng(37)
    passed = 0
    for d in _bounded(_ifc_mutations(good.read_bytes(), rng, N_MUTATIONS)):
        path.write_bytes(d)
        try:
            freecad_cli.check_ifc(str(path))
            passed += 1
        except InvradError as exc:
            assert "\n" not in str(exc) and "f.ifc" in str(exc), str(exc)
    assert passed > 0


def test_an_ifc_check_that_crashes_is_refused_in_one_line(tmp_path, monkeypatch):
    # ifcopenshell 0.8 (FreeCAD 1.0.0's NativeIFC needs it) segfaults on some of the
    # corrupt files above: the freecad command checks the IFC in a child process, so a
    # crash there is a one-line error, not the end of the command. A stand-in ifcopenshell
    # that crashes the same way:
    freecad_cli = pytest.importorskip("invrad_wb.cli.freecad_cmd")
    from invrad_wb.errors import SceneError
    fake = tmp_path / "fake" / "ifcopenshell"
    fake.mkdir(parents=True)
    (fake / "__init__.py").write_text("import os, signal\n"
                                      "def open(path):\n"
                                      "    os.kill(os.getpid(), signal.SIGSEGV)\n")
    path = tmp_path / "house.ifc"
    _small_ifc(path)
    monkeypatch.setenv("PYTHONPATH", str(fake.parent))
    with pytest.raises(SceneError) as err:
        freecad_cli.check_ifc_isolated(str(path))
    msg = str(err.value)
    assert "\n" not in msg and "house.ifc" in msg and "SIGSEGV" in msg, msg
    # a file the check refuses keeps its own message; a good one passes
    monkeypatch.delenv("PYTHONPATH")
    freecad_cli.check_ifc_isolated(str(path))
    (tmp_path / "bad.ifc").write_text("ISO-10303-21;\nnot an ifc\n")
    with pytest.raises(SceneError, match="bad.ifc: not a readable IFC file"):
        freecad_cli.check_ifc_isolated(str(tmp_path / "bad.ifc"))


def test_corrupt_json_lux_sidecars_are_read_or_refused_in_one_line(tmp_path):
    import trimesh
    sc = g.box_room(size=(3.0, 2.0, 2.5), cell=1.0)
    obj = tmp_path / "room.obj"
    trimesh.Trimesh(sc.vertices, sc.faces, process=False).export(obj)
    lux = np.linspace(0, 500, len(sc.vertices)).tolist()
    lux[3] = None                                       # no target there
    good = json.dumps({"vertex_lux": lux}).encode()
    (tmp_path / "good.json").write_bytes(good)
    assert np.isnan(read_scene(obj, lux=tmp_path / "good.json").vertex_targets()).any()
    _fuzz_json(tmp_path, good, 41, lambda p: read_scene(obj, lux=p))
