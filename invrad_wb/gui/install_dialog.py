"""The first-activation dialog: everything the workbench misses, in one list, and an
*Install* button that runs :func:`invrad_wb.app.dependencies.install` (the same installer
as the headless ``freecadcmd -c "from invrad_wb.app import dependencies;
dependencies.install()"``) with a progress bar, then offers to restart FreeCAD.

The installer runs in a worker thread (pip is a child process); the dialog polls a queue
with a QTimer, so no Qt object is touched outside the GUI thread. Every line also goes to
the Report view. With ``messages.QUIET`` (tests, scripted runs) or without a GUI nothing
is shown but the Report view lines.
"""
import queue
import threading

from invrad_wb.app import dependencies
from invrad_wb.gui import messages

TITLE = "InvRad: Python packages"
#: the dialog while it is open (one at a time)
_OPEN = None


def offer(statuses=None):
    """Report what is missing and, with a GUI, show the dialog; returns the statuses that
    are not 'ok' (empty: nothing to do)."""
    statuses = dependencies.check() if statuses is None else statuses
    todo = [s for s in statuses if s.state != "ok"]
    for s in todo:
        level = "error" if s.package.needed and s.state in ("missing", "wrong") else "warning"
        messages.show(level, "InvRad", s.line, box=False)
    if not todo or not [s for s in todo if s.state != "pending"]:
        return todo
    import FreeCAD
    if messages.QUIET or not FreeCAD.GuiUp:
        return todo
    import FreeCADGui
    global _OPEN
    if _OPEN is not None and _OPEN.isVisible():
        _OPEN.raise_()
        return todo
    # not modal: the workbench's activation goes on (nothing waits on the user, a GUI
    # script or test is not blocked), and FreeCAD stays usable while pip runs
    _OPEN = _dialog(todo, FreeCADGui.getMainWindow())
    _OPEN.show()
    return todo


def _dialog(todo, parent):
    from PySide import QtCore, QtGui

    dlg = QtGui.QDialog(parent)
    dlg.setWindowTitle(TITLE)
    dlg.setMinimumWidth(560)
    lay = QtGui.QVBoxLayout(dlg)
    target = dependencies.target_dir()
    intro = QtGui.QLabel(
        "InvRad needs these Python packages, which this FreeCAD does not have (or not in"
        " a version it can use). <b>Install</b> downloads them with pip into FreeCAD's own"
        f" add-on package folder, as the Addon Manager does:<br><tt>{target}</tt><br>"
        "(internet needed; a few minutes). Optional ones only add features; without"
        " pyopencl/OpenCL the workbench runs on numpy, much slower.")
    intro.setWordWrap(True)
    lay.addWidget(intro)
    listing = QtGui.QPlainTextEdit("\n".join(s.line for s in todo))
    listing.setReadOnly(True)
    lay.addWidget(listing)
    bar = QtGui.QProgressBar()
    bar.setRange(0, 100)
    bar.setVisible(False)
    lay.addWidget(bar)
    status = QtGui.QLabel("")
    status.setWordWrap(True)
    lay.addWidget(status)
    buttons = QtGui.QDialogButtonBox()
    install = buttons.addButton("Install", QtGui.QDialogButtonBox.AcceptRole)
    close = buttons.addButton("Close", QtGui.QDialogButtonBox.RejectRole)
    lay.addWidget(buttons)
    close.clicked.connect(dlg.reject)
    events = queue.Queue()
    timer = QtCore.QTimer(dlg)
    timer.setInterval(100)

    def start():
        install.setEnabled(False)
        close.setEnabled(False)
        bar.setVisible(True)
        bar.setValue(0)
        listing.setPlainText("")

        def work():
            result = dependencies.install(
                say=lambda line: events.put(("line", line)),
                progress=lambda frac, text: events.put(("progress", (frac, text))))
            events.put(("done", result))

        threading.Thread(target=work, name="invrad-install", daemon=True).start()
        timer.start()

    def poll():
        while True:
            try:
                kind, value = events.get_nowait()
            except queue.Empty:
                return
            if kind == "line":
                listing.appendPlainText(value.replace("invrad install: ", "", 1))
                messages.show("info", "InvRad", value, box=False)
            elif kind == "progress":
                bar.setValue(int(round(100 * value[0])))
                status.setText(value[1][:200])
            else:
                timer.stop()
                _finished(dlg, value, status, close)

    install.clicked.connect(start)
    timer.timeout.connect(poll)
    return dlg


def _finished(dlg, result, status, close):
    from PySide import QtGui
    from invrad_wb.gui.qtcompat import flag_int, run_exec
    close.setEnabled(True)
    failed = [f"{n}: {result.reasons.get(n, '')}" for n in result.failed]
    text = ("Installed: " + (", ".join(result.installed) or "nothing new") + "."
            + (" Not installed: " + "; ".join(failed) + "." if failed else ""))
    status.setText(text)
    if not result.restart_needed:
        return
    box = QtGui.QMessageBox(QtGui.QMessageBox.Question, TITLE,
                            text + "\n\nFreeCAD uses the new packages after a restart."
                            " Restart FreeCAD now?",
                            QtGui.QMessageBox.Yes | QtGui.QMessageBox.No, dlg)
    if flag_int(run_exec(box)) == flag_int(QtGui.QMessageBox.Yes):
        dlg.accept()
        restart()


def restart():
    """Close FreeCAD (it asks about unsaved documents) and start it again."""
    import FreeCADGui
    from PySide import QtCore, QtGui
    app = QtGui.QApplication.instance()
    if FreeCADGui.getMainWindow().close():
        QtCore.QProcess.startDetached(app.applicationFilePath(), app.arguments()[1:])
