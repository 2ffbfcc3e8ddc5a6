"""The GUI's Qt usage works with PySide2 (Qt 5) and PySide6 (Qt 6).

Every ``QtGui.X``, ``QtCore.X`` and ``QtCore.Qt.X`` the gui modules use is looked up in
the running FreeCAD's ``PySide`` shim (Qt 5 on Debian's 0.20 and 1.0), and, where a Python
has PySide6 (the FreeCAD 1.0 root has Debian's), in PySide6's QtGui + QtWidgets + QtCore
(what FreeCAD's shim merges on a Qt 6 build), in a separate process (Qt 5 is loaded here). Qt 5-only idioms are refused statically: ``exec_()`` calls (``qtcompat.run_exec``),
``int()`` of enum flags (``qtcompat.flag_int``), direct PySide2/PySide6/QtWidgets imports
(FreeCAD's shim maps them), and classes that Qt 6 removed."""
import ast
import glob
import os
import unittest

from fctest import ROOT

GUI = sorted(glob.glob(os.path.join(ROOT, "invrad_wb", "gui", "*.py"))) + \
    [os.path.join(ROOT, "InitGui.py")]
#: removed in Qt 6 (QtCore5Compat) or moved out of the modules FreeCAD's shim merges
QT5_ONLY = {"QRegExp", "QDesktopWidget", "QStringRef", "QTextCodec", "QGLWidget",
            "QSound", "QMatrix", "QLinkedList", "QRegExpValidator", "QWheelEvent.delta"}


def qt_names():
    """{(module, name) or ('Qt', name): [file:line, ...]} used by the gui modules."""
    out = {}
    for path in GUI:
        tree = ast.parse(open(path, encoding="utf-8").read(), path)
        for node in ast.walk(tree):
            if not isinstance(node, ast.Attribute):
                continue
            v = node.value
            where = f"{os.path.basename(path)}:{node.lineno}"
            if isinstance(v, ast.Name) and v.id in ("QtGui", "QtCore"):
                out.setdefault((v.id, node.attr), []).append(where)
            elif (isinstance(v, ast.Attribute) and v.attr == "Qt"
                  and isinstance(v.value, ast.Name) and v.value.id == "QtCore"):
                out.setdefault(("Qt", node.attr), []).append(where)
    return out


class TestQtNames(unittest.TestCase):

    def test_the_gui_uses_some_qt(self):
        names = qt_names()
        self.assertIn(("QtGui", "QMessageBox"), names)
        self.assertIn(("Qt", "UserRole"), names)

    def test_no_qt5_only_idioms(self):
        bad = []
        for path in GUI:
            tree = ast.parse(open(path, encoding="utf-8").read(), path)
            for node in ast.walk(tree):
                where = f"{os.path.basename(path)}:{getattr(node, 'lineno', 0)}"
                if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) \
                        and node.func.attr == "exec_":
                    bad.append(f"{where}: exec_() (use qtcompat.run_exec)")
                if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) \
                        and node.func.id == "int" and node.args \
                        and isinstance(node.args[0], ast.BinOp) \
                        and "Qt" in ast.unparse(node.args[0]):
                    bad.append(f"{where}: int() of Qt flags (use qtcompat.flag_int)")
                if isinstance(node, (ast.Import, ast.ImportFrom)):
                    mods = [a.name for a in node.names] if isinstance(node, ast.Import) \
                        else [node.module or ""]
                    for m in mods:
                        if m.split(".")[0] in ("PySide2", "PySide6", "PyQt5", "PyQt6") \
                                or m.endswith("QtWidgets"):
                            bad.append(f"{where}: imports {m} (use FreeCAD's PySide)")
                if isinstance(node, ast.Attribute) and node.attr in QT5_ONLY:
                    bad.append(f"{where}: {node.attr} is not in Qt 6")
        self.assertEqual(bad, [])

    def _check(self, modules, qt):
        missing = []
        for (mod, name), where in sorted(qt_names().items()):
            if mod == "Qt":
                ok = hasattr(qt, name)
            else:
                ok = any(hasattr(m, name) for m in modules[mod])
            if not ok:
                missing.append(f"{mod}.{name} ({', '.join(where)})")
        self.assertEqual(missing, [])

    def test_names_exist_in_freecads_pyside(self):
        try:
            from PySide import QtCore, QtGui
        except ImportError as exc:
            self.skipTest(f"FreeCAD's PySide shim cannot be imported here ({exc})")
        self._check({"QtGui": [QtGui], "QtCore": [QtCore]}, QtCore.Qt)

    def test_names_exist_in_pyside6(self):
        import json
        import subprocess
        import sys
        python = os.environ.get("INVRAD_PYTHON") or sys.executable
        names = sorted(set(qt_names()))
        code = ("import json, sys\n"
                "try:\n    from PySide6 import QtCore, QtGui, QtWidgets\n"
                "except ImportError as e:\n    print(json.dumps({'skip': str(e)})); sys.exit()\n"
                "mods = {'QtGui': [QtGui, QtWidgets], 'QtCore': [QtCore]}\n"
                "miss = [f'{m}.{n}' for m, n in json.loads(sys.argv[1])\n"
                "        if not (hasattr(QtCore.Qt, n) if m == 'Qt'\n"
                "                else any(hasattr(x, n) for x in mods[m]))]\n"
                "print(json.dumps({'missing': miss, 'version': QtCore.qVersion()}))\n")
        try:
            out = subprocess.run([python, "-c", code, json.dumps(names)], text=True,
                                 capture_output=True, timeout=120)
            res = json.loads(out.stdout.strip().splitlines()[-1])
        except (OSError, ValueError, IndexError, subprocess.TimeoutExpired) as exc:
            self.skipTest(f"no Python with PySide6 here ({python}: {exc})")
        if "skip" in res:
            self.skipTest(f"PySide6 is not installed for {python} ({res['skip']})")
        print(f"  {len(names)} Qt names checked against PySide6 / Qt {res['version']}")
        self.assertEqual(res["missing"], [])
