"""The workbench's message for a missing dependency, inside FreeCAD (0.20 and 1.x): the one
command that installs it, for a checkout (make setup) and for a copy the Addon Manager
installed (pip --target FreeCAD's AdditionalPythonPackages, on FreeCAD's path), with the
numpy and ifcopenshell that this FreeCAD needs."""
import os
import sys
import tempfile
import unittest

import FreeCAD

from fctest import ROOT
from invrad_wb.app import dependencies, nativeifc


class TestDependencyMessages(unittest.TestCase):

    def setUp(self):
        self.saved = {k: sys.modules.get(k) for k in ("trimesh", "pyopencl")}

    def tearDown(self):
        # undo only the hiding (a None entry): a package that problems() really imported
        # stays. Dropping 'pyopencl' while 'pyopencl._cl' & co. stayed made every later
        # import of pyopencl fail half-way ("partially initialized module"), so the FreeCAD
        # tests after this one ran on the numpy backend (NativeIFC all rooms 72 -> 425 s)
        for k, v in self.saved.items():
            if v is not None:
                sys.modules[k] = v
            elif sys.modules.get(k, 0) is None:
                del sys.modules[k]

    def test_hiding_a_package_leaves_it_importable(self):
        # what the tests above do to sys.modules must not break the imports after them
        self.test_an_addon_manager_copy_names_the_pip_command_into_freecads_path()
        self.tearDown()
        self.setUp()
        self.test_a_checkout_names_make_setup()
        self.tearDown()
        for name in self.saved:
            with self.subTest(package=name):
                self.assertIsNotNone(__import__(name).__name__)

    def test_an_addon_manager_copy_names_the_pip_command_into_freecads_path(self):
        sys.modules["trimesh"] = None
        with tempfile.TemporaryDirectory() as copy:       # not a checkout
            probs = dependencies.problems(copy)
        errors = [t for lvl, t in probs if lvl == "error"]
        self.assertEqual(len(errors), 1, probs)
        target = os.path.join(FreeCAD.getUserAppDataDir(), "AdditionalPythonPackages")
        if int(FreeCAD.Version()[0]) >= 1:          # 0.20 uses the folder itself
            target = os.path.join(target, "py%d%d" % sys.version_info[:2])
        self.assertIn(f"-m pip install --upgrade --target {target} 'trimesh>=4.0'",
                      errors[0])
        # the Addon Manager's folder is where FreeCAD looks (it is on sys.path once it
        # exists; FreeCAD adds it at start-up)
        self.assertEqual(dependencies.target_dir(), target)
        self.assertTrue(errors[0].startswith("missing Python package(s): trimesh."))

    def test_a_checkout_names_make_setup(self):
        sys.modules["pyopencl"] = None
        probs = dependencies.problems(ROOT)
        warn = [t for lvl, t in probs if lvl == "warning" and "pyopencl" in t]
        self.assertEqual(len(warn), 1, probs)
        self.assertTrue(warn[0].endswith(f"cd {ROOT} && make setup"))

    def test_numpy_requirement_follows_freecad(self):
        major = int(FreeCAD.Version()[0])
        self.assertEqual(dependencies.numpy_requirement(),
                         "numpy>=1.24" if major >= 1 else "numpy>=1.24,<2")

    @unittest.skipUnless(nativeifc.available(), "no NativeIFC in this FreeCAD")
    def test_nativeifc_works_with_the_installed_ifcopenshell(self):
        nativeifc.check_available()          # the set-up installs the 0.8 series
        self.assertFalse([t for _, t in dependencies.problems(ROOT) if "NativeIFC" in t])

    @unittest.skipUnless(nativeifc.available(), "no NativeIFC in this FreeCAD")
    def test_an_ifcopenshell_too_new_for_nativeifc_is_named_with_the_command(self):
        # a FreeCAD whose path has only the venv's ifcopenshell (0.9 from requirements.txt,
        # as the Addon Manager would install it), not the set-up's 0.8 folder
        import json
        import shutil
        import subprocess
        exe = shutil.which("freecadcmd")
        if exe is None:
            self.skipTest("no freecadcmd on the PATH")
        paths = [p for p in sys.path if "invrad-nativeifc" not in p]
        code = ("import sys, json\n"
                f"sys.path[:0] = {paths!r}\n"
                "import ifcopenshell\n"
                "from invrad_wb.app import dependencies as d\n"
                f"print('RESULT' + json.dumps([ifcopenshell.version, d.problems({ROOT!r})]))\n")
        out = subprocess.run([exe, "-c", code], capture_output=True, text=True, timeout=300)
        line = [l for l in out.stdout.splitlines() if l.startswith("RESULT")]
        self.assertTrue(line, out.stdout + out.stderr)
        version, probs = json.loads(line[0][6:])
        if not version.startswith("0.9"):
            self.skipTest(f"the venv's ifcopenshell is {version}, which NativeIFC accepts")
        warn = [t for lvl, t in probs if "NativeIFC" in t]
        self.assertEqual(len(warn), 1, probs)
        self.assertIn("needs ifcopenshell 0.8", warn[0])
        # make setup would install the requirements' ifcopenshell again: the pip command
        target = dependencies.target_dir()
        self.assertTrue(warn[0].endswith(
            f"-m pip install --upgrade --target {target} 'ifcopenshell>=0.8.1,<0.9'"),
            warn[0])
