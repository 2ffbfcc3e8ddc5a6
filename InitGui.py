# invrad workbench: the GUI part of FreeCAD's start-up.
# Nothing of the package is imported here and sys.path is left alone (this file runs at
# every FreeCAD start, for every workbench): Initialize() appends the checkout's venv to
# sys.path, checks the dependencies and loads invrad_wb.gui when the workbench is first
# activated.
#
# FreeCAD 0.20 runs this file with exec() inside a function: names defined at the top
# level are not visible inside the class's methods, and __file__ is not set. So every
# method imports what it needs, and the icon is found through the package's location
# (importlib's find_spec does not import it).
import FreeCADGui


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
        # FreeCAD's GUI clears PYTHONPATH: the venv of `make setup` goes at the END of
        # sys.path (other workbenches keep importing what they did); then everything still
        # missing in one dialog that offers to install it (invrad_wb/gui/install_dialog.py)
        from invrad_wb.app import dependencies
        dependencies.add_site_packages()
        from invrad_wb.gui import install_dialog
        install_dialog.offer()
        from invrad_wb.gui import commands
        commands.register()
        self.appendToolbar("InvRad", commands.TOOLBAR)
        self.appendMenu("InvRad", commands.MENU)
        # the same toolbar in the BIM workbench (FreeCAD 1.x), once, as a custom toolbar
        from invrad_wb.gui import bim
        bim.offer_toolbar()

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


class _InvRadBeamAxes:
    """The beam axes of aimed fixtures are Coin nodes, which FreeCAD does not save: drawn
    again once a document is opened (before the workbench is ever activated too) and
    after undo and redo (invrad_wb/gui/beamaxis.py, imported on the first document)."""

    def slotCreatedDocument(self, doc):
        try:
            from invrad_wb.gui import beamaxis
            beamaxis.redraw_later(doc)
        except Exception:          # a package that does not import leaves FreeCAD be
            pass

    slotUndoDocument = slotRedoDocument = slotCreatedDocument


import FreeCAD as _FreeCAD
if _FreeCAD.GuiUp and getattr(_FreeCAD, "_invrad_beam_axes", None) is None:
    _FreeCAD._invrad_beam_axes = _InvRadBeamAxes()
    _FreeCAD.addDocumentObserver(_FreeCAD._invrad_beam_axes)

# The 3D view's text (invrad's room names and legend, every other workbench's too): Coin
# opens FreeType and fontconfig at run time by their unversioned names, libfreetype.so and
# libfontconfig.so, which only the -dev packages install. FreeCAD 1.0 from Debian 13 has
# neither, and its text falls back to Coin's thin built-in font; where only the run-time
# libraries (.so.6, .so.1) load, Coin is pointed at them (its COIN_*_LIBNAME variables,
# read when the first text is drawn). Nothing changes where Coin finds them itself.
import sys as _sys
if _sys.platform.startswith("linux"):
    import ctypes as _ct
    import os as _os
    for _env, _dev, _run in (("COIN_FREETYPE2_LIBNAME", "libfreetype.so", "libfreetype.so.6"),
                             ("COIN_FONTCONFIG_LIBNAME", "libfontconfig.so",
                              "libfontconfig.so.1")):
        if _env in _os.environ:
            continue
        try:
            _ct.CDLL(_dev)
        except OSError:
            try:
                _ct.CDLL(_run)
                _os.environ[_env] = _run
            except OSError:
                pass
