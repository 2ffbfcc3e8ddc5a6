# invrad workbench: the GUI part of FreeCAD's start-up.
# Nothing of the package is imported here (it would slow down every FreeCAD start):
# Initialize() loads invrad_wb.gui when the workbench is first activated.
#
# FreeCAD 0.20 runs this file with exec() inside a function: names defined at the top
# level are not visible inside the class's methods, and __file__ is not set. So every
# method imports what it needs, and the icon is found through the package's location
# (importlib's find_spec does not import it).
import FreeCADGui


def _invrad_site_packages():
    """FreeCAD 0.20's GUI clears PYTHONPATH at start-up (MainGui.cpp, Linux), so the
    packages invrad needs (pyopencl, trimesh, OpenImageIO, ifcopenshell) are not found
    as they are under freecadcmd. Add the checkout's own venv (``make setup``) and the
    folders in $INVRAD_SITE_PACKAGES to sys.path, ahead of the system's packages as
    PYTHONPATH would be. Cheap: no package is imported."""
    import importlib.util
    import os
    import sys
    paths = [p for p in os.environ.get("INVRAD_SITE_PACKAGES", "").split(os.pathsep) if p]
    try:
        spec = importlib.util.find_spec("invrad_wb")
    except (ImportError, ValueError):
        spec = None
    if spec is not None and spec.origin:
        root = os.path.dirname(os.path.dirname(spec.origin))
        paths.append(os.path.join(root, ".venv", "lib",
                                  "python%d.%d" % sys.version_info[:2], "site-packages"))
    first_site = next((i for i, p in enumerate(sys.path)
                       if p.endswith(("site-packages", "dist-packages"))), len(sys.path))
    for p in reversed(paths):
        if os.path.isdir(p) and p not in sys.path:
            sys.path.insert(first_site, p)


_invrad_site_packages()


class InvRadWorkbench(FreeCADGui.Workbench):
    """Inverse lighting design: targets on room surfaces -> luminaires."""

    MenuText = "InvRad"
    ToolTip = ("Inverse lighting design: mark target illuminance on room surfaces, find"
               " where luminaires must go, insert them as light fixtures and verify")

    def _icon():
        import importlib.util
        import os
        try:
            spec = importlib.util.find_spec("invrad_wb")
        except (ImportError, ValueError):
            spec = None
        if spec is None or not spec.origin:
            return ""
        root = os.path.dirname(os.path.dirname(spec.origin))
        return os.path.join(root, "resources", "icons", "invrad.svg")

    Icon = _icon()
    del _icon

    def Initialize(self):
        from invrad_wb.gui import commands
        commands.register()
        self.appendToolbar("InvRad", commands.TOOLBAR)
        self.appendMenu("InvRad", commands.MENU)

    def Activated(self):
        pass

    def Deactivated(self):
        pass

    def ContextMenu(self, recipient):
        if recipient == "View":
            from invrad_wb.gui import commands
            self.appendContextMenu("InvRad", commands.CONTEXT)

    def GetClassName(self):
        return "Gui::PythonWorkbench"


FreeCADGui.addWorkbench(InvRadWorkbench())
