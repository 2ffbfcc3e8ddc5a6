"""GUI smoke run of the invrad workbench under Xvfb: every command once, with screenshots.

::

    .venv/bin/python tests/freecad/gui_smoke.py [--out out/screenshots] [--fzk] [--quick]

re-launches itself as ``xvfb-run freecad tests/freecad/gui_smoke.py`` with a private
FreeCAD user folder (its own ``user.cfg``; ``Mod/invrad`` linked to this checkout, so
FreeCAD loads ``Init.py``, ``InitGui.py`` and ``package.xml`` as it would for a user),
and inside the GUI:

1. checks that the workbench was registered at start-up and activates it (the package
   is imported only now), that every ``InvRad_*`` command, the toolbar and the menu exist;
2. models an office (4 walls, floor and ceiling slabs, an Arch Space), selects faces in the
   3D view and adds targets through the commands and the target task panel (work plane
   500 lx, side walls 150 lx, a spot on the back wall; a shaded ceiling, undone);
3. shows the targets in false colour and saves screenshots;
4. runs *Locate luminaires* from its task panel (progress dialog, worker thread), then
   *Recalculate peaks* and *Verify and report* (metrics spreadsheet, achieved illuminance
   in false colour), with screenshots; checks one undo step per action;
5. cancels a run and makes one fail, and checks that the document is unchanged and the
   message was shown;
6. with ``--fzk``, also imports the FZK-Haus IFC file through invrad's importer, applies
   ``examples/fzk_targets.json`` (a work-plane level in every room), cuts the view below
   the ceilings with a clipping plane, locates (regular ceiling rows, every level met),
   verifies, designs, and saves screenshots from above (ground floor and Galerie) and in
   isometric view.

Results: ``<out>/gui_smoke.json`` (every check with its outcome, the messages shown),
PNG screenshots of the 3D view (``saveImage``) and pictures of the task panels, the
progress dialog and the main window (``QWidget.grab``, which leaves the 3D view blank),
and ``gui_smoke.log`` (FreeCAD's output). The exit status is 0 when every check passed.
``--quick`` (the test suite, tests/freecad/test_gui.py) skips the views from inside the
room and the widget pictures; ``--fzk`` adds the FZK-Haus building (about 2 minutes).
"""
import json
import os
import sys
import time
import traceback

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
ENV_OUT = "INVRAD_SMOKE_OUT"


def _inside_freecad_gui():
    fc = sys.modules.get("FreeCAD")
    return fc is not None and getattr(fc, "GuiUp", 0) and os.environ.get(ENV_OUT)


# --------------------------------------------------------------------------- launcher
def free_display(start=None, tries=300):
    """An X display number that no X server uses: no lock file ``/tmp/.X<n>-lock`` (what
    ``xvfb-run -a`` looks at) and no listening abstract socket ``@/tmp/.X11-unix/X<n>``.
    An Xvfb in another root of this machine (the FreeCAD 1.0 chroot of ``make test``, or
    the host seen from it) leaves no lock file in this /tmp but holds the abstract socket,
    and a second Xvfb on its number fails ("server already running"). The search starts
    at a number that depends on this process, so that runs starting at once seldom probe
    the same numbers."""
    import socket
    start = 99 + os.getpid() % 400 if start is None else start
    for n in range(start, start + tries):
        if os.path.exists(f"/tmp/.X{n}-lock"):
            continue
        probe = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        try:
            probe.bind(f"\0/tmp/.X11-unix/X{n}")
        except OSError:
            continue
        finally:
            probe.close()
        return n
    return start


def invrad_tracebacks(text):
    """The Python tracebacks in FreeCAD's output ``text`` that pass through invrad's
    code (``invrad_wb/``, ``InitGui.py``, ``Init.py``), each as its last line; FreeCAD's
    own (an add-on's, the BIM workbench's) are not invrad's to fix."""
    found = []
    lines = text.splitlines()
    for i, line in enumerate(lines):
        if not line.startswith("Traceback (most recent call last)"):
            continue
        block = []
        for nxt in lines[i + 1:]:
            block.append(nxt)
            if not nxt.startswith(" "):      # the exception's own line ends the block
                break
        if any("invrad_wb/" in b or "InitGui.py" in b or "/Init.py" in b for b in block):
            found.append(block[-1] if block else line)
    return found


def relaunch(argv):
    import argparse
    import shutil
    import signal
    import subprocess
    import sysconfig
    import tempfile
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=os.path.join(ROOT, "out", "screenshots"))
    ap.add_argument("--fzk", action="store_true", help="also the FZK-Haus IFC building")
    ap.add_argument("--quick", action="store_true", help="fewer steps (test suite)")
    ap.add_argument("--native", action="store_true",
                    help="only FZK-Haus as a NativeIFC document in the BIM workbench"
                         " (FreeCAD 1.x; Smoke.run_native)")
    ap.add_argument("--timeout", type=float, default=900.0)
    ap.add_argument("-q", "--quiet", action="store_true", help="print failures only")
    ap.add_argument("--freecad", default=os.environ.get("INVRAD_FREECAD", "freecad"))
    args = ap.parse_args(argv)
    exe = shutil.which(args.freecad)
    xvfb = shutil.which("xvfb-run")
    if not exe or not xvfb:
        print(f"gui_smoke: needs {args.freecad} and xvfb-run on the PATH", file=sys.stderr)
        return 2
    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)
    result = os.path.join(out, "gui_smoke.json")
    if os.path.exists(result):
        os.remove(result)
    home = tempfile.mkdtemp(prefix="invrad-fchome-")
    os.makedirs(os.path.join(home, "Mod"))
    os.symlink(ROOT, os.path.join(home, "Mod", "invrad"))
    env = os.environ.copy()
    # $PYTHONPATH first: the FreeCAD 1.0 root puts its ifcopenshell 0.8 for NativeIFC there
    # ahead of the venv's
    paths = env.get("PYTHONPATH", "").split(os.pathsep) + [sysconfig.get_paths()["purelib"],
                                                            ROOT]
    paths = [p for i, p in enumerate(paths) if p and p not in paths[:i]]
    # the GUI clears PYTHONPATH (FreeCAD 0.20): InitGui.py reads INVRAD_SITE_PACKAGES
    env.update(PYTHONPATH=os.pathsep.join(paths), FREECAD_USER_HOME=home,
               INVRAD_SITE_PACKAGES=os.pathsep.join(paths),
               QTWEBENGINE_DISABLE_SANDBOX="1", INVRAD_SMOKE_OUT=out,
               INVRAD_SMOKE_FZK="1" if args.fzk else "",
               INVRAD_SMOKE_QUICK="1" if args.quick else "",
               INVRAD_SMOKE_NATIVE="1" if args.native else "",
               INVRAD_SMOKE_HANG_S=str(max(args.timeout - 60, 30)))
    env.pop("QT_QPA_PLATFORM", None)
    log = os.path.join(out, "gui_smoke.log")
    t0 = time.time()
    try:
        with open(log, "w") as fh:
            # own process group: a timeout kills FreeCAD and its helpers, not only xvfb-run
            proc = subprocess.Popen([xvfb, "-a", "-n", str(free_display()),
                                     "-s", "-screen 0 1280x800x24", exe,
                                     os.path.abspath(__file__)], env=env, stdout=fh,
                                    stderr=subprocess.STDOUT, start_new_session=True)
            try:
                rc = proc.wait(timeout=args.timeout)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()
                rc = 124
    finally:
        shutil.rmtree(home, ignore_errors=True)
    if not os.path.isfile(result):
        print(f"gui_smoke: FreeCAD exited ({rc}) without results; see {log}",
              file=sys.stderr)
        return 1
    with open(result) as fh:
        data = json.load(fh)
    # an exception in a Qt slot (a timer's, a button's) is printed and the GUI goes on:
    # no check inside sees it (a progress timer left running fired 470 tracebacks into a
    # deleted dialog while every check passed)
    with open(log, errors="replace") as fh:
        raised = invrad_tracebacks(fh.read())
    data["checks"].append({"name": "no Python traceback through invrad in FreeCAD's output",
                           "ok": not raised, "detail": f"{len(raised)}: {raised[:1]}"})
    with open(result, "w") as fh:
        json.dump(data, fh, indent=1)
    bad = [c for c in data["checks"] if not c["ok"]]
    for c in data["checks"]:
        if args.quiet and c["ok"]:
            continue
        print(f"{'ok  ' if c['ok'] else 'FAIL'} {c['name']}" +
              (f": {c['detail']}" if c.get("detail") and not c["ok"] else ""))
    print(f"{len(data['checks']) - len(bad)}/{len(data['checks'])} checks passed in"
          f" {time.time() - t0:.0f} s; screenshots: {', '.join(data['screenshots'])}")
    return 0 if not bad and data.get("finished") else 1


def beam_axis_length(obj):
    """Length (mm) of the beam axis drawn for ``obj`` (its Coin line's end), or -1."""
    from invrad_wb.app.fixturebody import BEAM_AXIS_NODE
    root = obj.ViewObject.RootNode
    for i in range(root.getNumChildren()):
        node = root.getChild(i)
        if node.getName() == BEAM_AXIS_NODE:
            for j in range(node.getNumChildren()):
                c = node.getChild(j)
                if c.getTypeId().getName() == "Coordinate3":
                    return -float(c.point[1][2])
    return -1.0


# --------------------------------------------------------------------------- panel widths
def clipped(form):
    """The visible widgets of a laid-out form whose text does not fit their width:
    ``[(kind, objectName, text, needed px, has px)]``. Drop-downs (their current text
    with the frame and arrow Qt adds for ``minimumContentsLength``), labels (the whole
    text, or the longest word where they wrap), buttons and check boxes, group titles,
    spin boxes (their text) and table columns (header and cells against the column's
    width, and a table that scrolls sideways)."""
    from PySide import QtGui
    out = []

    def adv(fm, text):
        return max((fm.horizontalAdvance(t) if hasattr(fm, "horizontalAdvance")
                    else fm.width(t)) for t in (text.split("\n") or [""]))

    def add(kind, w, text, need, has):
        if need > has + 1:
            out.append((kind, w.objectName(), text, int(need), int(has)))

    for w in form.findChildren(QtGui.QWidget):
        if not w.isVisibleTo(form) or not w.isVisible():
            continue
        fm = w.fontMetrics()
        if isinstance(w, QtGui.QComboBox):
            text = w.currentText()
            frame = w.sizeHint().width() - w.minimumContentsLength() * adv(fm, "x")
            if w.sizeAdjustPolicy() != QtGui.QComboBox.AdjustToMinimumContentsLengthWithIcon:
                frame = 32
            add("drop-down", w, text, frame + adv(fm, text), w.width())
        elif isinstance(w, QtGui.QLabel) and w.text() and not w.pixmap():
            text = w.text()
            if w.wordWrap():
                need = max(adv(fm, t) for t in text.split()) if text.split() else 0
            else:
                need = adv(fm, text)
            add("label", w, text, need, w.contentsRect().width())
        elif isinstance(w, (QtGui.QCheckBox, QtGui.QPushButton, QtGui.QRadioButton)):
            add("button", w, w.text(), w.sizeHint().width(), w.width())
        elif isinstance(w, QtGui.QGroupBox) and w.title():
            add("group title", w, w.title(), adv(fm, w.title()) + 16, w.width())
        elif isinstance(w, QtGui.QAbstractSpinBox):
            text = w.text()
            add("spin box", w, text, adv(fm, text) + 30, w.width())
        elif isinstance(w, QtGui.QTableWidget):
            head = w.horizontalHeader()
            for c in range(w.columnCount()):
                if w.isColumnHidden(c):
                    continue
                item = w.horizontalHeaderItem(c)
                text = item.text() if item is not None else ""
                need = max(head.sectionSizeHint(c), w.sizeHintForColumn(c))
                add("table column", w, text, need, head.sectionSize(c))
            bar = w.horizontalScrollBar()
            if bar.maximum() > 0:
                out.append(("table scrolls sideways", w.objectName(), "", bar.maximum(), 0))
    return out


# --------------------------------------------------------------------------- inside
class Smoke:
    """The steps, driven by a QTimer so that FreeCAD's event loop keeps running."""

    def __init__(self):
        self.out = os.environ[ENV_OUT]
        self.quick = bool(os.environ.get("INVRAD_SMOKE_QUICK"))
        self.fzk = bool(os.environ.get("INVRAD_SMOKE_FZK"))
        self.native = bool(os.environ.get("INVRAD_SMOKE_NATIVE"))
        self.checks = []
        self.shots = []
        self.finished = False
        self.steps = self.run()
        self.timer = None
        self.polling = False

    # ----------------------------------------------------------------- bookkeeping
    def check(self, name, ok, detail=""):
        self.checks.append({"name": name, "ok": bool(ok), "detail": str(detail)})
        self.save()
        return ok

    def save(self):
        log = []
        mod = sys.modules.get("invrad_wb.gui.messages")
        if mod is not None:
            log = [list(m) for m in mod.LOG]
        with open(os.path.join(self.out, "gui_smoke.json"), "w") as fh:
            json.dump({"checks": self.checks, "screenshots": self.shots,
                       "finished": self.finished, "messages": log}, fh, indent=1)

    def shot(self, name, width=1000, height=750):
        import FreeCADGui
        path = os.path.join(self.out, name + ".png")
        FreeCADGui.updateGui()
        FreeCADGui.activeDocument().activeView().saveImage(path, width, height, "White")
        self.shots.append(os.path.relpath(path, self.out))
        self.check(f"screenshot {name}", self.drawn(path) > 0.05, path)

    @staticmethod
    def drawn(path, step=8):
        """Fraction of (sampled) pixels that are not the white background: a blank or
        failed view gives 0 (the file's size said little: FreeCAD 1.0's flat shading
        compresses a full plan into 9 kB)."""
        from PySide import QtGui
        img = QtGui.QImage(path)
        if img.isNull():
            return 0.0
        n = hits = 0
        for y in range(0, img.height(), step):
            for x in range(0, img.width(), step):
                n += 1
                hits += (img.pixel(x, y) & 0xFFFFFF) != 0xFFFFFF
        return hits / max(n, 1)

    @staticmethod
    def report_view():
        """The text of FreeCAD's report view (None if it cannot be found)."""
        import FreeCADGui
        from PySide import QtGui
        mw = FreeCADGui.getMainWindow()
        dock = mw.findChild(QtGui.QDockWidget, "Report view")
        if dock is None:
            return None
        edit = dock.widget()
        if not hasattr(edit, "toPlainText"):
            edit = dock.findChild(QtGui.QTextEdit)
        return edit.toPlainText() if edit is not None else None

    def grab(self, widget, name):
        """A picture of a Qt widget (task panel, dialog, main window; not the 3D view)."""
        path = os.path.join(self.out, name + ".png")
        ok = widget is not None and widget.grab().save(path)
        if ok:
            self.shots.append(os.path.relpath(path, self.out))
        self.check(f"widget picture {name}", ok, path)

    def fits(self, panel, name):
        """The task panel fits FreeCAD's default task view (the combo view of a 1280 x 800
        window, where the panel is shown now) and a 1280 x 800 screen: its minimum width
        fits the task view, the task view has nothing to scroll sideways, and no text in
        it is cut (:func:`clipped`: a drop-down, label, button, group title or table
        column narrower than its text). The earlier check read only the form's minimum
        size and the scroll bar's visibility: tables and drop-downs report small minimum
        sizes and cut their text instead (the design panel's "Downlight 100...", "be (EN",
        "Custom En"), and it ran before the task view had laid the panel out."""
        import FreeCADGui
        from PySide import QtGui
        for _ in range(3):
            QtGui.QApplication.processEvents()
        hint, least = panel.form.sizeHint(), panel.form.minimumSizeHint()
        # the task view, found from the main window: walking up from the form with
        # parentWidget() left its Python wrapper "already deleted" (PySide ownership)
        areas = [a for a in FreeCADGui.getMainWindow().findChildren(QtGui.QScrollArea)
                 if a.isAncestorOf(panel.form)]
        area = areas[-1] if areas else None
        view_w = area.viewport().width() if area is not None else None
        sideways = area is not None and area.horizontalScrollBar().maximum() > 0
        cut = clipped(panel.form)
        widest = sorted(((w.minimumSizeHint().width(), w.objectName() or type(w).__name__)
                         for w in panel.form.findChildren(QtGui.QWidget)
                         if w.isVisibleTo(panel.form)), reverse=True)[:4]
        self.check(f"{name} panel fits the default task view ({view_w} px):"
                   " nothing cut, no sideways scrolling",
                   area is not None and least.width() <= view_w
                   and panel.form.width() <= view_w and not sideways and not cut,
                   {"hint": (hint.width(), hint.height()),
                    "minimum": (least.width(), least.height()),
                    "form": panel.form.width(), "sideways": sideways,
                    "task view": view_w, "cut": cut, "widest": widest})

    def tick(self):
        from PySide import QtCore
        try:
            wait = next(self.steps)
        except StopIteration:
            self.finish()
            return
        except Exception:
            self.check("smoke script ran to the end", False, traceback.format_exc())
            self.finish()
            return
        self.waiting = wait
        self.deadline = time.time() + 300
        self.polling = True
        if self.timer is None:
            # persistent timers owned here: a chain of QTimer.singleShot calls died when a
            # pending one went with the progress dialog's nested event loop (after Design)
            self.timer = QtCore.QTimer()
            self.timer.timeout.connect(self.poll)
            self.timer.start(100)
            self.next_step = QtCore.QTimer()
            self.next_step.setSingleShot(True)
            self.next_step.timeout.connect(self.tick)

    def poll(self):
        if not self.polling:
            return
        ok = True
        if callable(self.waiting):
            try:
                ok = self.waiting()
            except Exception:
                ok = True
        if ok or time.time() > self.deadline:
            if not ok:
                self.check("wait finished in time", False, str(self.waiting))
            self.polling = False
            self.next_step.start(0)      # after the events already queued, as before

    #: What the OpenCL compiler says (PoCL's clang: "AVX vector argument ... changes the
    #: ABI", "1 warning generated."; pyopencl's CompilerWarning): never for the user.
    COMPILER_WORDS = ("changes the ABI", "warning generated", "warnings generated",
                      "CompilerWarning", "Build on <pyopencl")

    def finish(self):
        text = self.report_view()
        said = [l for l in (text or "").splitlines()
                if any(w in l for w in self.COMPILER_WORDS)]
        self.check("no compiler warning in the report view after every run",
                   text is not None and not said, said[:5] if text is not None else text)
        self.finished = True
        self.save()
        sys.stdout.flush()
        os._exit(0)

    # ----------------------------------------------------------------- helpers
    @staticmethod
    def said(title, before):
        """A wait condition: a message of the command ``title`` after LOG[before]."""
        from invrad_wb.gui import messages
        return lambda: any(m[1] == title for m in messages.LOG[before:])

    @staticmethod
    def idle():
        from invrad_wb.gui import progress
        return not progress.busy()

    def select(self, obj, subs):
        import FreeCADGui
        FreeCADGui.Selection.clearSelection()
        for s in subs:
            FreeCADGui.Selection.addSelection(obj, s)

    def plan_cut(self, doc):
        """FZK-Haus: a plan cut just below the ground floor's ceilings (2.48 m) instead of
        hiding the upper storey (FreeCAD 0.20 keeps Arch components inside a BuildingPart
        visible); returns the active view."""
        import FreeCAD
        import FreeCADGui
        view = FreeCADGui.getDocument(doc.Name).activeView()
        view.toggleClippingPlane(1, False, True,
                                 FreeCAD.Placement(FreeCAD.Vector(0, 0, 2480),
                                                   FreeCAD.Rotation()))
        return view

    def upper_floor_shot(self, doc, view, name):
        """FZK-Haus's upper storey (the Galerie) from above in a storey view
        (display.storey_view: clipping planes just under its ceilings, the roof's slopes;
        hiding the roof did not do on 0.20, whose BuildingParts draw their elements, nor
        on NativeIFC), then back at the ground floor's plan cut."""
        from invrad_wb.app import rooms
        from invrad_wb.gui import display
        gal = [sp for sp in rooms.find_spaces(doc) if rooms.room_name(sp) == "Galerie"]
        if not gal:
            return
        view.toggleClippingPlane(0)          # the ground floor's plan cut off
        n = display.storey_view(doc, gal)
        view.viewTop()
        self.frame(view)
        shown = [lab for lab, _ in display.shown_labels(doc)]
        self.check(f"{name}: the Galerie under its roof's slopes ({n} planes), only its"
                   " name shown", n >= 1 and shown == ["Galerie"], (n, shown))
        self.shot(name)
        self.view_iso()
        self.shot(name.replace("_top", "_iso"))
        display.clear_storey_view(doc)
        self.plan_cut(doc)

    def frame(self, view=None):
        """The view framed on the active document's rooms, right of the legend, for the
        screenshots' 1000 x 750 (display.frame_rooms; fitAll framed the site and left
        half of every picture white)."""
        import FreeCAD
        import FreeCADGui
        from invrad_wb.gui import display
        view = view or FreeCADGui.activeDocument().activeView()
        display.frame_rooms(FreeCAD.ActiveDocument, view, aspect=1000 / 750)

    def view_iso(self, hide=()):
        import FreeCADGui
        for o in hide:
            o.Visibility = False
        v = FreeCADGui.activeDocument().activeView()
        v.setCameraType("Orthographic")
        v.viewIsometric()
        self.frame(v)

    def view_inside(self, eye, target):
        import FreeCADGui
        from pivy import coin
        v = FreeCADGui.activeDocument().activeView()
        v.setCameraType("Perspective")
        cam = v.getCameraNode()
        cam.position.setValue(coin.SbVec3f(*eye))
        cam.pointAt(coin.SbVec3f(*target), coin.SbVec3f(0, 0, 1))
        cam.heightAngle.setValue(1.0)
        cam.nearDistance.setValue(10.0)
        cam.farDistance.setValue(50000.0)

    # ----------------------------------------------------------------- the run
    def run(self):
        import FreeCAD
        import FreeCADGui
        from PySide import QtGui
        sys.path.insert(0, HERE)
        FreeCADGui.getMainWindow().resize(1280, 800)

        # 1. workbench
        wbs = FreeCADGui.listWorkbenches()
        text = self.report_view()
        self.check("no start-up error in the report view",
                   text is not None and "During initialization the error" not in text
                   and "InitGui.py" not in text,
                   text if text is None else
                   [l for l in text.splitlines() if "During initialization" in l])
        self.check("InitGui registered InvRadWorkbench", "InvRadWorkbench" in wbs)
        self.check("Init.py registered invrad's IFC importer",
                   "invrad_wb.app.ifcimport" in FreeCAD.getImportType("ifc"))
        before = set(sys.modules)
        # (but the beam-axis redrawing of InitGui.py's observer, light, on a first document)
        self.check("the package is not imported before activation",
                   not any(m.startswith("invrad_wb.gui") and m not in
                           ("invrad_wb.gui", "invrad_wb.gui.beamaxis") for m in before),
                   sorted(m for m in before if m.startswith("invrad_wb")))
        FreeCADGui.activateWorkbench("InvRadWorkbench")
        yield None
        from invrad_wb.gui import commands, designpanel, display, messages, runner, taskpanel
        from invrad_wb.gui import progress
        from invrad_wb.app import document, fixtures, targets
        messages.QUIET = True
        self.check("workbench active",
                   FreeCADGui.activeWorkbench().__class__.__name__ == "InvRadWorkbench")
        wb_icon = FreeCADGui.getWorkbench("InvRadWorkbench").Icon
        self.check("workbench icon exists", os.path.isfile(wb_icon), wb_icon)
        cmds = FreeCADGui.listCommands()
        missing = [c.NAME for c in commands.COMMANDS if c.NAME not in cmds]
        self.check("all InvRad_ commands registered", not missing, missing)
        mw = FreeCADGui.getMainWindow()
        tb = [t for t in mw.findChildren(QtGui.QToolBar) if t.windowTitle() == "InvRad"]
        self.check("InvRad toolbar", bool(tb) and len(tb[0].actions()) >= 6,
                   [a.text() for a in tb[0].actions()] if tb else "none")
        menus = [a.text().replace("&", "") for a in mw.menuBar().actions()]
        self.check("InvRad menu", "InvRad" in menus, menus)
        if self.native:        # --native: only the NativeIFC building (run_native)
            yield from self.run_native()
            return

        # 2. an office and its targets, through the commands
        from fctest import make_walled_room
        doc = FreeCAD.newDocument("Office")
        space = make_walled_room(doc, size=(5.0, 4.0, 2.8), label="Office")
        FreeCADGui.SendMsgToActiveView("ViewFit")
        ceiling = [o for o in doc.Objects if o.TypeId == "Part::FeaturePython"
                   and getattr(o, "IfcType", "") == "Slab"
                   and o.Shape.BoundBox.ZMin > 2700]
        floor_faces = targets._faces_arg(space, "floor")
        wall_faces = targets._faces_arg(space, "walls")
        walls_by_y = sorted(wall_faces, key=lambda f: -space.Shape.getElement(f)
                            .CenterOfMass.y)
        back_wall = walls_by_y[0]                         # the wall at the largest y
        side_walls = [f for f in wall_faces if f != back_wall]
        # work plane: select the room itself
        self.select(space, [])
        FreeCADGui.Selection.addSelection(space)
        FreeCADGui.runCommand("InvRad_SetTarget")
        yield None
        panel = taskpanel.ACTIVE
        self.check("target panel opens for a room (work plane)",
                   panel is not None and panel.kind() == "WorkPlane")
        self.fits(panel, "target")
        panel.widget("lux").setValue(500.0)
        n0 = doc.UndoCount
        panel.accept()
        yield None
        wp = targets.work_plane_target(space)
        self.check("work plane target 500 lx", wp is not None and wp.Lux == 500.0)
        self.check("one undo step per target", doc.UndoCount == n0 + 1,
                   (n0, doc.UndoCount))
        # walls 150 lx: select wall faces of the WALL object (mapped to the Space)
        wall_obj = [o for o in doc.Objects if getattr(o, "IfcType", "") == "Wall"][0]
        from invrad_wb.gui import selection
        wall_subs = []
        for i, f in enumerate(wall_obj.Shape.Faces):
            if selection.matching_space_faces(f, [space]):
                wall_subs.append(f"Face{i + 1}")
        self.select(wall_obj, wall_subs)
        groups, _ = selection.room_faces()
        self.check("wall faces map to the room's faces",
                   len(groups) == 1 and sorted(groups[0][1]) == sorted(wall_faces),
                   (groups[0][1] if groups else None, wall_faces))
        # uniform on the side walls (selected on the Space)
        self.select(space, side_walls)
        FreeCADGui.runCommand("InvRad_SetTarget")
        yield None
        panel = taskpanel.ACTIVE
        taskpanel.set_value(panel.widget("kind"), "Uniform")
        panel.widget("lux").setValue(150.0)
        panel.accept()
        yield None
        # a spot on the back wall, centre picked on it
        c = space.Shape.getElement(back_wall).CenterOfMass
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.Selection.addSelection(doc.Name, space.Name, back_wall,
                                          c.x + 600, c.y, c.z + 300)
        FreeCADGui.runCommand("InvRad_SetTarget")
        yield None
        panel = taskpanel.ACTIVE
        taskpanel.set_value(panel.widget("kind"), "Spot")
        self.fits(panel, "spot target")
        if not self.quick:
            QtGui.QApplication.processEvents()
            self.grab(panel.form, "panel_target_spot")
        self.check("spot centre from the picked point",
                   abs(panel.widget("centre_x").value() - (c.x + 600) / 1000) < 1e-3,
                   panel.widget("centre_x").value())
        # an accent: brighter than the general lighting gives that wall (a 400 lx peak
        # there is what the office's rows give a wall anyway: no accent to design)
        panel.widget("lux").setValue(800.0)
        panel.widget("radius_m").setValue(0.8)
        panel.accept()
        yield None
        kinds = sorted(t.Kind for t in targets.room_targets(space))
        self.check("targets added through the panel", kinds == ["Spot", "Uniform",
                                                                "WorkPlane"], kinds)
        # shade on the ceiling, shown, then undone (the office keeps a lit ceiling)
        self.select(space, targets._faces_arg(space, "ceiling"))
        n0 = doc.UndoCount
        FreeCADGui.runCommand("InvRad_MarkShade")
        yield None
        self.check("Mark shade adds a shade target in one undo step",
                   any(t.Kind == "Shade" for t in targets.room_targets(space))
                   and doc.UndoCount == n0 + 1)
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.runCommand("InvRad_ToggleTargets")
        yield None
        if not self.quick:
            self.view_inside((4500, 400, 1650), (1500, 3800, 1200))
            self.shot("office_shade_inside")
        FreeCADGui.runCommand("InvRad_ToggleTargets")
        yield None
        doc.undo()
        yield None
        self.check("undo removes the shade target",
                   not any(t.Kind == "Shade" for t in targets.room_targets(space)))

        # 3. false colour
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.runCommand("InvRad_ToggleTargets")
        yield None
        st = display.state(doc)
        self.check("targets shown in false colour", st is not None
                   and st["mode"] == "targets" and st["triangles"] > 1000, st)
        self.check("display adds no document object",
                   not any("InvRad" in o.Name and o.TypeId.startswith("Mesh")
                           for o in doc.Objects))
        self.view_iso(hide=ceiling)
        self.shot("office_targets")
        if not self.quick:
            self.view_inside((4500, 400, 1650), (1500, 3800, 900))
            self.shot("office_targets_inside")
            self.view_iso()

        # 4. locate through its task panel
        FreeCADGui.runCommand("InvRad_Locate")
        yield None
        panel = taskpanel.ACTIVE
        self.check("locate panel has every setting",
                   isinstance(panel, taskpanel.LocatePanel))
        adv = panel.widget("show_advanced")
        short = panel.form.sizeHint().height()
        self.check("the method's settings start hidden, the panel is short",
                   not adv.isChecked() and not panel.widget("threshold").isVisibleTo(
                       panel.form) and short < 700, short)
        self.fits(panel, "locate")
        if not self.quick:
            self.grab(panel.form, "panel_locate")
            self.grab(FreeCADGui.getMainWindow(), "main_window")
        adv.setChecked(True)
        self.check("'Advanced' shows them", panel.widget("threshold").isVisibleTo(panel.form))
        self.fits(panel, "locate, advanced settings shown,")
        if not self.quick:
            QtGui.QApplication.processEvents()
            self.grab(panel.form, "panel_locate_settings")
        adv.setChecked(False)
        panel.widget("flux_lm").setValue(2500.0)
        panel.widget("resolution_m").setValue(0.3)
        n0 = doc.UndoCount
        snap = document.snapshot(doc)
        shown = display._overlay(doc)
        self.check("locate panel accepted", panel.accept())
        yield lambda: runner.stored(doc) is not None or messages.LOG and \
            messages.LOG[-1][1] == "Locate luminaires"
        yield self.idle
        st = runner.stored(doc)
        self.check("locate stored its result", st is not None,
                   messages.LOG[-3:] if messages.LOG else "")
        if st is None:
            return
        fx = fixtures.room_fixtures(space)
        self.check("fixtures inserted", len(fx) == len(st.result.luminaires) > 0, len(fx))
        self.check("fixtures are Light Fixtures with flux",
                   all(f.IfcType == "Light Fixture" and f.LuminousFlux == 2500.0
                       for f in fx))
        self.check("locate is one undo step", doc.UndoCount == n0 + 1, (n0, doc.UndoCount))
        yield lambda: not commands._observer._pending
        now = display._overlay(doc)
        self.check("the targets' display is kept after Locate (the fixtures change the"
                   " room's contents, not its targets), its names placed again",
                   shown is not None and now is not None and now["node"] is shown["node"]
                   and now["label_vis"] is not None, (shown is None, now is None))
        self.check("the flux was stored in the parameters",
                   __import__("invrad_wb.gui.params", fromlist=["x"]).load_run()[
                       "flux_lm"] == 2500.0)
        self.view_iso()
        self.shot("office_located")
        if not self.quick:
            self.view_inside((4500, 400, 1650), (1500, 3800, 1200))
            self.shot("office_located_inside")
            self.view_iso()
        # undo/redo of the locate transaction
        doc.undo()
        self.check("undo removes the fixtures", document.snapshot(doc) == snap)
        doc.redo()
        self.check("redo brings them back", len(fixtures.room_fixtures(space)) == len(fx))

        # recalculate peaks
        FreeCADGui.runCommand("InvRad_Repeak")
        yield None
        panel = taskpanel.ACTIVE
        self.check("repeak panel", isinstance(panel, taskpanel.RepeakPanel))
        self.fits(panel, "repeak")
        panel.widget("threshold").setValue(80.0)
        n0 = doc.UndoCount
        before = len(messages.LOG)
        panel.accept()
        # the panel starts the command from the event loop: wait for its message (FreeCAD
        # 1.0 ran the checks before the deferred command had started)
        yield self.said("Recalculate peaks", before)
        yield self.idle
        self.check("repeak replaced the fixtures in one undo step",
                   doc.UndoCount == n0 + 1 and len(fixtures.room_fixtures(space))
                   == len(runner.stored(doc).result.luminaires),
                   (n0, doc.UndoCount, messages.LOG[-1:]))
        self.check("repeak used the new threshold",
                   runner.stored(doc).result.locate_result.settings["threshold"] == 80.0)

        # verify and report
        n0 = doc.UndoCount
        report = os.path.join(self.out, "office_report")
        runner_params = __import__("invrad_wb.gui.params", fromlist=["x"])
        runner_params.save_run({"report_dir": self.out})
        before = len(messages.LOG)
        FreeCADGui.runCommand("InvRad_Verify")
        yield self.said("Verify and report", before)
        yield self.idle
        st = runner.stored(doc)
        sheet = doc.getObject("InvRadReport")
        self.check("verify wrote the metrics spreadsheet", sheet is not None
                   and sheet.get("A2") == "Office", messages.LOG[-1:])
        self.check("verify is one undo step", doc.UndoCount == n0 + 1, (n0, doc.UndoCount))
        report = runner.default_report_dir(doc, "verify")
        self.check("verify wrote summary.json into its own report folder",
                   report == os.path.join(self.out, doc.Name, "verify")
                   and os.path.isfile(os.path.join(report, "summary.json")), report)
        self.verify_report = os.path.join(report, "summary.json")
        with open(self.verify_report, "rb") as fh:
            self.verify_summary = fh.read()
        self.check("achieved illuminance shown", display.mode(doc) == "achieved")
        self.view_iso(hide=ceiling)
        self.shot("office_achieved")
        st = display.state(doc)
        FreeCADGui.runCommand("InvRad_ToggleTargets")
        yield None
        self.check("toggle switches back to targets", display.mode(doc) == "targets")
        self.check("targets and achieved light share one lux scale",
                   st is not None and display.state(doc)["vmax"] == st["vmax"],
                   (st, display.state(doc)))
        self.check("the spot's edge is drawn finer than the room mesh",
                   display.state(doc)["triangles"] > len(display.last_achieved(doc)[0]
                                                         .scene.faces),
                   display.state(doc))
        FreeCADGui.runCommand("InvRad_ToggleDeviation")
        yield None
        self.check("deviation from the targets shown", display.mode(doc) == "deviation")
        self.shot("office_deviation")
        FreeCADGui.runCommand("InvRad_ToggleDeviation")
        yield None
        self.check("deviation toggles back to the achieved light",
                   display.mode(doc) == "achieved")
        FreeCADGui.runCommand("InvRad_ToggleTargets")
        yield None
        # the shown targets follow document changes (and undo)
        # (the scale: the largest target and half as much again, rounded up)
        # (the 800 lx spot is the largest target: 1500 lx; a 2000 lx work plane: 3000 lx,
        # and back: the scale is kept while it is no more than a step too high)
        targets.set_work_plane(space, 2000.0)
        yield lambda: display.state(doc)["vmax"] == 3000.0
        self.check("display follows a changed target", display.state(doc)["vmax"] == 3000.0,
                   display.state(doc))
        doc.undo()
        yield lambda: display.state(doc)["vmax"] == 1500.0
        self.check("display follows undo", display.state(doc)["vmax"] == 1500.0,
                   display.state(doc))

        # IFC export leaves display and sheet out
        from invrad_wb.app import ifcexport
        ifc = os.path.join(self.out, "office.ifc")
        try:
            ifcexport.export_ifc(doc, ifc)
            with open(ifc, encoding="utf-8", errors="replace") as fh:
                text = fh.read()
            self.check("IFC export has the fixtures and no display/report objects",
                       text.count("IFCLIGHTFIXTURE(") == len(fixtures.room_fixtures(space))
                       and "InvRadReport" not in text and "Lighting report" not in text
                       and "InvRadFalseColour" not in text)
        except Exception as exc:
            self.check("IFC export", False, exc)

        # 5. cancel and failure leave the document unchanged
        snap = document.snapshot(doc)
        n0 = doc.UndoCount

        def press_cancel():
            if progress.DIALOG is not None and progress.CURRENT.fraction > 0.15:
                if not self.quick:
                    self.grab(progress.DIALOG, "progress_dialog")
                self.check("the progress names the room", progress.CURRENT.message
                           .startswith("Office:"), progress.CURRENT.message)
                progress.DIALOG.cancel()
                return True
            return False
        FreeCADGui.runCommand("InvRad_Locate")
        yield None
        taskpanel.ACTIVE.accept()
        yield lambda: progress.busy()
        yield press_cancel
        yield self.idle
        last = messages.LOG[-1] if messages.LOG else ("", "", "")
        self.check("cancel: message shown", last[0] == "warning" and "cancelled" in last[2]
                   and "not changed" in last[2], last)
        self.check("cancel: document unchanged",
                   document.snapshot(doc) == snap and doc.UndoCount == n0)
        targets.add_texture_target(space, floor_faces[0], "/nonexistent/lux.exr")
        snap = document.snapshot(doc)
        n0 = doc.UndoCount
        FreeCADGui.doCommand("import invrad_wb.gui.runner")
        FreeCADGui.doCommand(f"invrad_wb.gui.runner.locate(App.getDocument({doc.Name!r}))")
        yield self.idle
        last = messages.LOG[-1] if messages.LOG else ("", "", "")
        self.check("failure: error message names the target", last[0] == "error"
                   and "/nonexistent/lux.exr" in last[2], last)
        self.check("failure: document unchanged",
                   document.snapshot(doc) == snap and doc.UndoCount == n0)
        doc.undo()

        # settings persist: the panel shows what was stored
        FreeCADGui.runCommand("InvRad_Settings")
        yield None
        panel = taskpanel.ACTIVE
        self.check("settings panel shows stored flux",
                   panel.widget("flux_lm").value() == 2500.0)
        panel.reject()
        yield None

        # 6. design from requirements through its task panel
        yield from self.run_design(doc, space, ceiling)

        # 7. an aimed spot's beam axis, drawn again where FreeCAD forgets it
        yield from self.run_aimed()

        if self.fzk:
            yield from self.run_fzk()

    def run_aimed(self):
        """An aimed spot's beam axis (a Coin node, not saved): drawn on insert, again after
        undo and redo and after the document is saved, closed and opened (the observer
        of InitGui.py, invrad_wb/gui/beamaxis.py)."""
        import FreeCAD
        import numpy as np
        from fctest import make_walled_room
        from invrad_wb.app import fixtures
        from invrad_wb.app.fixturebody import has_beam_axis
        from invrad_wb.core.model.aiming import aim_from_tilt_pan, aimed_c0
        from invrad_wb.core.model.luminaires import Luminaire
        doc = FreeCAD.newDocument("AimedSpot")
        doc.UndoMode = 1
        space = make_walled_room(doc)
        mount = np.array([0.0, 0.0, -1.0])
        aim = aim_from_tilt_pan(mount, 40.0, 120.0)
        spot = Luminaire([2.0, 1.5, 2.7], aim, 700.0, c0=aimed_c0(mount, aim),
                         extra={"tilt_deg": 40.0, "pan_deg": 120.0})
        (fx,) = fixtures.insert_fixtures(doc, [(space, [spot])])
        name, sname = fx.Name, space.Name
        self.check("aimed spot: beam axis drawn", has_beam_axis(fx))
        doc.undo()
        doc.redo()
        yield None
        fx = doc.getObject(name)
        self.check("aimed spot: beam axis drawn again after undo and redo",
                   fx is not None and has_beam_axis(fx))
        path = os.path.join(self.out, "aimed_spot.FCStd")
        doc.saveAs(path)
        FreeCAD.closeDocument(doc.Name)
        doc = FreeCAD.openDocument(path)
        yield None
        fx = fixtures.room_fixtures(doc.getObject(sname))
        self.check("aimed spot: beam axis drawn again after the document is reopened",
                   len(fx) == 1 and has_beam_axis(fx[0]) and fx[0].Tilt == 40.0)
        for o in doc.Objects:
            if getattr(o, "IfcType", "") in ("Wall", "Slab") and o.ViewObject is not None:
                o.ViewObject.Transparency = 75
        self.view_iso()
        self.shot("aimed_spot_reopened")
        if fx:
            # moved 1 m towards the lit wall (as a drag does, one transaction): the aim
            # point is where the beam now meets the room, the drawn axis ends there; undo
            # puts both back
            fx = fx[0]
            aim0, pl0 = FreeCAD.Vector(fx.AimPoint), FreeCAD.Placement(fx.Placement)
            pl = FreeCAD.Placement(pl0)
            d = pl.Rotation.multVec(FreeCAD.Vector(0, 0, -1))
            pl.Base = pl.Base + FreeCAD.Vector(d.x, d.y, 0).normalize() * 1000.0
            doc.openTransaction("Move")
            fx.Placement = pl
            doc.commitTransaction()
            yield None
            moved = FreeCAD.Vector(fx.AimPoint)
            self.check("aimed spot moved 1 m: its aim point follows the beam and the axis"
                       " is drawn to it", (moved - aim0).Length > 100.0
                       and abs(beam_axis_length(fx) - (moved - pl.Base).Length) < 1.0
                       and abs(fx.Tilt - 40.0) < 1e-6,
                       (aim0, moved, beam_axis_length(fx), fx.Tilt, fx.Pan))
            self.shot("aimed_spot_moved")
            doc.undo()
            yield None
            self.check("aimed spot move undone: placement, aim point and axis back",
                       (fx.Placement.Base - pl0.Base).Length < 1e-6
                       and (fx.AimPoint - aim0).Length < 1e-6
                       and abs(beam_axis_length(fx) - (aim0 - pl0.Base).Length) < 1.0,
                       (fx.Placement, fx.AimPoint, beam_axis_length(fx)))
        FreeCAD.closeDocument(doc.Name)

    def run_design(self, doc, space, ceiling):
        import FreeCADGui
        from PySide import QtGui
        from invrad_wb.app import fixtures
        from invrad_wb.gui import designpanel, messages, runner, taskpanel
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.runCommand("InvRad_Design")
        yield None
        panel = taskpanel.ACTIVE
        self.check("design panel opens", isinstance(panel, designpanel.DesignPanel))
        if not isinstance(panel, designpanel.DesignPanel):
            return
        # FreeCAD's own combo view width (about 260 px in a 1280 x 800 window on 1.0):
        # the panel is laid out for it (catalogue details in a form, fields under their
        # labels), not the dock widened (resizeDocks from the panel crashed the run)
        self.fits(panel, "design")
        req = panel.widget("requirements")
        self.check("design panel lists the room", req.rowCount() == 1
                   and req.item(0, 0).text() == "Office",
                   [req.item(r, 0).text() for r in range(req.rowCount())])
        self.check("its work-plane target is the starting requirement",
                   req.item(0, 2).text() == "500")
        self.check("the default catalogue is shown",
                   panel.widget("catalogue").rowCount() == 3)
        req.selectRow(0)
        taskpanel.set_value(panel.widget("room_type"), "office")
        self.check("a room type shows its EN 12464-1 values",
                   (req.item(0, 2).text(), req.item(0, 3).text()) == ("500", "0.6"),
                   (req.item(0, 2).text(), req.item(0, 3).text()))
        panel.widget("resolution_m").setValue(0.3)
        if not self.quick:
            self.grab(panel.form, "panel_design")
            self.grab(FreeCADGui.getMainWindow(), "main_window_design")
        n0 = doc.UndoCount
        spec, run = panel.check()
        self.check("design panel gives a spec the core accepts",
                   spec["rooms"]["Office"]["room_type"] == "office", spec["rooms"])
        self.check("the catalogue keeps what the table does not show (luminous size)",
                   [e.get("radius_m") for e in spec["catalogue"]] == [0.3] * 3,
                   spec["catalogue"])
        before = len(messages.LOG)
        self.check("design panel accepted", panel.accept())
        yield lambda: any(m[1] == "Design lighting" for m in messages.LOG[before:])
        yield self.idle
        last = ([m for m in messages.LOG[before:] if m[1] == "Design lighting"]
                or [("", "", "")])[-1]
        self.check("no other message during the design", len(messages.LOG) == before + 1,
                   messages.LOG[before:])
        fx = fixtures.room_fixtures(space)
        self.check("design inserted fixtures of catalogue types in one undo step",
                   last[0] == "info" and fx and doc.UndoCount == n0 + 1
                   and all("Downlight" in f.Description or "Panel" in f.Description
                           for f in fx),
                   (last, len(fx), n0, doc.UndoCount, [f.Description for f in fx]))
        self.check("the office meets its requirement", "meets its requirements" in last[2],
                   last[2])
        design_dir = runner.default_report_dir(doc, "design")
        with open(self.verify_report, "rb") as fh:
            kept = fh.read() == self.verify_summary
        self.check("design wrote its report into a folder of its own; the verification"
                   " report is untouched",
                   os.path.isfile(os.path.join(design_dir, "summary.json")) and kept
                   and os.path.dirname(self.verify_report) != design_dir,
                   (design_dir, os.listdir(os.path.dirname(design_dir)), kept))
        self.view_iso(hide=ceiling)
        self.shot("office_designed")
        yield from self.set_task_areas(doc, space)

    def set_task_areas(self, doc, space):
        """The architect draws the desks' area on the plan (a Draft rectangle at the work
        plane), makes it the room's task area with the toolbar command, and the design
        panel's spec carries it (the design with task areas is the core's: tested there)."""
        import Draft
        import FreeCAD
        import FreeCADGui
        from invrad_wb.app import targets
        from invrad_wb.gui import designpanel, taskpanel
        bb = space.Shape.BoundBox
        desks = Draft.makeRectangle(length=2500.0, height=2000.0, placement=FreeCAD.Placement(
            FreeCAD.Vector(bb.XMin + 1000.0, bb.YMin + 1000.0, bb.ZMin + 800.0),
            FreeCAD.Rotation()))
        desks.Label = "Desks 1.2"          # a label with a dot, as architects name things
        doc.recompute()
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.Selection.addSelection(space)
        FreeCADGui.Selection.addSelection(desks)
        n0 = doc.UndoCount
        FreeCADGui.runCommand("InvRad_TaskAreas")
        yield None
        wp = targets.work_plane_target(space)
        areas = targets.task_areas_m(wp) if wp is not None else []
        self.check("Set task areas makes the drawn rectangle the room's task area, in"
                   " metres, in one undo step",
                   [a["name"] for a in areas] == ["Desks 1.2"] and doc.UndoCount == n0 + 1
                   and abs(min(p[0] for p in areas[0]["polygon"])
                           - (bb.XMin + 1000.0) / 1000.0) < 1e-6,
                   (areas, n0, doc.UndoCount))
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.runCommand("InvRad_Design")
        yield None
        panel = taskpanel.ACTIVE
        ok = isinstance(panel, designpanel.DesignPanel)
        spec = panel.check()[0] if ok else {}
        self.check("the design panel's spec carries the drawn task area, accepted by the"
                   " core's spec reader",
                   ok and [a["name"] for a in spec["rooms"]["Office"]["work_plane"]
                           .get("task_areas", [])] == ["Desks 1.2"],
                   spec.get("rooms"))
        if ok:
            panel.reject()
        yield None
        doc.undo()
        self.check("undo clears the task areas", not targets.task_areas_m(wp), wp.TaskAreas)

    def run_fzk(self):
        import FreeCADGui
        import numpy as np
        from fctest import FZK
        from invrad_wb.app import fixtures, ifcimport, rooms, targets
        from invrad_wb.gui import display, messages, runner
        if not os.path.isfile(FZK):
            self.check("FZK-Haus file", False, FZK)
            return
        t0 = time.time()
        doc = ifcimport.open(FZK)
        FreeCADGui.SendMsgToActiveView("ViewFit")
        yield None
        spaces = rooms.find_spaces(doc)
        self.check("FZK-Haus: 7 rooms imported", len(spaces) == 7,
                   f"{len(spaces)} in {time.time() - t0:.0f} s")
        # an architect's own targets: a work-plane level in every room, nothing on the
        # walls (examples/fzk_targets.json, as the README's freecad command)
        opts = targets.apply_targets_file(doc, os.path.join(ROOT, "examples",
                                                            "fzk_targets.json"))
        names = [rooms.room_name(sp) for sp in spaces]
        FreeCADGui.runCommand("InvRad_ToggleTargets")
        yield None
        view = self.plan_cut(doc)
        self.view_iso()
        view.viewTop()
        self.frame(view)
        self.shot("fzk_targets")
        FreeCADGui.doCommand("import invrad_wb.gui.runner")
        t1 = time.time()
        FreeCADGui.doCommand(f"invrad_wb.gui.runner.locate(App.getDocument({doc.Name!r}),"
                             f" run={{'flux_lm': {float(opts['flux_lm'])!r},"
                             f" 'resolution_m': {float(opts['resolution_m'])!r}}})")
        yield self.idle
        n = len(fixtures.all_fixtures(doc))
        st = runner.stored(doc)
        last = messages.LOG[-1] if messages.LOG else ("", "", "")
        self.check("FZK-Haus: fixtures inserted", n > 0 and st is not None, last)
        print(f"FZK-Haus locate (fzk_targets.json) in the GUI: {time.time() - t1:.1f} s,"
              f" {n} fixtures\n{last[2]}")
        # requirement targets: regular ceiling rows, each room's level met, said so
        self.check("FZK-Haus: Locate says every room meets its level (fzk_targets.json)",
                   all(f"  met: {nm}:" in last[2] for nm in names)
                   and "NOT met" not in last[2], last[2])
        walls = [fx.Label for fx in fixtures.all_fixtures(doc)
                 if fx.LightDirection.z > -0.7]
        self.check("FZK-Haus: no wall light", not walls, walls)
        from test_fixtures import wall_clearance_m
        from invrad_wb.core.inverse.locate import MOUNT_CLEARANCE_M
        bad = []
        for fx in fixtures.all_fixtures(doc):
            clear, inside = wall_clearance_m(fx)
            if not inside or (fx.LightDirection.z < -0.99 and clear < MOUNT_CLEARANCE_M - 0.002):
                bad.append((fx.Label, round(clear, 3), inside))
        self.check("FZK-Haus: every fixture inside its room, ceiling lights clear of the"
                   " walls", not bad, bad)
        # no doubled fixtures: along the open Kueche/Wohnen border (a lighting zone) or
        # anywhere else, two fixtures facing the same way stand at least 0.6 m apart
        # (half the lumen-method spacing of 1500 lm luminaires for 500 lx is 0.61 m)
        pos = [(fx.Label, np.array([fx.Placement.Base.x, fx.Placement.Base.y,
                                    fx.Placement.Base.z]) / 1000.0,
                np.array([fx.LightDirection.x, fx.LightDirection.y, fx.LightDirection.z]))
               for fx in fixtures.all_fixtures(doc)]
        close = [(a[0], b[0], round(float(np.linalg.norm(a[1] - b[1])), 2))
                 for i, a in enumerate(pos) for b in pos[i + 1:]
                 if a[2] @ b[2] > 0.5 and np.linalg.norm(a[1] - b[1]) < 0.6]
        self.check("FZK-Haus: no doubled fixtures (none closer than 0.6 m)", not close,
                   close)
        view.viewTop()
        self.frame(view)
        self.shot("fzk_located_top")
        self.view_iso()
        self.shot("fzk_located_iso")
        self.upper_floor_shot(doc, view, "fzk_located_upper_top")
        before = len(messages.LOG)
        FreeCADGui.runCommand("InvRad_Verify")
        yield self.said("Verify and report", before)
        yield self.idle
        self.check("FZK-Haus: verify", display.mode(doc) == "achieved",
                   messages.LOG[-1:])
        view.viewTop()
        self.frame(view)
        self.shot("fzk_achieved_top")
        self.view_iso()
        self.shot("fzk_achieved_iso")
        self.upper_floor_shot(doc, view, "fzk_achieved_upper_top")
        last = messages.LOG[-1] if messages.LOG else ("", "", "")
        self.check("FZK-Haus: Verify judges the located fixtures as Locate did",
                   all(f"  met: {nm}:" in last[2] for nm in names)
                   and "NOT met" not in last[2], last[2])
        FreeCADGui.runCommand("InvRad_ToggleDeviation")
        yield None
        self.check("FZK-Haus: deviation shown", display.mode(doc) == "deviation")
        view.viewTop()
        self.frame(view)
        self.shot("fzk_deviation_top")
        self.check("FZK-Haus: in the plan cut only the ground floor's room names",
                   "Galerie" not in [n for n, _ in display.shown_labels(doc)]
                   and len(display.shown_labels(doc)) == 6, display.shown_labels(doc))
        # the design panel with the bundled requirements (examples/fzk_design.json)
        from invrad_wb.gui import designpanel, taskpanel
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.runCommand("InvRad_Design")
        yield None
        panel = taskpanel.ACTIVE
        if not self.check("FZK-Haus: design panel opens",
                          isinstance(panel, designpanel.DesignPanel), panel):
            return
        panel.open_spec(os.path.join(ROOT, "examples", "fzk_design.json"))
        req = panel.widget("requirements")
        self.check("FZK-Haus: the spec fills one requirement row per room",
                   req.rowCount() == 7, req.rowCount())
        self.fits(panel, "FZK-Haus design")
        self.grab(panel.form, "fzk_panel_design")
        before, t1 = len(messages.LOG), time.time()
        self.check("FZK-Haus: design panel accepted", panel.accept())
        yield lambda: any(m[1] == "Design lighting" for m in messages.LOG[before:])
        yield self.idle
        last = ([m for m in messages.LOG[before:] if m[1] == "Design lighting"]
                or [("", "", "")])[-1]
        self.check("FZK-Haus: design ran", last[0] == "info",
                   f"{last} in {time.time() - t1:.0f} s")
        self.check("FZK-Haus: every room meets its requirements",
                   "every requirement met" in last[2], last[2])
        print(f"FZK-Haus design in the GUI: {time.time() - t1:.1f} s\n{last[2]}")
        view.viewTop()
        self.frame(view)
        self.shot("fzk_designed_top")
        self.view_iso()
        self.shot("fzk_designed_iso")

    # ----------------------------------------------------------------- NativeIFC (1.x)
    def main_window_shot(self, name):
        """The main window with the 3D view drawn in: ``QWidget.grab`` leaves the 3D view
        blank, so the view's own ``saveImage`` at its size is painted into its place."""
        import tempfile
        import FreeCADGui
        from PySide import QtCore, QtGui
        mw = FreeCADGui.getMainWindow()
        FreeCADGui.updateGui()
        pix = mw.grab()
        area = mw.findChild(QtGui.QMdiArea)
        sub = area.activeSubWindow() if area is not None else None
        widget = sub.widget() if sub is not None else None
        ok = widget is not None
        if ok:
            fd, tmp = tempfile.mkstemp(suffix=".png")
            os.close(fd)
            size = widget.size()
            FreeCADGui.activeDocument().activeView().saveImage(
                tmp, size.width(), size.height(), "Current")
            painter = QtGui.QPainter(pix)
            painter.drawImage(QtCore.QRect(widget.mapTo(mw, QtCore.QPoint(0, 0)), size),
                              QtGui.QImage(tmp))
            painter.end()
            os.remove(tmp)
        path = os.path.join(self.out, name + ".png")
        ok = ok and pix.save(path)
        if ok:
            self.shots.append(os.path.relpath(path, self.out))
        self.check(f"main window picture {name}", ok and self.drawn(path) > 0.05, path)

    def run_native(self):
        """FreeCAD 1.x: FZK-Haus opened as a NativeIFC document, Locate in its ground-floor
        rooms through the workbench's runner, the luminaires as IfcLightFixture entities,
        then the BIM workbench with the InvRad toolbar and the located fixtures."""
        import shutil
        import tempfile
        import FreeCADGui
        from PySide import QtGui
        from fctest import FZK
        from invrad_wb.app import fixtures, ifcimport, nativeifc, rooms, targets
        from invrad_wb.gui import messages, runner
        if not self.check("NativeIFC available (FreeCAD 1.x)", nativeifc.available()):
            return
        tmp = tempfile.mkdtemp(prefix="invrad-native-")
        src = os.path.join(tmp, "AC20-FZK-Haus.ifc")
        shutil.copy(FZK, src)
        t0 = time.time()
        doc, proj = ifcimport.open_ifc(src, shapemode=1)      # NativeIFC's coin display
        FreeCADGui.SendMsgToActiveView("ViewFit")
        yield None
        spaces = {rooms.room_name(s): s for s in rooms.find_spaces(doc)}
        self.check("NativeIFC FZK-Haus: 7 rooms from its IfcSpaces", len(spaces) == 7,
                   f"{sorted(spaces)} in {time.time() - t0:.0f} s")
        # the architect's own targets (a work-plane level in every room), as in the
        # classic document; the plan cut shows the ground floor's rooms
        opts = targets.apply_targets_file(doc, os.path.join(ROOT, "examples",
                                                            "fzk_targets.json"))
        lux = [n for n in spaces if n != "Galerie"]
        # the targets in false colour with their legend and the rooms' names, as in a
        # classic document, framed on the building (not the site's terrain)
        from invrad_wb.gui import display
        FreeCADGui.runCommand("InvRad_ToggleTargets")
        yield None
        view = self.plan_cut(doc)
        # orthographic, as the classic views (the BIM workbench's view was a perspective
        # one: framed, its near plane cut the building)
        view.setCameraType("Orthographic")
        view.viewTop()
        self.frame(view)
        yield None
        self.check("NativeIFC FZK-Haus: targets in false colour with the ground floor's"
                   " names", display.mode(doc) == "targets"
                   and sorted(n for n, _ in display.shown_labels(doc)) == sorted(lux),
                   (display.mode(doc), display.shown_labels(doc)))
        self.shot("native_fzk_targets_top")
        n0 = doc.UndoCount
        t1 = time.time()
        FreeCADGui.doCommand("import invrad_wb.gui.runner")
        FreeCADGui.doCommand(f"invrad_wb.gui.runner.locate(App.getDocument({doc.Name!r}),"
                             f" run={{'flux_lm': {float(opts['flux_lm'])!r},"
                             f" 'resolution_m': {float(opts['resolution_m'])!r}}})")
        yield self.idle
        fx = fixtures.all_fixtures(doc)
        last = messages.LOG[-1][2] if messages.LOG else ""
        self.check("NativeIFC FZK-Haus: Locate says every room meets its level, no wall"
                   " light", all(f"  met: {n}:" in last for n in spaces)
                   and "NOT met" not in last
                   and all(fixtures.fixture_luminaire(f).normal[2] < -0.7 for f in fx),
                   last)
        ifc = proj.Proxy.ifcfile
        import ifcopenshell.util.element as E
        lights = [e for e in ifc.by_type("IfcLightFixture")
                  if (E.get_container(e) is not None
                      and E.get_container(e).is_a("IfcSpace"))]
        self.check("NativeIFC FZK-Haus: located luminaires are IfcLightFixture in their"
                   " IfcSpace, one undo step",
                   fx and len(lights) == len(fx) and doc.UndoCount == n0 + 1,
                   (len(fx), len(lights), doc.UndoCount - n0, messages.LOG[-1:],
                    f"{time.time() - t1:.0f} s"))
        print(f"NativeIFC FZK-Haus locate in the GUI: {time.time() - t1:.1f} s,"
              f" {len(fx)} fixtures")
        self.check("NativeIFC FZK-Haus: every fixture has a visible body",
                   fx and all(not f.Shape.isNull() and f.ViewObject.Visibility for f in fx),
                   [(f.Label, f.ShapeMode, f.Shape.isNull(), f.ViewObject.Visibility)
                    for f in fx[:3]])
        for f in fx:                        # the fixtures stand out from the building
            try:
                f.ViewObject.ShapeColor = (1.0, 0.8, 0.0)
            except Exception:
                pass
        FreeCADGui.activateWorkbench("BIMWorkbench")
        yield None
        self.check("BIM workbench active",
                   FreeCADGui.activeWorkbench().name() == "BIMWorkbench",
                   FreeCADGui.activeWorkbench().name())
        mw = FreeCADGui.getMainWindow()
        tb = [t for t in mw.findChildren(QtGui.QToolBar)
              if t.windowTitle() == "InvRad" and t.isVisible()]
        self.check("the BIM workbench shows the InvRad toolbar",
                   bool(tb) and len([a for a in tb[0].actions() if a.text()]) >= 6,
                   [a.text() for a in tb[0].actions()] if tb else
                   [t.windowTitle() for t in mw.findChildren(QtGui.QToolBar)
                    if t.isVisible()])
        if tb:
            self.grab(tb[0], "native_bim_invrad_toolbar")
        before = len(messages.LOG)
        FreeCADGui.runCommand("InvRad_Verify")
        yield self.said("Verify and report", before)
        yield self.idle
        last = messages.LOG[-1][2] if messages.LOG else ""
        self.check("NativeIFC FZK-Haus: Verify reads the located IfcLightFixtures (their flux"
                   " in the IFC file) and says per room whether it is met",
                   last.startswith(f"{len(fx)} luminaire(s)") and "left out" not in last
                   and all(f"met: {n}:" in last for n in lux), last)
        self.check("NativeIFC FZK-Haus: verified, the achieved light in false colour with"
                   " the legend and the ground floor's names",
                   display.mode(doc) == "achieved"
                   and sorted(n for n, _ in display.shown_labels(doc)) == sorted(lux),
                   (display.mode(doc), display.shown_labels(doc), messages.LOG[-1:]))
        view.setCameraType("Orthographic")
        view.viewIsometric()
        self.frame(view)
        yield None
        self.shot("native_fzk_located_iso")
        self.main_window_shot("native_fzk_bim_workbench")
        view.setCameraType("Orthographic")
        view.viewTop()
        self.frame(view)
        yield None
        self.shot("native_fzk_located_top")
        self.upper_floor_shot(doc, view, "native_fzk_achieved_upper_top")
        # Design with the bundled requirements (examples/fzk_design.json)
        with open(os.path.join(ROOT, "examples", "fzk_design.json"), encoding="utf-8") as fh:
            spec = json.load(fh)
        before, t2 = len(messages.LOG), time.time()
        res = runner.design(doc, spec=spec)
        yield self.idle
        last = ([m for m in messages.LOG[before:] if m[1] == "Design lighting"]
                or [("", "", "")])[-1]
        self.check("NativeIFC FZK-Haus: designed, every requirement met",
                   res is not None and "every requirement met" in last[2],
                   (last, f"{time.time() - t2:.0f} s"))
        view.viewTop()
        self.frame(view)
        yield None
        self.shot("native_fzk_designed_top")
        view.viewIsometric()
        self.frame(view)
        yield None
        self.shot("native_fzk_designed_iso")


SMOKE = None


def main_inside():
    import faulthandler
    from PySide import QtCore
    # a crash writes every thread's Python stack there (FreeCAD's stderr has no file
    # descriptor)
    stacks = open(os.path.join(os.environ[ENV_OUT], "crash_stacks.txt"), "w")
    faulthandler.enable(file=stacks, all_threads=True)
    # a hang writes them too, shortly before the outer timeout kills FreeCAD
    hang = float(os.environ.get("INVRAD_SMOKE_HANG_S", "0") or 0)
    if hang > 0:
        faulthandler.dump_traceback_later(hang, repeat=True, file=stacks)
    # standard views at once (FreeCAD 1.0 animates them: a picture saved right after
    # viewTop() caught the camera half-way)
    import FreeCAD
    FreeCAD.ParamGet("User parameter:BaseApp/Preferences/View").SetBool(
        "UseNavigationAnimations", False)
    global SMOKE
    # a module-level reference: PySide's connections to bound methods do not keep the
    # object alive, and the Smoke <-> its step generator cycle was collected by the cyclic
    # GC mid-run (seen after Design: the timers went with it, FreeCAD idled to the timeout)
    SMOKE = Smoke()
    QtCore.QTimer.singleShot(1500, SMOKE.tick)


if _inside_freecad_gui():
    main_inside()
elif __name__ == "__main__":
    sys.exit(relaunch(sys.argv[1:]))
