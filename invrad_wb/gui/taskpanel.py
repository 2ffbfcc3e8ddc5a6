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
    # a drop-down narrower than its items (fit_narrow) still lists them whole
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


# ------------------------------------------------------------------------- locate
class LocatePanel:
    """Every locate setting; OK saves them and, if ``run``, locates the luminaires."""

    RUN_FIELDS = ("flux_lm", "resolution_m", "interreflection", "backend", "replace",
                  "zones")

    def __init__(self, doc, rooms=None, run=True):
        self.doc = doc
        self.rooms = list(rooms or [])
        global ACTIVE
        ACTIVE = self
        self.run = run
        self.form = load_ui("locate_settings.ui", "locate.svg" if run else "settings.svg")
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
        box.setToolTip("The method's own settings (votes, dummy planes, peaks, refinement);"
                       " the defaults suit every room")
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

    def widget(self, name):
        w = _widget(self.form, name)
        if w is None:
            raise KeyError(f"locate_settings.ui has no widget {name!r}")
        return w

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

    def getStandardButtons(self):
        from PySide import QtGui
        from invrad_wb.gui.qtcompat import flag_int
        return flag_int(QtGui.QDialogButtonBox.Ok | QtGui.QDialogButtonBox.Cancel)

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
        import FreeCADGui
        try:
            run, loc = self.check()
        except Exception as exc:
            messages.exception("Locate settings", exc)
            return False
        params.save_run(run)
        params.save_locate(loc)
        FreeCADGui.Control.closeDialog()
        if self.run:
            from PySide import QtCore
            rooms = [r.Name for r in self.rooms] or None
            QtCore.QTimer.singleShot(0, lambda: run_locate(self.doc, rooms))
        return True

    def reject(self):
        import FreeCADGui
        FreeCADGui.Control.closeDialog()
        return True


def run_locate(doc, rooms=None):
    """Record and run the locate action (with the stored settings, spelled out)."""
    run = params.load_run()
    loc = params.load_locate()
    do_command("import invrad_wb.gui.runner",
               _call("invrad_wb.gui.runner.locate", doc_src(doc), rooms=rooms,
                     run={k: run[k] for k in LocatePanel.RUN_FIELDS}, locate=loc))


# ------------------------------------------------------------------------- targets
#: Panel kinds -> the app's target kinds.
TARGET_KINDS = [("Uniform", "Uniform illuminance on the faces"), ("Spot", "Spot"),
                ("Texture", "Illuminance image"), ("Shade", "Shade (0 lx)"),
                ("WorkPlane", "Work plane of the room")]


class TargetPanel:
    """A new lighting target on selected faces of one room (or its work plane)."""

    def __init__(self, space, faces, point_mm=None, kind=None):
        from invrad_wb.app.units import mm_to_m
        self.space = space
        global ACTIVE
        ACTIVE = self
        self.faces = list(faces)
        self.form = load_ui("target.ui", "set_target.svg")
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
        self.widget("room_label").setText(space.Label)
        self.widget("faces_label").setText(", ".join(self.faces) or "(the whole room)")
        set_value(self.widget("kind"), kind or (stored["kind"] if self.faces else "WorkPlane"))
        self.widget("kind").currentIndexChanged.connect(self.update_groups)
        self.widget("browse").clicked.connect(self.browse)
        self.update_groups()

    def widget(self, name):
        w = _widget(self.form, name)
        if w is None:
            raise KeyError(f"target.ui has no widget {name!r}")
        return w

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

    def getStandardButtons(self):
        from PySide import QtGui
        from invrad_wb.gui.qtcompat import flag_int
        return flag_int(QtGui.QDialogButtonBox.Ok | QtGui.QDialogButtonBox.Cancel)

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

    def reject(self):
        import FreeCADGui
        FreeCADGui.Control.closeDialog()
        return True


# ------------------------------------------------------------------------- repeak
class RepeakPanel:
    """New threshold and neighbourhood for the stored votes of the last locate run."""

    def __init__(self, doc):
        from invrad_wb.gui import runner
        self.doc = doc
        global ACTIVE
        ACTIVE = self
        self.form = load_ui("repeak.ui", "repeak.svg")
        st = runner.stored(doc)
        s = st.result.locate_result.settings if st is not None else params.load_locate()
        set_value(self.widget("threshold"), s.get("threshold"))
        set_value(self.widget("neighbourhood_m"), s.get("neighbourhood_m"))
        if st is not None:
            self.widget("info_label").setText(
                f"Last run: {len(st.result.luminaires)} luminaire(s) in"
                f" {', '.join(st.result.building.room_names)}. The fixtures of these rooms"
                " are replaced.")

    def widget(self, name):
        w = _widget(self.form, name)
        if w is None:
            raise KeyError(f"repeak.ui has no widget {name!r}")
        return w

    def getStandardButtons(self):
        from PySide import QtGui
        from invrad_wb.gui.qtcompat import flag_int
        return flag_int(QtGui.QDialogButtonBox.Ok | QtGui.QDialogButtonBox.Cancel)

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

    def reject(self):
        import FreeCADGui
        FreeCADGui.Control.closeDialog()
        return True


# ------------------------------------------------------------------------- design
#: Mounting choices of the design panel (value, label).
MOUNTINGS = [("ceiling", "Ceiling"), ("pendant", "Pendant")]
#: The requirement table's "room type" for rooms designed to an Em/U0 of their own, and
#: for rooms left out.
CUSTOM, SKIP = "custom", "skip"


class DesignPanel:
    """Design from requirements: a catalogue, per-room requirements, run options.

    The catalogue and requirements are a DESIGN.json spec (the same as ``python -m
    invrad_wb design`` and ``freecad --targets`` read); OK checks it with the core's
    parser (an error names the row and value), stores it and records
    :func:`invrad_wb.gui.runner.design` with it spelled out.
    """

    CAT_COLUMNS = ("name", "flux_lm", "watts", "dim_percent", "photometry")
    #: Catalogue columns shown in the table; the others are edited in the form below it
    #: for the selected entry (five columns do not fit a narrow task view).
    CAT_SHOWN = 2
    #: The catalogue entry's form: widget -> column.
    ENTRY_FIELDS = (("entry_watts", 2), ("entry_dim", 3), ("entry_photometry", 4))
    RUN_FIELDS = ("resolution_m", "interreflection", "backend", "replace")

    def __init__(self, doc, rooms=None):
        from invrad_wb.app.rooms import find_spaces, room_name
        from invrad_wb.core.design import en12464
        self.doc = doc
        global ACTIVE
        ACTIVE = self
        self.form = load_ui("design.ui", "design.svg")
        self.form.setWindowTitle("Design lighting")
        self.selected = list(rooms or [])
        self.spaces = self.selected or find_spaces(doc)
        self.types = [(CUSTOM, "Custom Em / U0"), (SKIP, "(not designed)")] + [
            (n, f"{n.replace('_', ' ')} ({en12464.lookup(n).em_lux:g} lx)")
            for n in en12464.names()]
        fill_combo(self.widget("mounting"), MOUNTINGS)
        fill_combo(self.widget("room_type"), self.types)
        fill_combo(self.widget("backend"), params.CHOICES["backend"])
        run = params.load_run()
        for k in self.RUN_FIELDS:
            set_value(self.widget(k), run[k])
        self.widget("rooms_label").setText(
            "Rooms: " + (", ".join(room_name(sp) for sp in self.spaces)
                         or "(none in the document)"))
        for name, fn in (("add_entry", self.add_entry), ("remove_entry", self.remove_entries),
                         ("load_spec", self.open_spec), ("save_spec", self.save_spec)):
            self.widget(name).clicked.connect(fn)
        self.widget("mounting").currentIndexChanged.connect(self._mounting_changed)
        self.widget("requirements").itemSelectionChanged.connect(self._selection_changed)
        self.widget("room_type").currentIndexChanged.connect(self._room_type_chosen)
        cat = self.widget("catalogue")
        for col in range(self.CAT_SHOWN, len(self.CAT_COLUMNS)):
            cat.setColumnHidden(col, True)
        cat.itemSelectionChanged.connect(self._entry_selected)
        self.widget("entry_watts").valueChanged.connect(self._entry_edited)
        self.widget("entry_dim").valueChanged.connect(self._entry_edited)
        self.widget("entry_photometry").textChanged.connect(self._entry_edited)
        # the numbers first, the long room-type names last (visual order only); the
        # names take the width left (elided when narrow), the numbers their own
        from PySide import QtGui
        fit, stretch = QtGui.QHeaderView.ResizeToContents, QtGui.QHeaderView.Stretch
        head = self.widget("requirements").horizontalHeader()
        head.moveSection(1, 3)
        head.setStretchLastSection(False)
        for col, mode in ((0, stretch), (1, stretch), (2, fit), (3, fit)):
            head.setSectionResizeMode(col, mode)
        head = cat.horizontalHeader()
        head.setStretchLastSection(False)
        head.setSectionResizeMode(0, stretch)
        head.setSectionResizeMode(1, fit)
        self.show_spec(params.load_design())
        self._run_toggle(run)

    def widget(self, name):
        w = _widget(self.form, name)
        if w is None:
            raise KeyError(f"design.ui has no widget {name!r}")
        return w

    def _run_toggle(self, run):
        """The run settings start hidden unless one differs from its default."""
        box, group = self.widget("show_run"), self.widget("group_run")
        box.toggled.connect(group.setVisible)
        changed = any(run[k] != params.RUN[k][1] for k in self.RUN_FIELDS)
        box.setChecked(changed)
        group.setVisible(changed)

    # ---------------------------------------------------------------- catalogue form
    def _entry_row(self):
        rows = sorted({i.row() for i in self.widget("catalogue").selectedIndexes()})
        return rows[0] if rows else None

    def _entry_selected(self):
        """Show the selected entry's power, dimming and photometry in the form."""
        row = self._entry_row()
        cat = self.widget("catalogue")
        self._filling = True
        try:
            for name, col in self.ENTRY_FIELDS:
                w = self.widget(name)
                w.setEnabled(row is not None)
                item = cat.item(row, col) if row is not None else None
                text = item.text() if item is not None else ""
                if name == "entry_photometry":
                    w.setText(text)
                else:
                    try:
                        w.setValue(float(text))
                    except ValueError:
                        w.setValue(w.minimum())
        finally:
            self._filling = False

    def _entry_edited(self, *_):
        """The form's values into the selected entry's (hidden) cells."""
        from PySide import QtGui
        row = self._entry_row()
        if row is None or getattr(self, "_filling", False):
            return
        cat = self.widget("catalogue")
        for name, col in self.ENTRY_FIELDS:
            w = self.widget(name)
            text = w.text().strip() if name == "entry_photometry" else f"{w.value():g}"
            if cat.item(row, col) is None:
                cat.setItem(row, col, QtGui.QTableWidgetItem(text))
            else:
                cat.item(row, col).setText(text)

    # ---------------------------------------------------------------- spec <-> widgets
    def show_spec(self, spec):
        """Fill the panel from a DESIGN.json dict (rooms keyed by label or name)."""
        self.widget("maintenance_factor").setValue(float(spec.get("maintenance_factor", 0.8)))
        cat = self.widget("catalogue")
        cat.setRowCount(0)
        for e in spec.get("catalogue") or []:
            self.add_entry(e)
        rooms = spec.get("rooms") or {}
        default = rooms.get("*") or {}
        wp0 = default.get("work_plane") if isinstance(default.get("work_plane"), dict) else {}
        set_value(self.widget("height_m"), float(wp0.get("height_m", 0.75)))
        set_value(self.widget("margin_m"), float(wp0.get("margin_m", 0.5)))
        mount = default.get("mounting", "ceiling")
        mount = {"type": mount} if isinstance(mount, str) else mount
        set_value(self.widget("mounting"), mount.get("type", "ceiling"))
        if mount.get("height_m"):
            self.widget("pendant_height_m").setValue(float(mount["height_m"]))
        self._mounting_changed()
        req = self.widget("requirements")
        req.setRowCount(0)
        from invrad_wb.app.rooms import room_name
        for sp in self.spaces:
            r = rooms.get(room_name(sp)) or rooms.get(sp.Label) or rooms.get(sp.Name)
            self._add_room_row(sp, r if r is not None else self._room_default(sp, default))
        cat.resizeColumnsToContents()
        req.resizeColumnsToContents()
        if req.rowCount():
            req.selectRow(0)
        if cat.rowCount():
            cat.selectRow(0)
        self._entry_selected()

    def _room_default(self, space, default):
        """A room without its own entry: its work-plane target's lux if it has one (with
        the default's U0), else the default requirement."""
        from invrad_wb.app.targets import work_plane_target
        wp = work_plane_target(space)
        if wp is not None:
            u0 = 0.4
            if default.get("room_type"):
                from invrad_wb.core.design import en12464
                t = en12464.lookup(default["room_type"])
                u0 = t.u0 if t is not None else u0
            return {"work_plane": {"lux": float(wp.Lux), "u0": u0}}
        return default

    def add_entry(self, entry=None):
        from PySide import QtGui
        cat = self.widget("catalogue")
        e = entry if isinstance(entry, dict) else {
            "name": f"Luminaire {cat.rowCount() + 1}", "flux_lm": 2000.0, "watts": 16.0}
        dim = e.get("dimming") or [1.0, 1.0]
        cells = [str(e.get("name", "")), f"{float(e.get('flux_lm', 0)):g}",
                 f"{float(e.get('watts', 0)):g}", f"{100.0 * float(dim[0]):g}",
                 str(e.get("photometry") or "")]
        row = cat.rowCount()
        cat.insertRow(row)
        for col, text in enumerate(cells):
            cat.setItem(row, col, QtGui.QTableWidgetItem(text))
        if entry is None or not isinstance(entry, dict):     # a new entry: edit it now
            cat.selectRow(row)

    def remove_entries(self):
        cat = self.widget("catalogue")
        for row in sorted({i.row() for i in cat.selectedIndexes()}, reverse=True):
            cat.removeRow(row)

    def _add_room_row(self, space, r):
        from PySide import QtCore, QtGui
        req = self.widget("requirements")
        row = req.rowCount()
        req.insertRow(row)
        from invrad_wb.app.rooms import room_name
        item = QtGui.QTableWidgetItem(room_name(space))
        item.setFlags(item.flags() & ~QtCore.Qt.ItemIsEditable)
        item.setData(QtCore.Qt.UserRole, space.Name)
        req.setItem(row, 0, item)
        wp = r.get("work_plane") if isinstance(r, dict) else None
        wp = {"lux": wp} if isinstance(wp, (int, float)) else (wp or {})
        kind = (r or {}).get("room_type") or (CUSTOM if wp.get("lux") else SKIP)
        kind_item = QtGui.QTableWidgetItem("")
        kind_item.setFlags(kind_item.flags() & ~QtCore.Qt.ItemIsEditable)
        req.setItem(row, 1, kind_item)
        req.setItem(row, 2, QtGui.QTableWidgetItem(f"{float(wp.get('lux', 500.0)):g}"))
        req.setItem(row, 3, QtGui.QTableWidgetItem(f"{float(wp.get('u0', 0.4)):g}"))
        self.set_room_type(row, kind)

    def room_type(self, row):
        from PySide import QtCore
        return self.widget("requirements").item(row, 1).data(QtCore.Qt.UserRole)

    def set_room_type(self, row, kind):
        """A room type shows (read-only) its EN 12464-1 Em and U0; Custom makes them
        editable; a room left out greys them."""
        from PySide import QtCore
        from invrad_wb.core.design import en12464
        req = self.widget("requirements")
        it = req.item(row, 1)
        it.setData(QtCore.Qt.UserRole, kind)
        it.setText(dict(self.types).get(kind, kind))
        for col in (2, 3):
            it = req.item(row, col)
            editable = kind == CUSTOM
            it.setFlags(it.flags() | QtCore.Qt.ItemIsEditable if editable else
                        it.flags() & ~QtCore.Qt.ItemIsEditable)
            if kind == SKIP:
                it.setText("-")
            elif kind != CUSTOM:
                t = en12464.lookup(kind)
                it.setText(f"{t.em_lux:g}" if col == 2 else f"{t.u0:g}")
            elif it.text() == "-":
                it.setText("500" if col == 2 else "0.4")

    def _selected_rows(self):
        req = self.widget("requirements")
        return sorted({i.row() for i in req.selectedIndexes()})

    def _selection_changed(self):
        rows = self._selected_rows()
        if rows:
            combo = self.widget("room_type")
            combo.blockSignals(True)
            set_value(combo, self.room_type(rows[0]))
            combo.blockSignals(False)

    def _room_type_chosen(self, *_):
        kind = get_value(self.widget("room_type"))
        for row in self._selected_rows():
            self.set_room_type(row, kind)

    def _mounting_changed(self, *_):
        self.widget("pendant_height_m").setEnabled(get_value(self.widget("mounting")) ==
                                                   "pendant")

    def spec(self):
        """The panel's DESIGN.json dict (not yet checked by the core)."""
        from invrad_wb.errors import SettingsError
        cat = self.widget("catalogue")
        entries = []
        for row in range(cat.rowCount()):
            text = [(cat.item(row, c).text().strip() if cat.item(row, c) else "")
                    for c in range(len(self.CAT_COLUMNS))]
            where = f"catalogue row {row + 1} ({text[0] or 'no name'})"
            try:
                flux, watts, dim = float(text[1]), float(text[2]), float(text[3] or 100)
            except ValueError:
                raise SettingsError(f"{where}: flux, power and dimming must be numbers,"
                                    f" got {text[1]!r}, {text[2]!r}, {text[3]!r}")
            e = {"name": text[0], "flux_lm": flux, "watts": watts,
                 "dimming": [dim / 100.0, 1.0]}
            if text[4]:
                e["photometry"] = text[4]
            entries.append(e)
        mount = get_value(self.widget("mounting"))
        mounting = mount if mount == "ceiling" else {
            "type": mount, "height_m": get_value(self.widget("pendant_height_m"))}
        plane = {"height_m": get_value(self.widget("height_m")),
                 "margin_m": get_value(self.widget("margin_m"))}
        req = self.widget("requirements")
        rooms = {}
        for row in range(req.rowCount()):
            label = req.item(row, 0).text()
            kind = self.room_type(row)
            if kind == SKIP:
                continue
            if kind == CUSTOM:
                try:
                    lux, u0 = float(req.item(row, 2).text()), float(req.item(row, 3).text())
                except ValueError:
                    raise SettingsError(f"room {label}: Em and U0 must be numbers, got"
                                        f" {req.item(row, 2).text()!r},"
                                        f" {req.item(row, 3).text()!r}")
                rooms[label] = {"work_plane": {"lux": lux, "u0": u0, **plane},
                                "mounting": mounting}
            else:
                rooms[label] = {"room_type": kind, "work_plane": dict(plane),
                                "mounting": mounting}
        return {"maintenance_factor": get_value(self.widget("maintenance_factor")),
                "catalogue": entries, "rooms": rooms}

    def check(self):
        """(spec dict, run options), checked by the core's parser; SettingsError names the
        row or key at fault."""
        from invrad_wb.app.design import spec_from_data
        from invrad_wb.app.rooms import check_resolution
        from invrad_wb.errors import SettingsError
        spec = self.spec()
        if not spec["rooms"]:
            raise SettingsError("no room to design: give at least one room a room type or"
                                " a custom Em / U0")
        base = os.path.dirname(self.doc.FileName) if self.doc.FileName else os.getcwd()
        spec_from_data(spec, "design panel", base)
        run = {k: get_value(self.widget(k)) for k in self.RUN_FIELDS}
        check_resolution(run["resolution_m"])
        return spec, run

    # ---------------------------------------------------------------- files
    def open_spec(self, path=None):
        """Fill the panel from a DESIGN.json file (a file dialog without ``path``)."""
        import json
        if path is None:
            from PySide import QtGui
            path, _ = QtGui.QFileDialog.getOpenFileName(
                self.form, "Open design spec", "", "Design spec (*.json);;All files (*)")
            if not path:
                return
        try:
            with open(path, "r", encoding="utf-8") as fh:
                data = json.load(fh)
            if not isinstance(data, dict) or "catalogue" not in data:
                raise ValueError("no catalogue in it")
            base = os.path.dirname(os.path.abspath(path))
            for e in data.get("catalogue") or []:
                p = e.get("photometry") if isinstance(e, dict) else None
                if p and not os.path.isabs(p):
                    e["photometry"] = os.path.join(base, p)
        except (OSError, ValueError) as exc:
            messages.exception("Open design spec", ValueError(f"{path}: {exc}"))
            return
        self.show_spec(data)

    def save_spec(self, path=None):
        """Write the panel's spec as DESIGN.json (atomically; a file dialog without
        ``path``)."""
        import json
        from invrad_wb.core.io.atomic import atomic_write_text
        try:
            spec, _ = self.check()
        except Exception as exc:
            messages.exception("Save design spec", exc)
            return
        if path is None:
            from PySide import QtGui
            path, _ = QtGui.QFileDialog.getSaveFileName(
                self.form, "Save design spec", "design.json",
                "Design spec (*.json);;All files (*)")
            if not path:
                return
        atomic_write_text(path, json.dumps(spec, indent=1))

    # ---------------------------------------------------------------- dialog
    def getStandardButtons(self):
        from PySide import QtGui
        from invrad_wb.gui.qtcompat import flag_int
        return flag_int(QtGui.QDialogButtonBox.Ok | QtGui.QDialogButtonBox.Cancel)

    def accept(self):
        import FreeCADGui
        try:
            spec, run = self.check()
        except Exception as exc:
            messages.exception("Design lighting", exc)
            return False
        params.save_design(spec)
        params.save_run(run)
        from PySide import QtCore
        rooms = [sp.Name for sp in self.selected] or None
        line = _call("invrad_wb.gui.runner.design", doc_src(self.doc), spec=spec,
                     rooms=rooms, run=run)
        FreeCADGui.Control.closeDialog()
        QtCore.QTimer.singleShot(0, lambda: do_command("import invrad_wb.gui.runner", line))
        return True

    def reject(self):
        import FreeCADGui
        FreeCADGui.Control.closeDialog()
        return True
