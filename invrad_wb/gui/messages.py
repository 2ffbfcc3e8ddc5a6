"""Messages to the user: the report view always, a dialog box when the GUI is up.

invrad's own errors (:class:`invrad_wb.errors.InvradError`) already say what is wrong and
where, so they are shown as their text, without a traceback; anything else is a bug and
gets its traceback in the report view.

``QUIET = True`` (the GUI tests and the smoke script) keeps the dialog boxes from
blocking: the messages are then only logged and collected in :data:`LOG`.
"""
import traceback

#: Do not open modal message boxes (tests, scripted runs).
QUIET = False
#: (level, title, text) of every message shown, newest last (kept short).
LOG = []
_MAX_LOG = 200


def _console(level, text):
    import FreeCAD
    line = text if text.endswith("\n") else text + "\n"
    {"error": FreeCAD.Console.PrintError, "warning": FreeCAD.Console.PrintWarning}.get(
        level, FreeCAD.Console.PrintMessage)("invrad: " + line)


def _box(level, title, text, details=None):
    import FreeCAD
    if QUIET or not FreeCAD.GuiUp:
        return
    import FreeCADGui
    from PySide import QtGui
    icon = {"error": QtGui.QMessageBox.Critical, "warning": QtGui.QMessageBox.Warning}.get(
        level, QtGui.QMessageBox.Information)
    box = QtGui.QMessageBox(icon, title, text, QtGui.QMessageBox.Ok,
                            FreeCADGui.getMainWindow())
    if details:
        box.setDetailedText(details)
    from invrad_wb.gui.qtcompat import run_exec
    run_exec(box)


def show(level, title, text, details=None, box=True):
    """Log ``text`` to the report view and, with a GUI and ``box``, in a message box."""
    LOG.append((level, title, text))
    del LOG[:-_MAX_LOG]
    _console(level, f"{title}: {text}" + (f"\n{details}" if details else ""))
    if box:
        _box(level, title, text, details)


def info(title, text, details=None):
    show("info", title, text, details)


def warning(title, text, details=None):
    show("warning", title, text, details)


def error(title, text, details=None):
    show("error", title, text, details)


def exception(title, exc):
    """Report an exception: invrad errors as their message, others with the traceback."""
    from invrad_wb.errors import Cancelled, InvradError
    if isinstance(exc, Cancelled):
        from invrad_wb.gui.progress import plain_words
        warning(title, f"{plain_words(exc)}\nThe document was not changed.")
    elif isinstance(exc, InvradError):
        error(title, f"{exc}\nThe document was not changed.")
    else:
        tb = "".join(traceback.format_exception(type(exc), exc, exc.__traceback__))
        error(title, f"{type(exc).__name__}: {exc}\nThe document was not changed.", tb)
