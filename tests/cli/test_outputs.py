"""Outputs are checked before any work and a user's files are never replaced unasked
(each case a command line a user could type; clean one-line errors, exit 2, nothing
written)."""
import json
import os
import stat
import subprocess
import sys

import pytest
from repo_paths import ROOT

OFFICE = os.path.join(ROOT, "examples", "office.ply")


def _env(**extra):
    """This checkout's package first: a run in another folder must not import an installed
    (or another checkout's editable) invrad_wb."""
    env = dict(os.environ, **extra)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (ROOT, env.get("PYTHONPATH")) if p)
    return env


def run(*args, cwd):
    return subprocess.run([sys.executable, "-m", "invrad_wb", *args], cwd=cwd, env=_env(),
                          capture_output=True, text=True, timeout=300)


def one_line_error(cp, *words):
    assert cp.returncode == 2, cp.stderr
    err = cp.stderr.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("invrad: error:"), cp.stderr
    assert "Traceback" not in cp.stderr
    for w in words:
        assert w in err[0], err[0]


def test_output_on_a_folder_is_refused_before_reading(tmp_path):
    (tmp_path / "out").mkdir()
    cp = run("locate", OFFICE, "--flux", "3000", "-o", "out", cwd=tmp_path)
    one_line_error(cp, "out", "is a folder")


def test_output_under_a_file_or_in_an_unwritable_folder(tmp_path):
    (tmp_path / "f").write_text("keep")
    cp = run("locate", OFFICE, "--flux", "3000", "-o", "f/sub/r.json", cwd=tmp_path)
    one_line_error(cp, "is a file, not a folder")
    assert (tmp_path / "f").read_text() == "keep"
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        if os.access(ro, os.W_OK):
            pytest.skip("running as a user that can write anywhere (root)")
        cp = run("locate", OFFICE, "--flux", "3000", "-o", "ro/r.json", cwd=tmp_path)
        one_line_error(cp, "not writable")
    finally:
        ro.chmod(0o755)


def test_read_only_result_is_not_replaced(tmp_path):
    res = tmp_path / "r.json"
    res.write_text("{}")
    res.chmod(0o444)
    cp = run("locate", OFFICE, "--flux", "3000", "-o", "r.json", cwd=tmp_path)
    one_line_error(cp, "read-only")
    assert res.read_text() == "{}" and stat.S_IMODE(res.stat().st_mode) == 0o444


def test_vote_maps_and_report_on_a_file_are_refused_first(tmp_path):
    (tmp_path / "f").write_text("keep")
    cp = run("locate", OFFICE, "--flux", "3000", "-o", "r.json", "--vote-maps", "f",
             cwd=tmp_path)
    one_line_error(cp, "--vote-maps", "existing file")
    assert not (tmp_path / "r.json").exists()     # nothing written before the refusal
    lums = tmp_path / "l.json"
    lums.write_text(json.dumps({"luminaires": [{"position": [3, 2, 3], "flux_lm": 3000}]}))
    cp = run("verify", OFFICE, "--luminaires", "l.json", "--report", "f", cwd=tmp_path)
    one_line_error(cp, "--report", "existing file")
    assert (tmp_path / "f").read_text() == "keep"


def test_render_never_replaces_its_input(tmp_path):
    lums = tmp_path / "l.json"
    lums.write_text(json.dumps({"luminaires": [{"position": [3, 2, 3], "flux_lm": 3000}]}))
    scene = tmp_path / "s.ply"
    scene.write_bytes(open(OFFICE, "rb").read())
    before = scene.read_bytes()
    cp = run("render", "s.ply", "--luminaires", "l.json", "-o", "s.ply", cwd=tmp_path)
    one_line_error(cp, "input file")
    assert scene.read_bytes() == before


def test_symlinked_output_stays_a_link(tmp_path):
    target = tmp_path / "real.ply"
    target.write_text("old")
    (tmp_path / "link.ply").symlink_to(target)
    cp = run("example", "one_ceiling", "-o", "link.ply", "--cell", "0.5", cwd=tmp_path)
    assert cp.returncode == 0, cp.stderr
    assert (tmp_path / "link.ply").is_symlink()
    assert target.read_bytes().startswith(b"ply")


@pytest.mark.parametrize("cell", ["0", "nan", "-1", "0.001", "0.005", "inf"])
def test_example_cell_out_of_range(tmp_path, cell):
    cp = run("example", "one_ceiling", "-o", "x.ply", "--cell", cell, cwd=tmp_path)
    one_line_error(cp, "--cell")
    assert not (tmp_path / "x.ply").exists()


def test_freecad_output_over_its_input_is_refused(tmp_path):
    src = tmp_path / "in.ifc"
    src.write_bytes(open(os.path.join(ROOT, "tests", "data", "AC20-FZK-Haus.ifc"),
                         "rb").read())
    before = src.stat().st_mtime_ns
    cp = run("freecad", "in.ifc", "--out", "in.ifc", "--report", "rep", cwd=tmp_path)
    one_line_error(cp, "input file")
    assert src.stat().st_mtime_ns == before
    (tmp_path / "rep").write_text("a file")
    cp = run("freecad", "in.ifc", "--out", "out.ifc", "--report", "rep", cwd=tmp_path)
    one_line_error(cp, "--report", "existing file")


@pytest.mark.parametrize("content, words", [
    ('{"threshold": "high"}', "threshold must be a number"),
    ('[1, 2]', "must be a JSON object"),
    ('{"refine": "yes"}', "refine must be true or false"),
    ('{"dummy_count": 2.5}', "dummy_count must be a whole number"),
    ('{"pixel_m": 1e-4', "cannot read settings"),
])
def test_bad_settings_files_fail_before_reading_the_scene(tmp_path, content, words):
    (tmp_path / "s.json").write_text(content)
    cp = run("locate", OFFICE, "--flux", "3000", "-o", "r.json", "--settings", "s.json",
             cwd=tmp_path)
    one_line_error(cp, "s.json", words)
    assert not (tmp_path / "r.json").exists()


def test_impossible_flux_says_so_and_exits_3_with_strict_json(tmp_path):
    cp = run("locate", OFFICE, "--flux", "1e30", "-o", "r.json", cwd=tmp_path)
    assert cp.returncode == 3
    assert "no luminaire of 1e+30 lm explains the targets" in cp.stderr
    text = (tmp_path / "r.json").read_text()
    json.loads(text, parse_constant=lambda c: pytest.fail(f"non-strict JSON: {c}"))


def test_a_folder_that_refuses_files_is_caught_before_work(tmp_path, monkeypatch):
    # permission bits may say yes (root, a read-only mount): the check tries a file
    import tempfile
    from invrad_wb import outputs
    from invrad_wb.errors import InvradError

    def refuse(*a, **k):
        raise OSError(30, "Read-only file system")
    monkeypatch.setattr(tempfile, "mkstemp", refuse)
    with pytest.raises(InvradError, match="cannot write in the folder .*Read-only"):
        outputs.check_file(tmp_path / "r.json", "-o")
    monkeypatch.undo()
    assert outputs.check_file(tmp_path / "r.json", "-o").endswith("r.json")
    assert not [p for p in os.listdir(tmp_path) if p.startswith(".invrad-probe")]


@pytest.mark.parametrize("content,extra,words", [
    (b"hello", [], ["not a FreeCAD document", "not a zip archive"]),
    (None, [], ["no Document.xml"]),
    (None, ["--freecadcmd", "/nonexistent/freecadcmd"], ["--freecadcmd", "no such executable"]),
])
def test_freecad_command_checks_its_input_before_freecad_starts(tmp_path, content, extra,
                                                                 words):
    pytest.importorskip("invrad_wb.cli.freecad_cmd")
    import zipfile
    src = tmp_path / "in.FCStd"
    if content is None:
        with zipfile.ZipFile(src, "w") as z:
            z.writestr("GuiDocument.xml", "<x/>")
            if extra:
                z.writestr("Document.xml", "<Document/>")
    else:
        src.write_bytes(content)
    p = subprocess.run([sys.executable, "-m", "invrad_wb", "freecad", str(src), "--out",
                        str(tmp_path / "o.FCStd"), "--report", str(tmp_path / "r"),
                        *extra], cwd=ROOT, capture_output=True,
                       text=True, timeout=120)
    assert p.returncode == 2, p.stderr
    lines = [l for l in p.stderr.splitlines() if l.strip()]
    assert len(lines) == 1 and all(w in lines[0] for w in words), p.stderr


def test_a_killed_runs_temporary_files_are_removed_by_the_next(tmp_path):
    # a child that dies (SIGKILL) inside the atomic writers leaves its temporaries ...
    code = ("import os, signal, sys\n"
            "from invrad_wb.core.io.atomic import atomic_dir, atomic_path\n"
            "with atomic_path(sys.argv[1] + '/r.json') as t:\n"
            "    open(t, 'w').write('x')\n"
            "    with atomic_dir(sys.argv[1] + '/report') as d:\n"
            "        open(os.path.join(d, 'index.html'), 'w').write('x')\n"
            "        os.kill(os.getpid(), signal.SIGKILL)\n")
    p = subprocess.run([sys.executable, "-c", code, str(tmp_path)], cwd=ROOT)
    assert p.returncode == -9
    left = sorted(os.listdir(tmp_path))
    assert len(left) == 2 and all(n.startswith(".invrad-") for n in left), left
    # ... a live process' are kept; the next run removes the dead one's
    mine = tmp_path / f".invrad-{os.getpid()}-busy.json"
    mine.write_text("running")
    from invrad_wb.core.io.atomic import atomic_write_text
    atomic_write_text(tmp_path / "r.json", "{}")
    assert sorted(os.listdir(tmp_path)) == sorted([mine.name, "r.json"])


@pytest.mark.slow
def test_interrupted_vote_maps_leave_the_previous_ones_and_the_result(tmp_path, monkeypatch):
    from invrad_wb import cli
    from invrad_wb.core.output import votemap_images
    out, maps = tmp_path / "r.json", tmp_path / "maps"
    args = ["locate", os.path.join(ROOT, "examples", "office.ply"), "--flux", "3000",
            "-o", str(out), "--vote-maps", str(maps), "--backend", "numpy",
            "--resolution", "0.2", "--votes-per-m2", "40"]
    assert cli.main(args) == 0
    before = {p: (maps / "room0" / p).read_bytes() for p in os.listdir(maps / "room0")}
    (maps / "mine.txt").write_text("the user's")
    out.write_text("previous result")
    calls = []

    def interrupted(path, a):               # Ctrl-C at the fifth image
        calls.append(path)
        if len(calls) == 5:
            raise KeyboardInterrupt
        return real(path, a)
    real = votemap_images.save_png
    monkeypatch.setattr(votemap_images, "save_png", interrupted)
    assert cli.main(args) == 130
    assert out.read_text() == "previous result"
    assert sorted(os.listdir(maps)) == ["mine.txt", "room0"]          # no staging left
    after = {p: (maps / "room0" / p).read_bytes() for p in os.listdir(maps / "room0")}
    assert after == before


# --------------------------------------------------------------------------- issue 10's
# remaining cases, each as a user would type it

def _small_scene(path, lux=None, floor_only=False):
    """The one_ceiling example at 0.25 m, targets rendered (or ``lux`` everywhere);
    ``floor_only``: its floor alone (no surface for a luminaire to be on)."""
    import numpy as np
    from invrad_wb.core.io.sceneio import write_scene
    from invrad_wb.core.synthetic.scenarios import known_scene
    scene, _ = known_scene("one_ceiling", cell=0.25, backend="numpy")
    if floor_only:
        scene = scene.face_subset(np.flatnonzero(scene.face_normals[:, 2] > 0.9))
    t = scene.vertex_targets() if lux is None else np.full(len(scene.vertices), lux)
    write_scene(path, scene, lux=t)
    return path


def _exit_3_with_reason(cp, out, *words):
    assert cp.returncode == 3, cp.stdout + cp.stderr
    assert "Traceback" not in cp.stderr
    for w in words:
        assert w in cp.stderr, cp.stderr
    json.loads(out.read_text(), parse_constant=lambda c: pytest.fail(f"non-strict: {c}"))


def test_unreachable_targets_say_so_and_exit_3(tmp_path):
    _small_scene(tmp_path / "s.ply", lux=1e30)           # every target at 1e30 lx
    cp = run("locate", "s.ply", "--flux", "3000", "-o", "r.json", cwd=tmp_path)
    _exit_3_with_reason(cp, tmp_path / "r.json", "no luminaire of 3000 lm explains",
                        "reachable", "up to 1e+30 lx, brighter than direct sunlight")
    assert json.loads((tmp_path / "r.json").read_text())["luminaires"] == []


def test_a_floor_only_scene_says_so_and_exits_3(tmp_path):
    _small_scene(tmp_path / "s.ply", floor_only=True)
    cp = run("locate", "s.ply", "--flux", "3000", "-o", "r.json", cwd=tmp_path)
    _exit_3_with_reason(cp, tmp_path / "r.json", "no luminaire of 3000 lm explains")


def test_a_vanishing_flux_says_so_and_exits_3(tmp_path):
    _small_scene(tmp_path / "s.ply")
    cp = run("locate", "s.ply", "--flux", "1e-30", "-o", "r.json", cwd=tmp_path)
    _exit_3_with_reason(cp, tmp_path / "r.json", "no luminaire of 1e-30 lm explains")


def test_a_malformed_lux_sidecar_without_flux_names_the_file_not_the_flux(tmp_path):
    (tmp_path / "t.json").write_text('{"lux": [1, 2')
    cp = run("locate", OFFICE, "--lux", "t.json", "-o", "r.json", cwd=tmp_path)
    one_line_error(cp, "t.json", "not valid JSON")
    assert "flux" not in cp.stderr
    assert not (tmp_path / "r.json").exists()


@pytest.mark.parametrize("how", [["--settings", "s.json"], ["--votes-per-m2", "1e9"]])
def test_memory_settings_from_a_file_or_the_command_line_are_refused_first(tmp_path, how):
    (tmp_path / "s.json").write_text('{"pixel_m": 1e-4}')
    env = _env(INVRAD_MEMORY_LIMIT="2G")
    cp = subprocess.run([sys.executable, "-m", "invrad_wb", "locate", OFFICE, "--flux",
                         "3000", "-o", "r.json", *how], cwd=tmp_path, env=env,
                        capture_output=True, text=True, timeout=300)
    one_line_error(cp, "over the limit of 2.0 GB", "INVRAD_MEMORY_LIMIT")
    assert not (tmp_path / "r.json").exists()


@pytest.mark.parametrize("colour", [0, 2])              # grey and RGB PNG
def test_a_texture_declaring_huge_dimensions_is_refused_by_the_cli(tmp_path, colour):
    pytest.importorskip("OpenImageIO")
    import struct
    import zlib
    from invrad_wb.core.synthetic import generate as g
    sc = g.box_room((3, 2, 2.5), cell=1.0)
    v, f = sc.vertices, sc.faces
    head = ("ply\nformat ascii 1.0\nelement vertex %d\nproperty float x\nproperty float y\n"
            "property float z\nproperty float s\nproperty float t\nelement face %d\n"
            "property list uchar int vertex_indices\nend_header\n" % (len(v), len(f)))
    rows = [f"{x} {y} {z} {x / 3} {y / 2}" for x, y, z in v]
    rows += [f"3 {a} {b} {c}" for a, b, c in f]
    (tmp_path / "uv.ply").write_text(head + "\n".join(rows) + "\n")

    def chunk(kind, data):
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))
    ihdr = struct.pack(">IIBBBBB", 20000, 20000, 8, colour, 0, 0, 0)
    (tmp_path / "bomb.png").write_bytes(
        b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr)
        + chunk(b"IDAT", zlib.compress(b"\0" * 4096)) + chunk(b"IEND", b""))
    env = _env(INVRAD_MEMORY_LIMIT="2G")
    cp = subprocess.run([sys.executable, "-m", "invrad_wb", "info", "uv.ply", "--texture",
                         "bomb.png", "--texture-max-lux", "500"], cwd=tmp_path, env=env,
                        capture_output=True, text=True, timeout=300)
    one_line_error(cp, "bomb.png")
    assert "20000 x 20000" in cp.stderr or "corrupt" in cp.stderr or "claims" in cp.stderr


def test_a_killed_verify_leaves_no_hidden_folder_after_the_next_run(tmp_path):
    lums = tmp_path / "l.json"
    lums.write_text(json.dumps({"luminaires": [{"position": [3, 2, 2.95],
                                                "flux_lm": 3000}]}))
    rep = tmp_path / "rep"
    # SIGKILL while the report's first figure is drawn (a real verify, killed inside)
    code = ("import os, signal, sys\n"
            "from invrad_wb.core.output import figures\n"
            "figures.png = lambda *a, **k: os.kill(os.getpid(), signal.SIGKILL)\n"
            "from invrad_wb import cli\n"
            "cli.main(sys.argv[1:])\n")
    args = ["verify", OFFICE, "--luminaires", str(lums), "--report", str(rep),
            "--no-interreflection"]
    p = subprocess.run([sys.executable, "-c", code, *args], cwd=ROOT, capture_output=True)
    assert p.returncode == -9, p.stderr
    assert [n for n in os.listdir(rep) if n.startswith(".invrad-")], os.listdir(rep)
    assert not (rep / "index.html").exists()
    cp = run(*args, cwd=ROOT)
    assert cp.returncode == 0, cp.stderr
    assert (rep / "index.html").exists()
    assert not [n for n in os.listdir(rep) if n.startswith(".invrad-")], os.listdir(rep)


@pytest.mark.parametrize("option, value, words", [
    ("--resolution", "0", "--resolution must be a positive number, got 0.0"),
    ("--dummy-spacing", "-1", "--dummy-spacing must be a positive number"),
    ("--threshold", "300", "--threshold must be in [0, 254]"),
    ("--max-tilt", "95", "--max-tilt must be in [0, 90) degrees"),
    ("--dummy-count", "-3", "--dummy-count must be >= 0"),
    ("--flux", "0", "--flux must be a positive number of lumens"),
])
def test_a_bad_locate_option_is_named_as_typed(tmp_path, capsys, option, value, words):
    # the option the user gave, not the setting's field name (--resolution, not pixel_m)
    from invrad_wb import cli
    rc = cli.main(["locate", OFFICE, "--flux", "3000", option, value, "-o",
                   str(tmp_path / "r.json")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1, err
    assert err[0].startswith(f"invrad: error: {words}") and not os.listdir(tmp_path)


@pytest.mark.parametrize("case, words", [
    ("settings", ["s.json", "threshold must be a number"]),
    ("flux", ["--flux must be a positive number"]),
    ("mesh size", ["--mesh-size must be a finite length of at least 0.01 m, got 0.0"]),
    ("resolution", ["--resolution must be a finite length of at least 0.01 m, got 0.0"]),
    ("garbage", ["in.ifc", "not a readable IFC file"]),
    ("no rooms", ["in.ifc", "no rooms (IfcSpace)"]),
])
def test_freecad_command_checks_settings_flux_and_the_ifc_before_freecad_starts(tmp_path,
                                                                                case, words):
    pytest.importorskip("invrad_wb.cli.freecad_cmd")
    pytest.importorskip("ifcopenshell")
    src = tmp_path / "in.ifc"
    fzk = open(os.path.join(ROOT, "tests", "data", "AC20-FZK-Haus.ifc"), "rb").read()
    extra = []
    if case == "garbage":
        src.write_bytes(b"\x00\xffnot an IFC at all" * 10)
    elif case == "no rooms":
        src.write_bytes(b"\n".join(l for l in fzk.split(b"\n") if b"IFCSPACE(" not in l))
    else:
        src.write_bytes(fzk)
    if case == "settings":
        (tmp_path / "s.json").write_text('{"threshold": "high"}')
        extra = ["--settings", "s.json"]
    elif case == "flux":
        extra = ["--flux", "-3"]
    elif case == "mesh size":
        extra = ["--mesh-size", "0"]          # not taken for 'not given'
    elif case == "resolution":
        extra = ["--resolution", "0"]         # the old spelling: named as typed
    # a freecadcmd that fails the test if it is ever started
    fake = tmp_path / "freecadcmd"
    fake.write_text("#!/bin/sh\necho started >&2\nexit 9\n")
    fake.chmod(0o755)
    cp = run("freecad", "in.ifc", "--out", "out.ifc", "--report", "rep", "--freecadcmd",
             str(fake), *extra, cwd=tmp_path)
    if case == "resolution":                  # the old spelling is also warned about
        warning, cp.stderr = cp.stderr.split("\n", 1)
        assert warning.startswith("invrad: warning: --resolution is deprecated"), warning
    one_line_error(cp, *words)
    assert "started" not in cp.stderr and not (tmp_path / "rep").exists()
