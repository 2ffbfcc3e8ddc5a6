"""Command line: the documented commands work on plain meshes and fail cleanly."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest
from repo_paths import ROOT



def run(*args, env=None, check=False):
    e = dict(os.environ)
    e.update(env or {})
    p = subprocess.run([sys.executable, "-m", "invrad_wb", *args], cwd=ROOT, env=e,
                       capture_output=True, text=True, timeout=600)
    if check and p.returncode != 0:
        raise AssertionError(p.stdout + p.stderr)
    return p


def test_locate_without_flux_fits_each_luminaires_flux(tmp_path):
    scene, truth, result = tmp_path / "s.ply", tmp_path / "t.json", tmp_path / "r.json"
    run("example", "wall_and_ceiling", "-o", str(scene), "--truth", str(truth), check=True)
    p = run("locate", str(scene), "-o", str(result), check=True)
    assert "each luminaire are fitted" in p.stdout and "2 luminaire(s) in" in p.stdout
    assert "of one kind" not in p.stdout                  # 800 and 2500 lm stay apart
    found = sorted(json.loads(result.read_text())["luminaires"], key=lambda l: l["flux_lm"])
    true = sorted(json.loads(truth.read_text())["luminaires"], key=lambda l: l["flux_lm"])
    for f, t in zip(found, true):
        assert np.linalg.norm(np.subtract(f["position"], t["position"])) < 0.02
        assert f["flux_lm"] == pytest.approx(t["flux_lm"], rel=0.05)


def test_locate_without_flux_says_which_luminaires_are_of_one_kind(tmp_path):
    # two 3000 lm downlights: their fluxes fitted as one, said on the command line and
    # in the JSON (the same flux group)
    scene, result = tmp_path / "s.ply", tmp_path / "r.json"
    run("example", "two_ceiling", "-o", str(scene), check=True)
    p = run("locate", str(scene), "-o", str(result), check=True)
    assert "2 luminaires of one kind, 3000 lm each" in p.stdout
    found = json.loads(result.read_text())["luminaires"]
    assert [f["flux_group"] for f in found] == [1, 1]
    assert found[0]["flux_lm"] == found[1]["flux_lm"] == pytest.approx(3000.0, rel=0.01)


def test_example_locate_verify_round_trip(tmp_path):
    scene = tmp_path / "scene.ply"
    truth = tmp_path / "truth.json"
    run("example", "two_ceiling", "-o", str(scene), "--truth", str(truth), "--cell", "0.15",
        check=True)
    result = tmp_path / "result.json"
    maps = tmp_path / "maps"
    p = run("locate", str(scene), "--flux", "3000", "-o", str(result), "--vote-maps", str(maps),
            check=True)
    assert "2 luminaire(s)" in p.stdout
    data = json.loads(result.read_text())
    found = np.array([l["position"] for l in data["luminaires"]])
    true = np.array([l["position"] for l in json.loads(truth.read_text())["luminaires"]])
    d = np.linalg.norm(found[:, None] - true[None], axis=2)
    assert d.min(axis=0).max() < 0.1
    assert set(data) >= {"luminaires", "settings", "timings"}
    assert data["settings"]["vote_model"] == "exact"
    # the contact sheet is a page for a person: every map at a readable size, the
    # luminaires found crossed in red
    from invrad_wb.core.output.images import read_image
    sheet = read_image(maps / "room0" / "contact_sheet.png")
    assert sheet.shape[0] > 600 and sheet.shape[1] > 1000
    px = sheet[..., :3].astype(float)
    px = px * (255.0 if px.max() <= 1.0 else 1.0)
    red = (px[..., 0] > 200) & (px[..., 1] < 80) & (px[..., 2] < 80)
    assert red.sum() > 20
    assert (maps / "room0" / "maps.json").exists()
    rep = tmp_path / "report"
    run("verify", str(scene), "--luminaires", str(result), "--report", str(rep), check=True)
    assert (rep / "index.html").exists()
    # render: the forward solve of the true luminaires reproduces the targets
    out = tmp_path / "rendered.ply"
    run("render", str(scene), "--luminaires", str(truth), "-o", str(out),
        "--no-interreflection", check=True)
    from invrad_wb.core.io.sceneio import read_scene
    a, b = read_scene(str(scene)), read_scene(str(out))
    assert np.allclose(a.vertex_lux, b.vertex_lux, rtol=1e-4, atol=1e-3)


def test_settings_are_passed_through(tmp_path):
    scene = tmp_path / "scene.ply"
    run("example", "one_ceiling", "-o", str(scene), "--cell", "0.25", check=True)
    result = tmp_path / "r.json"
    run("locate", str(scene), "--flux", "3000", "-o", str(result), "--vote-model", "ellipse",
        "--resolution", "0.15", "--threshold", "60", "--dummy-planes", "false", check=True)
    s = json.loads(result.read_text())["settings"]
    assert s["vote_model"] == "ellipse" and s["pixel_m"] == 0.15 and s["threshold"] == 60
    assert s["dummy_planes"] is False


@pytest.mark.parametrize("args,needle", [
    (["locate", "missing.ply", "--flux", "3000", "-o", "x.json"], "missing.ply"),
    (["locate", "examples/office.ply", "--flux", "-5", "-o", "x.json"], "flux"),
    (["locate", "examples/office.ply", "--flux", "3000", "-o", "x.json", "--threshold", "300"],
     "threshold"),
    (["render", "examples/office.ply", "--luminaires", "nope.json", "-o", "x.ply"], "nope.json"),
    (["example", "castle", "-o", "x.ply"], "castle"),
])
def test_errors_are_one_line_with_status_2(tmp_path, args, needle):
    p = run(*[a if a != "x.json" and a != "x.ply" else str(tmp_path / a) for a in args])
    assert p.returncode == 2, p.stderr
    err = [l for l in p.stderr.splitlines() if l.startswith("invrad: error:")]
    assert len(err) == 1 and needle in err[0], p.stderr
    assert "Traceback" not in p.stderr


def test_millimetre_file_needs_unit(tmp_path):
    from invrad_wb.core.synthetic import generate as g
    from invrad_wb.core.io.sceneio import write_scene
    s = g.box_room((6, 4, 3), cell=1.0)
    s.vertices = s.vertices * 1000.0
    path = tmp_path / "mm.ply"
    write_scene(str(path), s, lux=np.full(len(s.vertices), 100.0))
    p = run("info", str(path))
    assert p.returncode == 2 and "--unit mm" in p.stderr
    p = run("info", str(path), "--unit", "mm", check=True)
    assert "6.0" in p.stdout


def test_no_opencl_device_is_a_clear_error(tmp_path):
    # an empty ICD vendor folder: the loader finds no platform
    empty = tmp_path / "vendors"
    empty.mkdir()
    p = run("locate", "examples/office.ply", "--flux", "3000", "-o", str(tmp_path / "r.json"),
            "--backend", "opencl", env={"OCL_ICD_VENDORS": str(empty)})
    assert p.returncode == 2
    assert "OpenCL" in p.stderr and "--backend numpy" in p.stderr
    assert not (tmp_path / "r.json").exists()


def test_failed_run_leaves_existing_output_untouched(tmp_path):
    out = tmp_path / "result.json"
    out.write_text("precious")
    p = run("locate", "examples/office.ply", "--flux", "0", "-o", str(out))
    assert p.returncode == 2
    assert out.read_text() == "precious"


def _one_luminaire(path, **kw):
    lum = {"position": [1.6, 1.1, 3.0], "normal": [0, 0, -1], "flux_lm": 3000.0,
           "radius_m": 0.0}
    lum.update(kw)
    path.write_text(json.dumps({"luminaires": [lum]}))
    return str(path)


@pytest.mark.parametrize("change,rc,needle", [
    ({"flux_lm": True}, 2, "flux_lm is true"),
    ({"radius_m": 1e6}, 2, "larger than the scene"),
    ({"normal": [0, 0, 1]}, 3, "faces away from every surface"),
    ({"position": [50, 50, 50]}, 0, "is outside the scene"),
])
def test_render_says_when_a_luminaire_cannot_light_the_room(tmp_path, change, rc, needle):
    lums = _one_luminaire(tmp_path / "l.json", **change)
    out = tmp_path / "r.ply"
    p = run("render", "examples/office.ply", "--luminaires", lums, "-o", str(out),
            "--no-interreflection")
    assert p.returncode == rc, p.stdout + p.stderr
    assert needle in p.stderr and "Traceback" not in p.stderr
    if rc == 2:
        assert not out.exists()                 # refused before any work


def test_a_metres_file_read_as_millimetres_is_refused(tmp_path):
    p = run("info", "examples/office.ply", "--unit", "mm")
    assert p.returncode == 2 and "6 mm across" in p.stderr and "--unit m" in p.stderr


def test_an_internal_error_says_what_to_report_and_logs_its_traceback(tmp_path,
                                                                     monkeypatch, capsys):
    from invrad_wb import cli
    from invrad_wb.cli import common, info

    def broken(args):
        return {}["no such key"]           # a bug, not an input error
    monkeypatch.setattr(info, "run", broken)
    monkeypatch.setenv(common.ENV_LOG_DIR, str(tmp_path / "logs"))
    rc = cli.main(["info", "examples/office.ply"])
    err = capsys.readouterr().err
    assert rc == common.EXIT_INTERNAL
    lines = [l for l in err.splitlines() if l.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    assert lines[0].startswith("invrad: internal error: KeyError: 'no such key'")
    assert "bug in invrad" in lines[0] and "please report it" in lines[0]
    logs = list((tmp_path / "logs").iterdir())
    assert len(logs) == 1 and str(logs[0]) in lines[0]
    log = logs[0].read_text()
    assert "Traceback" in log and "in broken" in log and "info examples/office.ply" in log
    # no folder for logs: the traceback is kept on stderr after the line, never lost
    (tmp_path / "file").write_text("")
    monkeypatch.setenv(common.ENV_LOG_DIR, str(tmp_path / "file" / "logs"))
    monkeypatch.setattr("tempfile.gettempdir", lambda: str(tmp_path / "file" / "tmp"))
    assert cli.main(["info", "examples/office.ply"]) == common.EXIT_INTERNAL
    err = capsys.readouterr().err
    assert "the traceback follows" in err.splitlines()[0] and "in broken" in err


def test_an_internal_error_under_freecadcmd_is_reported_the_same_way(tmp_path):
    # a stand-in for freecadcmd that fails the way child_main reports an internal error
    freecad_cli = pytest.importorskip("invrad_wb.cli.freecad_cmd")
    fake = tmp_path / "freecadcmd"
    fake.write_text(
        f"#!{sys.executable}\n"
        "import json, os\n"
        f"print({freecad_cli.SENTINEL!r}, flush=True)\n"
        f"job = json.load(open(os.environ[{freecad_cli.ENV_JOB!r}]))\n"
        "json.dump({'ok': False, 'type': 'internal',\n"
        "           'error': 'internal error: ZeroDivisionError: division by zero',\n"
        "           'traceback': 'Traceback (most recent call last):\\n  File x\\n'\n"
        "                        'ZeroDivisionError: division by zero\\n'},\n"
        "          open(job['status'], 'w'))\n")
    fake.chmod(0o755)
    import zipfile
    src = tmp_path / "in.FCStd"
    with zipfile.ZipFile(src, "w") as z:
        z.writestr("Document.xml", "<Document/>")
    p = run("freecad", str(src), "--out", str(tmp_path / "o.FCStd"), "--report",
            str(tmp_path / "r"), "--freecadcmd", str(fake), "--flux", "3000",
            env={"INVRAD_LOG_DIR": str(tmp_path / "logs")})
    assert p.returncode == 70, p.stdout + p.stderr
    lines = [l for l in p.stderr.splitlines() if l.strip()]
    assert len(lines) == 1 and "Traceback" not in p.stderr, p.stderr
    assert lines[0].startswith("invrad: internal error: ZeroDivisionError: division by zero.")
    log = next((tmp_path / "logs").iterdir()).read_text()
    assert "ZeroDivisionError" in log and "Traceback" in log
