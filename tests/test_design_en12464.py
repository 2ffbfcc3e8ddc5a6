"""Design to the whole of EN 12464-1: legal spec values never crash, walls and ceiling
requirements, UGR of every entry, installed power; each checked against an independent
computation."""
import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest

from invrad_wb.core.synthetic import generate as g

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _cli(args, cwd):
    """``python -m invrad_wb`` of THIS tree (not whichever copy is installed)."""
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run([sys.executable, "-m", "invrad_wb", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300)


def _write_room(path, size=(5.0, 4.0, 2.8), cell=0.4):
    from invrad_wb.core.io.sceneio import write_scene
    sc = g.with_reflectances(g.box_room(size=size, cell=cell))
    write_scene(path, sc, lux=np.full(len(sc.vertices), np.nan))
    return sc


# ----------------------------------------------------------------------------- slice 1
def test_null_upper_mounting_height_never_crashes_after_the_computation(tmp_path):
    """``"mount_height_m": [2, null]`` ("no upper limit") is legal: the design, its
    RESULT.json and its report are written, the null kept as null."""
    _write_room(tmp_path / "room.ply")
    (tmp_path / "d.json").write_text(json.dumps(
        {"catalogue": [{"name": "HB", "flux_lm": 2000, "watts": 15.0,
                        "mount_height_m": [2, None]},
                       {"name": "HIGH", "flux_lm": 12000, "watts": 85.0,
                        "mount_height_m": [4, None]}],
         "rooms": {"0": {"work_plane": {"lux": 300, "u0": 0.4}}}}))
    cp = _cli(["design", "room.ply", "--spec", "d.json", "-o", "r.json", "--report", "rep"],
              tmp_path)
    assert cp.returncode in (0, 3), cp.stderr
    assert "internal error" not in cp.stderr
    data = json.loads((tmp_path / "r.json").read_text(),
                      parse_constant=lambda c: pytest.fail(f"{c} in RESULT.json"))
    cat = {e["name"]: e for e in data["catalogue"]}
    assert cat["HB"]["mount_height_m"] == [2.0, None]
    assert cat["HIGH"]["mount_height_m"] == [4.0, None]
    # the 2.8 m ceiling is below the high-bay's 4 m: only HB is used
    assert {lum["type"] for lum in data["luminaires"]} == {"HB"}
    assert (tmp_path / "rep" / "index.html").exists()
