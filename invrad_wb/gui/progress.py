"""Long runs with a progress dialog that can cancel them.

:func:`run` calls ``work(progress)`` in a worker thread while the main thread shows a
modal dialog (message, bar, elapsed time, *Cancel*) and keeps FreeCAD responsive. The
worker only computes: it must not change the document (document changes, which create
view providers and coin nodes, stay in the main thread). ``progress(fraction, message)``
returns False once the user has cancelled, which makes invrad's pipeline raise
:class:`~invrad_wb.errors.Cancelled` at its next step; the dialog says that it is
cancelling until then.

Without a GUI (freecadcmd, tests) ``work`` simply runs in the calling thread.
"""
import threading
import time


#: The method's step names in progress messages (the core's, also the CLI's) and the words
#: the dialog shows an architect instead; the docs and the Advanced settings keep the
#: method's terms.
PLAIN_WORDS = (("voting points", "sampling the targets"),
               ("vote maps", "looking for positions"),
               ("votes", "weighing positions"),
               ("peaks and refinement", "placing luminaires"),
               ("refinement", "fine-tuning positions"),
               ("peaks", "placing luminaires"),
               ("forward solve", "computing the light"))


def plain_words(message):
    """A progress message in plain words: each ": "-separated part that names one of the
    method's steps (:data:`PLAIN_WORDS`) translated; a room's name and the rest as they
    are."""
    parts = str(message).split(": ")
    for i, part in enumerate(parts):
        for method, plain in PLAIN_WORDS:
            if part == method or part.startswith(method + " "):
                parts[i] = plain + part[len(method):]
                break
    return ": ".join(parts)


class Job:
    """Shared state between the worker and the dialog (plain attributes: the GIL suffices)."""

    def __init__(self):
        self.fraction = 0.0
        self.message = ""
        self.cancelled = False
        self.done = False
        self.result = None
        self.error = None
        self.started = time.monotonic()

    def progress(self, fraction, message):
        self.fraction = min(max(float(fraction), 0.0), 1.0)
        self.message = plain_words(message)
        return not self.cancelled


#: The job now running (None when idle); tests and the smoke script look at it.
CURRENT = None
#: Dialog of the job now running (GUI only), e.g. for a test to press Cancel.
DIALOG = None


def busy():
    return CURRENT is not None


def _make_dialog(title):
    import FreeCADGui
    from PySide import QtCore, QtGui

    class ProgressDialog(QtGui.QDialog):
        def __init__(self, parent):
            super().__init__(parent)
            self.setWindowTitle(title)
            self.setWindowModality(QtCore.Qt.ApplicationModal)
            self.setMinimumWidth(420)
            lay = QtGui.QVBoxLayout(self)
            self.label = QtGui.QLabel("Starting...")
            self.label.setWordWrap(True)
            self.bar = QtGui.QProgressBar()
            self.bar.setRange(0, 1000)
            self.elapsed = QtGui.QLabel("")
            self.button = QtGui.QPushButton("Cancel")
            row = QtGui.QHBoxLayout()
            row.addWidget(self.elapsed)
            row.addStretch(1)
            row.addWidget(self.button)
            lay.addWidget(self.label)
            lay.addWidget(self.bar)
            lay.addLayout(row)
            self.job = None
            self.button.clicked.connect(self.cancel)

        def cancel(self):
            if self.job is not None and not self.job.cancelled:
                self.job.cancelled = True
                self.button.setEnabled(False)
                self.label.setText("Cancelling after the current step...")

        def reject(self):            # Esc or the window's close button: cancel, stay open
            self.cancel()

        def update_from(self, job):
            if not job.cancelled:
                self.label.setText(job.message or "Working...")
            self.bar.setValue(int(round(1000 * job.fraction)))
            self.elapsed.setText(f"{time.monotonic() - job.started:.0f} s")

    return ProgressDialog(FreeCADGui.getMainWindow())


def run(title, work, poll_ms=100):
    """Run ``work(progress)`` with a progress dialog; its return value, or its exception.

    Parameters
    ----------
    title : str, the dialog's title (the command's name)
    work : callable(progress) -> object; ``progress(fraction, message) -> bool``
    poll_ms : int, how often the dialog is refreshed

    Raises
    ------
    Whatever ``work`` raised (Cancelled after the user cancelled), in the calling thread.
    """
    global CURRENT, DIALOG
    import FreeCAD
    if CURRENT is not None:
        from invrad_wb.errors import InvradError
        raise InvradError("another invrad run is still going on; wait for it or cancel it")
    job = Job()
    CURRENT = job
    try:
        if not FreeCAD.GuiUp:
            return work(job.progress)
        from PySide import QtCore
        import FreeCADGui

        def worker():
            try:
                job.result = work(job.progress)
            except BaseException as exc:          # handed to the main thread
                job.error = exc
            finally:
                job.done = True

        dialog = _make_dialog(title)
        dialog.job = job
        DIALOG = dialog
        status = FreeCADGui.getMainWindow().statusBar()
        loop = QtCore.QEventLoop()
        timer = QtCore.QTimer()

        def poll():
            dialog.update_from(job)
            status.showMessage(f"{title}: {job.message}")
            if job.done:
                timer.stop()
                loop.quit()

        timer.timeout.connect(poll)
        dialog.show()
        thread = threading.Thread(target=worker, name=f"invrad: {title}", daemon=True)
        thread.start()
        timer.start(poll_ms)
        if not job.done:
            from invrad_wb.gui.qtcompat import run_exec
            run_exec(loop)
        thread.join()
        # a job done before the loop started (Recalculate peaks: a few ms) never let
        # poll() stop the timer: it went on firing every poll_ms into the deleted dialog
        # ("Internal C++ object already deleted", a traceback each time)
        timer.stop()
        dialog.update_from(job)
        dialog.hide()
        dialog.deleteLater()
        status.clearMessage()
        if job.error is not None:
            raise job.error
        return job.result
    finally:
        CURRENT = None
        DIALOG = None
