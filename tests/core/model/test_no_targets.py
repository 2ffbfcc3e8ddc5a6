"""No targets is an error before any work, naming the file; a result without luminaires
always says why."""
import os
import subprocess
import sys

import numpy as np
import pytest

from invrad_wb.core.io.sceneio import read_scene, write_scene
from invrad_wb.core.model.targets import no_luminaire_reason, require_targets
from invrad_wb.core.synthetic import generate
from invrad_wb.errors import SceneError
from repo_paths import ROOT, SCENE_FILE_HELPERS

sys.path.insert(0, SCENE_FILE_HELPERS)


def _cli(*args):
    p = subprocess.run([sys.executable, "-m", "invrad_wb", *map(str, args)], cwd=ROOT,
                       capture_output=True, text=True, timeout=300,
                       )
    return p.returncode, [l for l in p.stderr.splitlines() if l.strip()], p


def _room(tmp_path, name, lux):
    scene = generate.box_room((4, 3, 2.5), cell=0.5)
    path = tmp_path / name
    write_scene(path, scene, lux=np.full(len(scene.vertices), lux))
    return path


def test_all_nan_targets_are_refused_before_work(tmp_path):
    scene = _room(tmp_path, "dark.ply", np.nan)
    out, report = tmp_path / "r.json", tmp_path / "report"
    rc, err, p = _cli("locate", scene, "--flux", "3000", "-o", out)
    assert rc == 2 and len(err) == 1, p.stderr
    assert err[0].startswith(f"invrad: error: {scene}: every target") and "NaN" in err[0]
    assert "luminaire(s)" not in p.stdout and not out.exists()
    lums = tmp_path / "lums.json"
    lums.write_text('{"luminaires": [{"position": [2, 1.5, 2.4], "normal": [0, 0, -1],'
                    ' "flux_lm": 1000}]}')
    rc, err, p = _cli("verify", scene, "--luminaires", lums, "--report", report)
    assert rc == 2 and len(err) == 1 and str(scene) in err[0], p.stderr
    assert not report.exists()


def test_all_shade_targets_say_why_no_luminaire(tmp_path):
    scene = _room(tmp_path, "shade.ply", 0.0)
    assert no_luminaire_reason(read_scene(scene)).startswith("every one of its")
    rc, err, p = _cli("locate", scene, "--flux", "3000", "-o", tmp_path / "r.json")
    assert rc == 0 and "0 luminaire(s)" in p.stdout, p.stderr
    assert len(err) == 1 and "no luminaire needed" in err[0] and "0 lx (shade)" in err[0]
    assert no_luminaire_reason(read_scene(_room(tmp_path, "lit.ply", 300.0))) is None


def test_an_all_nan_texture_is_refused_naming_the_texture(tmp_path):
    from scene_file_helpers import floor_with_uv, write_image
    mesh = floor_with_uv(tmp_path)
    tex = write_image(tmp_path / "lux.exr", np.full((4, 8), np.nan, np.float32), "float")
    with pytest.raises(SceneError, match=r"lux\.exr: every pixel"):
        require_targets(read_scene(mesh, texture=tex), mesh, texture=tex)
    rc, err, p = _cli("locate", mesh, "--texture", tex, "--flux", "3000", "-o",
                      tmp_path / "r.json")
    assert rc == 2 and len(err) == 1 and f"{tex}: every pixel" in err[0], p.stderr
    # one finite pixel is a target
    img = np.full((4, 8), np.nan, np.float32)
    img[1, 2] = 300.0
    tex2 = write_image(tmp_path / "lux2.exr", img, "float")
    require_targets(read_scene(mesh, texture=tex2), mesh, texture=tex2)
