"""``python -m invrad_wb freecad``: re-launch under freecadcmd, exit status, outputs."""
import json
import os
import subprocess

import numpy as np

import FreeCAD

from fctest import (FZK, ROOT, FreeCADTestCase, needs_fzk, needs_locate)
from invrad_wb.app import fixtures

# the interpreter with invrad's dependencies: $INVRAD_PYTHON (the FreeCAD 1.0 root's venv,
# .ci/test-freecad1.sh), else the checkout's venv, else the system's
PYTHON = os.environ.get("INVRAD_PYTHON") or os.path.join(ROOT, ".venv", "bin", "python")
if not os.path.exists(PYTHON):
    PYTHON = "/usr/bin/python3"


def cli(*args, timeout=900):
    """Run the command as a user would, from a plain Python (not FreeCAD)."""
    env = os.environ.copy()
    env["PYTHONPATH"] = ROOT
    p = subprocess.run([PYTHON, "-m", "invrad_wb", "freecad", *args], capture_output=True,
                       text=True, env=env, cwd=ROOT, timeout=timeout)
    return p.returncode, p.stdout, p.stderr


class TestCliErrors(FreeCADTestCase):

    def test_errors_are_one_line_with_status_2(self):
        cases = [
            ((self.path("missing.ifc"), "--out", self.path("o.ifc"), "--report",
              self.path("r"), "--flux", "1000"), ["missing.ifc", "does not exist"]),
            ((FZK, "--out", self.path("o.ifc"), "--report", self.path("r"), "--flux", "0"),
             ["flux", "positive"]),
            # no --flux is allowed (locate finds each luminaire's flux); a building
            # without targets is still an error naming it
            ((FZK, "--out", self.path("o.ifc"), "--report", self.path("r")),
             ["AC20-FZK-Haus", "lighting targets"]),
            ((FZK, "--out", self.path("o.step"), "--report", self.path("r"), "--flux", "800"),
             ["o.step", ".FCStd or .ifc"]),
        ]
        for args, words in cases:
            rc, out, err = cli(*args)
            self.assertEqual(rc, 2, (args, out, err))
            lines = [l for l in err.splitlines() if l.strip()]
            self.assertEqual(len(lines), 1, err)
            self.assertTrue(lines[0].startswith("invrad: error: "), err)
            for w in words:
                self.assertIn(w, lines[0])
            self.assertNotIn("FreeCAD 0.20", out)              # banner filtered out

    def test_old_resolution_spelling_is_a_deprecated_mesh_size(self):
        import warnings
        from invrad_wb.cli import build_parser
        base = ["freecad", "in.FCStd", "--out", "o.FCStd", "--report", "r"]
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            new = build_parser().parse_args(base + ["--mesh-size", "0.25"])
            self.assertEqual(caught, [])
            old = build_parser().parse_args(base + ["--resolution", "0.2"])
        self.assertEqual((new.mesh_size, old.mesh_size), (0.25, 0.2))
        self.assertEqual(len(caught), 1)
        self.assertIn("--mesh-size", str(caught[0].message))
        # `locate --resolution` keeps its meaning (vote-map metres per pixel), no warning
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            loc = build_parser().parse_args(["locate", "s.ply", "--flux", "1000", "-o", "r",
                                             "--resolution", "0.05"])
        self.assertEqual((loc.pixel_m, caught), (0.05, []))
        # from the command line: one warning line, then the run goes on (here: its error)
        rc, out, err = cli(self.path("missing.FCStd"), "--out", self.path("o.FCStd"),
                           "--report", self.path("r"), "--flux", "1000", "--resolution", "0.2")
        lines = [l for l in err.splitlines() if l.strip()]
        self.assertEqual(rc, 2, err)
        self.assertEqual(len(lines), 2, err)
        self.assertTrue(lines[0].startswith("invrad: warning: --resolution is deprecated"))
        self.assertIn("missing.FCStd", lines[1])

    @needs_fzk
    def test_room_without_targets_fails_cleanly(self):
        t = self.path("t.json")
        with open(t, "w") as fh:
            json.dump({"rooms": {"Dachboden": {"work_plane": 300}}}, fh)
        rc, out, err = cli(FZK, "--targets", t, "--out", self.path("o.ifc"), "--report",
                           self.path("r"), "--flux", "1000")
        self.assertEqual(rc, 2, err)
        self.assertIn("no room 'Dachboden'", err)
        self.assertIn("Wohnen", err)
        self.assertFalse(os.path.exists(self.path("o.ifc")))


@needs_locate
class TestCliRuns(FreeCADTestCase):

    def test_fcstd_in_fcstd_out_finds_known_luminaires(self):
        from test_pipeline import office_with_two_lights
        _, truth = office_with_two_lights(self.doc, self.tmp)
        src = self.path("office.FCStd")
        self.doc.saveAs(src)
        out = self.path("lit.FCStd")
        rc, stdout, err = cli(src, "--out", out, "--report", self.path("report"), "--flux",
                              "2000", "--mesh-size", "0.2", "--no-interreflection")
        self.assertEqual(rc, 0, stdout + err)
        self.assertIn("room Office: 2 luminaire(s)", stdout)
        self.assertTrue(os.path.isfile(os.path.join(self.path("report"), "summary.json")))
        doc = FreeCAD.openDocument(out)
        lit = doc.getObjectsByLabel("Office")[0]
        got = sorted(fixtures.fixture_luminaire(o).position[0]
                     for o in fixtures.room_fixtures(lit))
        np.testing.assert_allclose(got, [1.15, 2.85], atol=0.05)

    @needs_fzk
    def test_ifc_in_ifc_out_with_a_targets_file(self):
        import ifcopenshell
        import ifcopenshell.util.element as E
        t = self.path("targets.json")
        with open(t, "w") as fh:
            json.dump({"flux_lm": 1500, "rooms": {"Buero": {"work_plane": 300}}}, fh)
        out = self.path("fzk_lit.ifc")
        rc, stdout, err = cli(FZK, "--targets", t, "--out", out, "--report",
                              self.path("report"), "-v")
        self.assertEqual(rc, 0, stdout + err)
        self.assertIn("imported 7 room(s)", stdout)
        self.assertIn("room Buero:", stdout)
        ifc = ifcopenshell.open(out)
        lf = ifc.by_type("IfcLightFixture")
        self.assertGreaterEqual(len(lf), 1)
        src = ifcopenshell.open(FZK)
        office = [s for s in src.by_type("IfcSpace") if s.LongName == "Buero"][0]
        for e in lf:
            self.assertEqual(E.get_container(e).GlobalId, office.GlobalId)
        req = E.get_psets(ifc.by_guid(office.GlobalId))["Pset_SpaceLightingRequirements"]
        self.assertEqual(req["Illuminance"], 300.0)
        with open(os.path.join(self.path("report"), "summary.json")) as fh:
            summary = json.load(fh)
        self.assertEqual([r["room"] for r in summary["rooms"]], ["Buero"])
        self.assertEqual(len(summary["luminaires"]), len(lf))
