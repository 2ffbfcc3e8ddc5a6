"""Task panels: locate settings, a lighting target, recalculated peaks.

Each panel loads its form from ``resources/ui/*.ui`` and stays thin: a widget is bound to
the option of the same name (its ``objectName``), values come from and go back to the
stored parameters (:mod:`.params`), and *OK* records the action with ``Gui.doCommand``
(so macros replay it) through :mod:`.runner` or :mod:`invrad_wb.app.targets`.

Widgets and values: ``QDoubleSpinBox``/``QSpinBox`` hold numbers in SI units (their
minimum, shown as "auto", stands for the core's ``None``); ``QComboBox`` items carry the
option's value as item data (:data:`invrad_wb.gui.params.CHOICES`); ``QCheckBox`` a bool.
"""
import os

from invrad_wb import constants as C
from invrad_wb.gui import messages, params

UI_DIR = os.path.join(C.RESOURCES_DIR, "ui")

#: The panel shown last (tests and the smoke script drive it).
ACTIVE = None


def ui_path(name):
    return os.path.join(UI_DIR, name)


def load_ui(name, icon=None):
    """The form of ``resources/ui/<name>``; ``icon`` (an SVG of resources/icons) shows in
    the task panel's title bar."""
    import FreeCADGui
    form = FreeCADGui.PySideUic.loadUi(ui_path(name))
    if icon:
        from PySide import QtGui
        form.setWindowIcon(QtGui.QIcon(os.path.join(C.RESOURCES_DIR, "icons", icon)))
    fit_narrow(form)
    return form


#: The narrowest task view a panel must fit without horizontal scrolling (px): FreeCAD
#: 1.0's default combo view in a 1280 x 800 window is about 260 px wide, of which the
#: task box's frame, margins and scroll bar take about 20.
NARROW_WIDTH_PX = 240
#: Characters a drop-down keeps visible at its narrowest (its list still shows whole items).
COMBO_MIN_CHARS = 5


def fit_narrow(form):
    """Let a form shrink to :data:`NARROW_WIDTH_PX`: labels wrap their words, a form
    layout's field goes under its label when both do not fit side by side, and drop-downs
    may be narrower than their longest item (the open list shows whole items)."""
    from PySide import QtGui
    for w in form.findChildren(QtGui.QLabel):
        w.setWordWrap(True)
    for w in form.findChildren(QtGui.QComboBox):
        w.setSizeAdjustPolicy(QtGui.QComboBox.AdjustToMinimumContentsLengthWithIcon)
        w.setMinimumContentsLength(COMBO_MIN_CHARS)
    for lay in form.findChildren(QtGui.QFormLayout):
        lay.setRowWrapPolicy(QtGui.QFormLayout.WrapLongRows)     # field under its label


def _widget(form, name):
    from PySide import QtGui
    return form.findChild(QtGui.QWidget, name)


def fill_combo(w, choices):
    w.clear()
    for value, text in choices:
        w.addItem(text, value)
    # its narrowest shows its longest item whole (a form layout then puts it under its
    # label where both do not fit side by side: 'Work plane of the room' was cut to
    # 110 px, 'By light' to 'By ligh'); its open list lists them whole
    fm = w.fontMetrics()
    adv = fm.horizontalAdvance if hasattr(fm, "horizontalAdvance") else fm.width
    frame = w.minimumSizeHint().width() - w.minimumContentsLength() * adv("x")
    w.setMinimumWidth(frame + max((adv(text) for _, text in choices), default=0))
    w.view().setMinimumWidth(w.view().sizeHintForColumn(0) + 8)


def set_value(w, value):
    """Show ``value`` in a bound widget (None -> the spin box minimum, i.e. "auto")."""
    cls = type(w).__name__
    if cls in ("QDoubleSpinBox", "QSpinBox"):
        if value is None:
            w.setValue(w.minimum())
        else:
            w.setValue(value)
    elif cls == "QCheckBox":
        w.setChecked(bool(value))
    elif cls == "QComboBox":
        for i in range(w.count()):
            data = w.itemData(i)
            if data == value and type(data) is type(value) or w.itemText(i) == value:
                w.setCurrentIndex(i)
                return
    elif cls == "QLineEdit":
        w.setText("" if value is None else str(value))
    elif cls == "QLabel":
        w.setText(str(value))


def get_value(w, optional=False, integer=False):
    cls = type(w).__name__
    if cls in ("QDoubleSpinBox", "QSpinBox"):
        v = w.value()
        if optional and v <= w.minimum():
            return None
        return int(v) if integer or cls == "QSpinBox" else float(v)
    if cls == "QCheckBox":
        return bool(w.isChecked())
    if cls == "QComboBox":
        data = w.itemData(w.currentIndex())
        return data if data is not None else w.currentText()
    if cls == "QLineEdit":
        return w.text()
    raise TypeError(f"widget {w.objectName()} ({cls}) holds no value")


def _call(func, *args, **kwargs):
    """``module.func(arg, ..., key=value)`` as Python source (for Gui.doCommand)."""
    parts = [repr(a) if not isinstance(a, _Src) else str(a) for a in args]
    parts += [f"{k}={v if isinstance(v, _Src) else repr(v)}" for k, v in kwargs.items()]
    return f"{func}({', '.join(parts)})"


class _Src(str):
    """Source text passed through :func:`_call` unquoted."""


def doc_src(doc):
    return _Src(f"App.getDocument({doc.Name!r})")


def obj_src(obj):
    return _Src(f"App.getDocument({obj.Document.Name!r}).getObject({obj.Name!r})")


def do_command(*lines):
    """Run (and record) Python source lines like a FreeCAD command does."""
    import FreeCADGui
    for line in lines:
        FreeCADGui.doCommand(line)


# ------------------------------------------------------------------------- base
class Panel:
    """What every task panel shares: its form from ``resources/ui/<UI>``, widgets by
    name, OK/Cancel, Cancel closing it; the newest panel is :data:`ACTIVE`."""

    UI = ""

    def _load(self, icon):
        global ACTIVE
        ACTIVE = self
        self.form = load_ui(self.UI, icon)

    def widget(self, name):
        w = _widget(self.form, name)
        if w is None:
            raise KeyError(f"{self.UI} has no widget {name!r}")
        return w

    def getStandardButtons(self):
        from PySide import QtGui
        from invrad_wb.gui.qtcompat import flag_int
        return flag_int(QtGui.QDialogButtonBox.Ok | QtGui.QDialogButtonBox.Cancel)

    def reject(self):
        import FreeCADGui
        FreeCADGui.Control.closeDialog()
        return True

    def _accept(self, title, then):
        """OK: the panel's values checked (:meth:`check`; an error is shown under
        ``title`` and the panel stays), ``then(*values)`` stores them and returns what
        to run once the panel is closed (None: nothing)."""
        import FreeCADGui
        try:
            values = self.check()
        except Exception as exc:
            messages.exception(title, exc)
            return False
        later = then(*values)
        FreeCADGui.Control.closeDialog()
        if later is not None:
            from PySide import QtCore
            QtCore.QTimer.singleShot(0, later)
        return True


# ------------------------------------------------------------------------- locate
class LocatePanel(Panel):
    """Every locate setting; OK saves them and, if ``run``, locates the luminaires."""

    UI = "locate_settings.ui"

    RUN_FIELDS = ("flux_lm", "resolution_m", "interreflection", "backend", "replace",
                  "zones")

    def __init__(self, doc, rooms=None, run=True):
        self.doc = doc
        self.rooms = list(rooms or [])
        self.run = run
        self._load("locate.svg" if run else "settings.svg")
        self.form.setWindowTitle("Locate luminaires" if run else "invrad settings")
        self.fields = params.locate_fields()
        for name, choices in params.CHOICES.items():
            fill_combo(self.widget(name), choices)
        self.show_values(params.load_run(), params.load_locate())
        names = ", ".join(r.Label for r in self.rooms) if self.rooms else \
            "every room with lighting targets"
        self.widget("rooms_label").setText(names if run else "(settings only)")
        self.widget("reset_defaults").clicked.connect(self.reset_defaults)
        self._advanced_toggle()

    #: Group boxes of the method's own settings, hidden until asked for (the panel was
    #: about 1170 px tall with them).
    ADVANCED = ("group_votes", "group_dummy", "group_peaks", "group_refine")

    def _advanced_toggle(self):
        """A check box above the method's settings that shows or hides them; they start
        shown when any of them differs from its default (nothing is changed unseen)."""
        from PySide import QtGui
        groups = [self.form.findChild(QtGui.QGroupBox, n) for n in self.ADVANCED]
        groups = [g for g in groups if g is not None]
        if not groups:
            return
        box = QtGui.QCheckBox("Advanced settings")
        box.setObjectName("show_advanced")
        box.setToolTip("The method's own settings (inverse voting: votes, dummy planes,"
                       " peaks, refinement; each named in its tooltip); the defaults suit"
                       " every room")
        lay = self.form.layout()
        lay.insertWidget(lay.indexOf(groups[0]), box)
        box.toggled.connect(lambda on: [g.setVisible(on) for g in groups])
        box.setChecked(self.advanced_changed())
        for g in groups:
            g.setVisible(box.isChecked())

    def advanced_changed(self):
        """True when a setting in the advanced groups differs from its default."""
        from PySide import QtGui
        _, loc = self.values()
        defaults = {k: d for k, (_, d) in self.fields.items()}
        for n in self.ADVANCED:
            g = self.form.findChild(QtGui.QGroupBox, n)
            if g is None:
                continue
            for w in g.findChildren(QtGui.QWidget):
                k = w.objectName()
                if k in loc and loc[k] != defaults.get(k):
                    return True
        return False

    def show_values(self, run, loc):
        for k in self.RUN_FIELDS:
            set_value(self.widget(k), run[k])
        for k, v in loc.items():
            set_value(self.widget(k), v)

    def values(self):
        """(run options, locate settings) as shown in the panel."""
        run = {k: get_value(self.widget(k)) for k in self.RUN_FIELDS}
        loc = {}
        for k, (kind, _) in self.fields.items():
            loc[k] = get_value(self.widget(k), optional=kind.startswith("opt"),
                               integer=kind in ("int", "optint"))
        return run, loc

    def reset_defaults(self):
        run = {k: d for k, (_, d) in params.RUN.items()}
        loc = {k: d for k, (_, d) in self.fields.items()}
        self.show_values(run, loc)

    def check(self):
        """The panel's values, checked; raises SettingsError naming the bad one."""
        from invrad_wb.app.pipeline import check_flux
        from invrad_wb.app.rooms import check_resolution
        from invrad_wb.core.inverse.locate import LocateSettings
        run, loc = self.values()
        check_flux(run["flux_lm"])
        check_resolution(run["resolution_m"])
        LocateSettings.from_dict(loc)
        return run, loc

    def accept(self):
        return self._accept("Locate settings", self._save)

    def _save(self, run, loc):
        params.save_run(run)
        params.save_locate(loc)
        if self.run:
            rooms = [r.Name for r in self.rooms] or None
            return lambda: run_locate(self.doc, rooms)
        return None



def run_locate(doc, rooms=None):
    """Record and run the locate action (with the stored settings, spelled out)."""
    run = params.load_run()
    loc = params.load_locate()
    do_command("import invrad_wb.gui.runner",
               _call("invrad_wb.gui.runner.locate", doc_src(doc), rooms=rooms,
                     run={k: run[k] for k in LocatePanel.RUN_FIELDS}, locate=loc))


# ------------------------------------------------------------------------- targets
#: Panel kinds -> the app's target kinds (short: the kind's tooltip says more).
TARGET_KINDS = [("Uniform", "Uniform"), ("Spot", "Spot"), ("Texture", "Image"),
                ("Shade", "Shade (0 lx)"), ("WorkPlane", "Work plane")]


class TargetPanel(Panel):
    """A new lighting target on selected faces of one room (or its work plane)."""

    UI = "target.ui"

    def __init__(self, space, faces, point_mm=None, kind=None):
        from invrad_wb.app.units import mm_to_m
        self.space = space
        self.faces = list(faces)
        self._load("set_target.svg")
        fill_combo(self.widget("kind"), TARGET_KINDS)
        from invrad_wb.app.targets import FALLOFFS
        fill_combo(self.widget("falloff"), [(f, f) for f in FALLOFFS])
        stored = params.load_target()
        for k in ("lux", "radius_m", "lux_scale", "image", "height_m", "margin_m",
                  "falloff"):
            set_value(self.widget(k), stored[k])
        if point_mm is None and self.faces:
            from invrad_wb.app.rooms import room_shape
            point_mm = room_shape(space).Faces[int(self.faces[0][4:]) - 1].CenterOfMass
        if point_mm is not None:
            c = mm_to_m(point_mm)
            for axis, v in zip("xyz", c):
                self.widget(f"centre_{axis}").setValue(float(v))
        from invrad_wb.app.rooms import room_name
        self.widget("room_label").setText(room_name(space))
        self.widget("faces_label").setText(", ".join(self.faces) or "(the whole room)")
        set_value(self.widget("kind"), kind or (stored["kind"] if self.faces else "WorkPlane"))
        self.widget("kind").currentIndexChanged.connect(self.update_groups)
        self.widget("browse").clicked.connect(self.browse)
        self.update_groups()

    def kind(self):
        return get_value(self.widget("kind"))

    def update_groups(self, *_):
        k = self.kind()
        self.widget("group_spot").setVisible(k == "Spot")
        self.widget("group_texture").setVisible(k == "Texture")
        self.widget("group_work_plane").setVisible(k == "WorkPlane")
        self.widget("lux").setEnabled(k in ("Uniform", "Spot", "WorkPlane"))

    def browse(self):
        from PySide import QtGui
        path, _ = QtGui.QFileDialog.getOpenFileName(
            self.form, "Illuminance image", os.path.dirname(self.widget("image").text()),
            "Images (*.exr *.hdr *.tif *.tiff *.png *.jpg);;All files (*)")
        if path:
            self.widget("image").setText(path)

    def command(self):
        """The Python source that adds the target (what OK records)."""
        k = self.kind()
        sp = obj_src(self.space)
        lux = get_value(self.widget("lux"))
        T = "invrad_wb.app.targets"
        if k != "WorkPlane" and not self.faces:
            from invrad_wb.errors import SceneError
            raise SceneError(f"a {k.lower()} target needs faces: select faces of the room",
                             self.space.Label)
        if k == "Uniform":
            return _call(f"{T}.add_uniform_target", sp, self.faces, lux)
        if k == "Spot":
            centre = [round(get_value(self.widget(f"centre_{a}")), 6) for a in "xyz"]
            return _call(f"{T}.add_spot_target", sp, self.faces[0], centre,
                         get_value(self.widget("radius_m")), lux,
                         falloff=get_value(self.widget("falloff")).lower())
        if k == "Texture":
            return _call(f"{T}.add_texture_target", sp, self.faces[0],
                         get_value(self.widget("image")), get_value(self.widget("lux_scale")))
        if k == "Shade":
            return _call(f"{T}.add_shade_target", sp, self.faces)
        return _call(f"{T}.set_work_plane", sp, lux, get_value(self.widget("height_m")),
                     get_value(self.widget("margin_m")))

    def accept(self):
        import FreeCADGui
        try:
            cmd = self.command()
            do_command("import invrad_wb.app.targets", cmd)
        except Exception as exc:
            messages.exception("Set target", exc)
            return False
        params.save_target({"kind": self.kind(),
                            **{k: get_value(self.widget(k)) for k in
                               ("lux", "radius_m", "lux_scale", "image", "height_m",
                                "margin_m", "falloff")}})
        FreeCADGui.Control.closeDialog()
        return True



# ------------------------------------------------------------------------- repeak
class RepeakPanel(Panel):
    """New threshold and neighbourhood for the stored votes of the last locate run."""

    UI = "repeak.ui"

    def __init__(self, doc):
        from invrad_wb.gui import runner
        self.doc = doc
        self._load("repeak.svg")
        st = runner.stored(doc)
        s = st.result.locate_result.settings if st is not None else params.load_locate()
        set_value(self.widget("threshold"), s.get("threshold"))
        set_value(self.widget("neighbourhood_m"), s.get("neighbourhood_m"))
        if st is not None:
            self.widget("info_label").setText(
                f"Last run: {len(st.result.luminaires)} luminaire(s) in"
                f" {', '.join(st.result.building.room_names)}. The fixtures of these rooms"
                " are replaced.")

    def accept(self):
        import FreeCADGui
        from PySide import QtCore
        th = get_value(self.widget("threshold"))
        nb = get_value(self.widget("neighbourhood_m"))
        FreeCADGui.Control.closeDialog()
        QtCore.QTimer.singleShot(0, lambda: do_command(
            "import invrad_wb.gui.runner",
            _call("invrad_wb.gui.runner.repeak", doc_src(self.doc), threshold=th,
                  neighbourhood_m=nb)))
        return True
