"""The Design task panel: a luminaire catalogue, per-room requirements, run options.

Its catalogue and requirements are a DESIGN.json spec (the same as ``python -m invrad_wb
design`` and ``freecad --targets`` read); laid out for FreeCAD's default task view (the
catalogue's names whole, the selected entry's numbers in a form below; the requirements'
room, Em and U0 in the table, the room type in a drop-down below it).
"""
import json
import os

from invrad_wb.gui import messages, params
from invrad_wb.gui.taskpanel import (Panel, _call, do_command, doc_src, fill_combo,
                                     get_value, set_value)

#: Mounting choices of the design panel (value, label).
MOUNTINGS = [("ceiling", "Ceiling"), ("pendant", "Pendant")]
#: The requirement table's "room type" for rooms designed to an Em/U0 of their own, and
#: for rooms left out.
CUSTOM, SKIP = "custom", "skip"
#: a room's keys that the requirements table shows (the others are kept, not shown)
ROOM_COLUMNS_KEYS = ("work_plane", "room_type", "mounting")
#: the item data role (Qt.UserRole + 1) that holds a room's other keys, as JSON
ROOM_EXTRA_ROLE = 0x0100 + 1


class DesignPanel(Panel):
    """Design from requirements: a catalogue, per-room requirements, run options.

    The catalogue and requirements are a DESIGN.json spec (the same as ``python -m
    invrad_wb design`` and ``freecad --targets`` read); OK checks it with the core's
    parser (an error names the row and value), stores it and records
    :func:`invrad_wb.gui.runner.design` with it spelled out.
    """

    UI = "design.ui"

    CAT_COLUMNS = ("name", "flux_lm", "watts", "dim_percent", "photometry", "size_mm")
    #: entry keys the table shows (dim_percent is the entry's "dimming", size_mm the
    #: luminous opening's diameter, its "radius_m")
    TABLE_KEYS = ("name", "flux_lm", "watts", "dimming", "photometry", "radius_m")
    #: Catalogue columns shown in the table (the names, whole); the others are edited in
    #: the form below it for the selected entry (a second column cut the names to
    #: "Downlight 100..." in the default task view).
    CAT_SHOWN = 1
    #: The catalogue entry's form: widget -> column.
    ENTRY_FIELDS = (("entry_flux", 1), ("entry_watts", 2), ("entry_dim", 3),
                    ("entry_photometry", 4), ("entry_size", 5))
    #: The requirements table shows room, Em and U0; the room type (column 1) is the
    #: drop-down below it for the selected rooms, and the room name's tooltip.
    REQ_HIDDEN = (1,)
    RUN_FIELDS = ("resolution_m", "interreflection", "backend", "replace")

    def __init__(self, doc, rooms=None):
        from invrad_wb.app.rooms import find_spaces, room_name
        from invrad_wb.core.design import en12464
        self.doc = doc
        self._load("design.svg")
        self.form.setWindowTitle("Design lighting")
        self.selected = list(rooms or [])
        self.spaces = self.selected or find_spaces(doc)
        self.types = [(CUSTOM, "Custom Em / U0"), (SKIP, "(not designed)")] + [
            (n, n.replace("_", " "))
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
        for name, _ in self.ENTRY_FIELDS:
            w = self.widget(name)
            (w.textChanged if name == "entry_photometry" else w.valueChanged).connect(
                self._entry_edited)
        # the room names take the width left, the numbers their own
        from PySide import QtGui
        fit, stretch = QtGui.QHeaderView.ResizeToContents, QtGui.QHeaderView.Stretch
        req = self.widget("requirements")
        for col in self.REQ_HIDDEN:
            req.setColumnHidden(col, True)
        head = req.horizontalHeader()
        head.setStretchLastSection(False)
        for col, mode in ((0, stretch), (2, fit), (3, fit)):
            head.setSectionResizeMode(col, mode)
        cat.horizontalHeader().setStretchLastSection(True)
        self.show_spec(params.load_design())
        self._run_toggle(run)

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
        # what the panel has no field for (a project's name, default operating hours...)
        # goes back into the spec as the file gave it
        self._spec_extra = {k: v for k, v in spec.items()
                            if k not in ("maintenance_factor", "catalogue", "rooms")}
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
                 str(e.get("photometry") or ""),
                 f"{2000.0 * float(e.get('radius_m') or 0.0):g}"]
        row = cat.rowCount()
        cat.insertRow(row)
        for col, text in enumerate(cells):
            cat.setItem(row, col, QtGui.QTableWidgetItem(text))
        # what the table has no column for (luminous size, mounting, heights) stays with
        # the entry: the name cell carries it, spec() gives it back
        extra = {k: v for k, v in e.items() if k not in self.TABLE_KEYS}
        if extra:
            from PySide import QtCore
            cat.item(row, 0).setData(QtCore.Qt.UserRole, json.dumps(extra))
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
        # the room's keys the table has no column for (its own catalogue, ugr_max, walls,
        # ceiling, cylindrical, background, operating hours...): kept as the file gave them
        extra = {k: v for k, v in (r or {}).items() if k not in ROOM_COLUMNS_KEYS}
        item.setData(ROOM_EXTRA_ROLE, json.dumps(extra) if extra else "")
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
        req.item(row, 0).setToolTip(f"Room type: {it.text()}")
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
            try:
                size_mm = float(text[5] or 0.0)
            except ValueError:
                size_mm = 0.0
            where = f"catalogue row {row + 1} ({text[0] or 'no name'})"
            try:
                flux, watts, dim = float(text[1]), float(text[2]), float(text[3] or 100)
            except ValueError:
                raise SettingsError(f"{where}: flux, power and dimming must be numbers,"
                                    f" got {text[1]!r}, {text[2]!r}, {text[3]!r}")
            e = {}
            from PySide import QtCore
            extra = cat.item(row, 0).data(QtCore.Qt.UserRole) if cat.item(row, 0) else None
            if extra:
                e.update(json.loads(extra))
            e.update({"name": text[0], "flux_lm": flux, "watts": watts,
                      "dimming": [dim / 100.0, 1.0]})
            if text[4]:
                e["photometry"] = text[4]
            if size_mm > 0:          # none: a point (the file's own opening, if any)
                e["radius_m"] = size_mm / 2000.0
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
            extra = req.item(row, 0).data(ROOM_EXTRA_ROLE)
            extra = json.loads(extra) if extra else {}
            if kind == CUSTOM:
                try:
                    lux, u0 = float(req.item(row, 2).text()), float(req.item(row, 3).text())
                except ValueError:
                    raise SettingsError(f"room {label}: Em and U0 must be numbers, got"
                                        f" {req.item(row, 2).text()!r},"
                                        f" {req.item(row, 3).text()!r}")
                rooms[label] = {**extra, "work_plane": {"lux": lux, "u0": u0, **plane},
                                "mounting": mounting}
            else:
                rooms[label] = {**extra, "room_type": kind, "work_plane": dict(plane),
                                "mounting": mounting}
            # the task areas drawn in the document (Set task areas) replace the margin
            from PySide import QtCore
            from invrad_wb.app.design import with_task_areas
            space = self.doc.getObject(req.item(row, 0).data(QtCore.Qt.UserRole) or "")
            if space is not None:
                rooms[label] = with_task_areas(rooms[label], space)
        return {**getattr(self, "_spec_extra", {}),
                "maintenance_factor": get_value(self.widget("maintenance_factor")),
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
    def _ask_path(self, how, title, start):
        """A file dialog's answer (QFileDialog.<how>), '' when cancelled."""
        from PySide import QtGui
        path, _ = getattr(QtGui.QFileDialog, how)(
            self.form, title, start, "Catalogue and requirements (*.json);;All files (*)")
        return path

    def open_spec(self, path=None):
        """Fill the panel from a DESIGN.json file (a file dialog without ``path``)."""
        import json
        path = path or self._ask_path("getOpenFileName", "Open requirements", "")
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
            messages.exception("Open requirements", ValueError(f"{path}: {exc}"))
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
            messages.exception("Save requirements", exc)
            return
        path = path or self._ask_path("getSaveFileName", "Save requirements", "design.json")
        if not path:
            return
        atomic_write_text(path, json.dumps(spec, indent=1))

    # ---------------------------------------------------------------- dialog
    def accept(self):
        return self._accept("Design lighting", self._save)

    def _save(self, spec, run):
        params.save_design(spec)
        params.save_run(run)
        rooms = [sp.Name for sp in self.selected] or None
        line = _call("invrad_wb.gui.runner.design", doc_src(self.doc), spec=spec,
                     rooms=rooms, run=run)
        return lambda: do_command("import invrad_wb.gui.runner", line)

