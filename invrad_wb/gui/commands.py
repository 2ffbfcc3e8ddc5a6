"""The workbench's commands (toolbar and menu "InvRad").

One class per command with ``GetResources``/``Activated``/``IsActive``; :func:`register`
adds them all to FreeCAD and does nothing without a GUI. Actions that change the
document are run through ``Gui.doCommand`` (directly, or by the task panel's OK), so that
macros record them:

==========================  ==========================================================
InvRad_SetTarget            target on the selected faces of a room (task panel: uniform,
                            spot, illuminance image, shade, work plane)
InvRad_MarkShade            the selected faces must stay dark (0 lx)
InvRad_TaskAreas            the selected outlines become the task areas of the selected
                            room's work plane (design)
InvRad_ToggleTargets        show/hide the targets in false colour (a view overlay)
InvRad_ToggleDeviation      switch the achieved illuminance to its deviation from the
                            targets and back
InvRad_Locate               locate luminaires for the selected rooms or all rooms with
                            targets (task panel with every setting, then progress)
InvRad_Repeak               new threshold/neighbourhood on the stored votes
InvRad_Verify               forward solve + report + metrics spreadsheet
InvRad_Settings             the locate settings, without running
==========================  ==========================================================
"""
import os

from invrad_wb import constants as C
from invrad_wb.gui import messages

ICON_DIR = os.path.join(C.RESOURCES_DIR, "icons")
WORKBENCH_ICON = os.path.join(ICON_DIR, "invrad.svg")


def icon(name):
    return os.path.join(ICON_DIR, name)


def _active_doc():
    import FreeCAD
    return FreeCAD.ActiveDocument


def _no_task_dialog():
    import FreeCADGui
    try:
        return not FreeCADGui.Control.activeDialog()
    except Exception:
        return True


def _busy():
    from invrad_wb.gui import progress
    return progress.busy()


class _Command:
    """Common parts: resources and the usual 'a document is open' activity."""

    NAME = ""
    PIXMAP = ""
    MENU = ""
    TIP = ""
    ACCEL = ""

    def GetResources(self):
        res = {"Pixmap": icon(self.PIXMAP), "MenuText": self.MENU, "ToolTip": self.TIP}
        if self.ACCEL:
            res["Accel"] = self.ACCEL
        return res

    def IsActive(self):
        return _active_doc() is not None and not _busy()


class SetTarget(_Command):
    NAME = "InvRad_SetTarget"
    PIXMAP = "set_target.svg"
    MENU = "Set lighting target"
    TIP = ("Ask for an illuminance on the selected faces of a room: uniform lux, a spot,"
           " an illuminance image, or the room's work plane (select the room itself)")

    def Activated(self):
        import FreeCADGui
        from invrad_wb.gui import selection, taskpanel
        try:
            try:
                groups, point = selection.room_faces()
            except Exception:
                rooms = selection.rooms()
                if len(rooms) == 1 and not any(s.SubElementNames
                                               for s in selection.current()):
                    panel = taskpanel.TargetPanel(rooms[0], [], kind="WorkPlane")
                    FreeCADGui.Control.showDialog(panel)
                    return
                raise
            if len(groups) > 1:
                from invrad_wb.errors import SceneError
                raise SceneError("the selected faces belong to "
                                 f"{len(groups)} rooms; select faces of one room")
            space, faces = groups[0]
            FreeCADGui.Control.showDialog(taskpanel.TargetPanel(space, faces, point))
        except Exception as exc:
            messages.exception(self.MENU, exc)

    def IsActive(self):
        return super().IsActive() and _no_task_dialog()


class MarkShade(_Command):
    NAME = "InvRad_MarkShade"
    PIXMAP = "mark_shade.svg"
    MENU = "Mark shade"
    TIP = "The selected faces of a room must stay dark (a 0 lx target)"

    def Activated(self):
        from invrad_wb.gui import selection
        from invrad_wb.gui.taskpanel import _call, do_command, obj_src
        try:
            groups, _ = selection.room_faces()
            lines = ["import invrad_wb.app.targets"]
            for space, faces in groups:
                lines.append(_call("invrad_wb.app.targets.add_shade_target",
                                   obj_src(space), faces))
            do_command(*lines)
        except Exception as exc:
            messages.exception(self.MENU, exc)


class TaskAreas(_Command):
    NAME = "InvRad_TaskAreas"
    PIXMAP = "task_areas.svg"
    MENU = "Set task areas"
    TIP = ("Make the selected closed outlines (Draft rectangles or wires drawn on the plan,"
           " or a desk's top face) the task areas of the selected room's work plane: the"
           " design lights them, their surroundings and background (instead of the room"
           " less a border zone)")

    def Activated(self):
        from invrad_wb.app.targets import task_area_selection
        from invrad_wb.gui import selection
        from invrad_wb.gui.taskpanel import _Src, _call, do_command, obj_src
        try:
            items = [(s.Object, list(s.SubElementNames)) for s in selection.current()]
            space, outlines = task_area_selection(_active_doc(), items)
            src = _Src("[" + ", ".join(str(obj_src(o)) if sub is None else
                                       f"({obj_src(o)}, [{sub!r}])"
                                       for o, sub in outlines) + "]")
            do_command("import invrad_wb.app.targets",
                       _call("invrad_wb.app.targets.set_task_areas", obj_src(space), src))
        except Exception as exc:
            messages.exception(self.MENU, exc)


class ToggleTargets(_Command):
    NAME = "InvRad_ToggleTargets"
    PIXMAP = "toggle_targets.svg"
    MENU = "Show/hide targets"
    TIP = ("Show the lighting targets in false colour on the room surfaces, with a legend"
           " (display only: nothing is added to the document)")

    def Activated(self):
        from invrad_wb.gui.taskpanel import do_command
        doc = _active_doc()
        do_command("import invrad_wb.gui.display",
                   f"invrad_wb.gui.display.toggle_targets(App.getDocument({doc.Name!r}))")


class ToggleDeviation(_Command):
    NAME = "InvRad_ToggleDeviation"
    PIXMAP = "toggle_deviation.svg"
    MENU = "Show/hide deviation"
    TIP = ("Switch the achieved illuminance (after Verify and report or Design) to its"
           " deviation from the targets, -50 % (blue, too dark) to +50 % (red, too"
           " bright), and back")

    def Activated(self):
        from invrad_wb.gui.taskpanel import do_command
        doc = _active_doc()
        do_command("import invrad_wb.gui.display",
                   f"invrad_wb.gui.display.toggle_deviation(App.getDocument({doc.Name!r}))")

    def IsActive(self):
        from invrad_wb.gui import display
        doc = _active_doc()
        return doc is not None and not _busy() and display.has_achieved(doc)


class _PanelCommand(_Command):
    """A command that opens a task panel for the selected rooms (or every room):
    ``PANEL`` names its class, ``"<module of invrad_wb.gui>.<class>"``."""

    PANEL = ""

    def Activated(self):
        import importlib
        import FreeCADGui
        from invrad_wb.gui import selection
        module, cls = self.PANEL.rsplit(".", 1)
        try:
            panel = getattr(importlib.import_module(f"invrad_wb.gui.{module}"), cls)
            FreeCADGui.Control.showDialog(panel(_active_doc(), selection.rooms()))
        except Exception as exc:
            messages.exception(self.MENU, exc)

    def IsActive(self):
        return super().IsActive() and _no_task_dialog()


class Locate(_PanelCommand):
    NAME, PIXMAP, MENU = "InvRad_Locate", "locate.svg", "Locate luminaires"
    PANEL = "taskpanel.LocatePanel"
    TIP = ("Find where luminaires of the given flux must go to light the selected rooms"
           " (or every room with targets) as asked, and insert them as light fixtures")


class Design(_PanelCommand):
    NAME, PIXMAP, MENU = "InvRad_Design", "design.svg", "Design lighting"
    PANEL = "designpanel.DesignPanel"
    TIP = ("Choose luminaires from a catalogue, and how many go where, to meet each room's"
           " requirement (Em, U0 on the work plane; EN 12464-1 room types) with the fewest"
           " watts; insert them as light fixtures and write the client report")


class Repeak(_Command):
    NAME = "InvRad_Repeak"
    PIXMAP = "repeak.svg"
    MENU = "Recalculate peaks"
    TIP = ("Find the luminaires again from the last run's votes with another threshold"
           " or neighbourhood (no new voting) and replace the fixtures")

    def Activated(self):
        import FreeCADGui
        from invrad_wb.gui import taskpanel
        try:
            FreeCADGui.Control.showDialog(taskpanel.RepeakPanel(_active_doc()))
        except Exception as exc:
            messages.exception(self.MENU, exc)

    def IsActive(self):
        from invrad_wb.gui import runner
        return super().IsActive() and _no_task_dialog() and \
            runner.stored(_active_doc()) is not None


class Verify(_Command):
    NAME = "InvRad_Verify"
    PIXMAP = "verify.svg"
    MENU = "Verify and report"
    TIP = ("Compute the illuminance of the light fixtures in the document (with"
           " interreflection), write an HTML/CSV report with false-colour images and put"
           " the per-room metrics into a spreadsheet")

    def Activated(self):
        from invrad_wb.gui import selection
        from invrad_wb.gui.taskpanel import _call, do_command, doc_src
        doc = _active_doc()
        rooms = [r.Name for r in selection.rooms()] or None
        do_command("import invrad_wb.gui.runner",
                   _call("invrad_wb.gui.runner.verify", doc_src(doc), rooms=rooms))


class Settings(_Command):
    NAME, PIXMAP, MENU = "InvRad_Settings", "settings.svg", "Locate settings..."
    TIP = "Every locate setting (kept between sessions), without running"

    def Activated(self):
        import FreeCADGui
        from invrad_wb.gui import taskpanel
        try:
            FreeCADGui.Control.showDialog(taskpanel.LocatePanel(_active_doc(), run=False))
        except Exception as exc:
            messages.exception(self.MENU, exc)

    def IsActive(self):
        return _no_task_dialog() and not _busy()


COMMANDS = [SetTarget, MarkShade, TaskAreas, ToggleTargets, ToggleDeviation, Locate, Design, Repeak,
            Verify, Settings]
#: Toolbar and menu layout ("Separator" between groups).
TOOLBAR = ["InvRad_SetTarget", "InvRad_MarkShade", "InvRad_TaskAreas",
           "InvRad_ToggleTargets", "InvRad_ToggleDeviation", "Separator",
           "InvRad_Locate", "InvRad_Design", "InvRad_Repeak", "InvRad_Verify"]
MENU = TOOLBAR + ["Separator", "InvRad_Settings"]
CONTEXT = ["InvRad_SetTarget", "InvRad_MarkShade", "InvRad_Locate", "InvRad_Design"]

_registered = False
_observer = None


def register():
    """Add every command to FreeCAD (once); returns their names, [] without a GUI."""
    global _registered
    import FreeCAD
    if not FreeCAD.GuiUp:
        return []
    import FreeCADGui
    if not _registered:
        for cls in COMMANDS:
            FreeCADGui.addCommand(cls.NAME, cls())
        _install_observer()
        _registered = True
    return [cls.NAME for cls in COMMANDS]


class DocumentObserver:
    """Keeps the workbench's in-memory state in step with the documents.

    * a closed document's stored locate result and overlay are forgotten;
    * a shown target display is rebuilt (shortly after, once) when a target or a room
      changes, is added or is deleted (undo/redo included);
    * when only a room's contents change (fixtures inserted by Locate or Design, or taken
      out by an undo), its targets are the same: only the room names move clear of the
      fixtures. Rebuilding the display there re-meshed the whole building in the GUI
      thread after every run (FZK-Haus: minutes, the GUI frozen, on a busy machine).
    """

    def __init__(self):
        self._pending = {}              # document name -> "labels" or "display"

    def _relevant(self, obj):
        from invrad_wb.app.document import object_type
        try:
            return object_type(obj) in ("InvRadTarget", "Space")
        except Exception:
            return False

    def _schedule(self, obj, what="display"):
        from invrad_wb.gui import display
        try:
            doc = obj.Document
        except Exception:
            return
        if not display.is_shown(doc, "targets"):
            return
        before = self._pending.get(doc.Name)
        if before is not None:
            if what == "display":
                self._pending[doc.Name] = what          # the whole display wins
            return
        self._pending[doc.Name] = what
        from PySide import QtCore
        name = doc.Name
        QtCore.QTimer.singleShot(300, lambda: self._refresh(name))

    def _refresh(self, name):
        import FreeCAD
        from invrad_wb.gui import display
        what = self._pending.pop(name, "display")
        if name in FreeCAD.listDocuments():
            doc = FreeCAD.getDocument(name)
            if what == "labels":
                display.relabel(doc)
            else:
                display.refresh(doc)

    def slotCreatedObject(self, obj):
        if self._relevant(obj):
            self._schedule(obj)

    def slotDeletedObject(self, obj):
        if self._relevant(obj):
            self._schedule(obj)

    def slotChangedObject(self, obj, prop):
        if prop in ("Label", "Label2", "ExpressionEngine", "Visibility"):
            return
        if self._relevant(obj):
            self._schedule(obj, "labels" if self._contents_only(obj, prop) else "display")

    #: a room's properties that Locate and Design change with its contents (fixtures
    #: grouped in it, its IFC data, the areas FreeCAD recomputes), not its targets
    CONTENTS_PROPS = ("Group", "_GroupTouched", "IfcData", "IfcProperties",
                      "ElevationWithFlooring", "VerticalArea", "HorizontalArea", "Area",
                      "PerimeterLength")

    def _contents_only(self, obj, prop):
        """Whether this change leaves the room's targets as they are: its contents, or
        its solid recomputed to what it was (a recompute after an insert)."""
        from invrad_wb.app.document import object_type
        from invrad_wb.gui import display
        try:
            if object_type(obj) != "Space":
                return False
            if prop in self.CONTENTS_PROPS:
                return True
            return (prop in ("Shape", "Placement")
                    and not display.room_geometry_changed(obj.Document, obj))
        except Exception:
            return False

    def slotDeletedDocument(self, doc):
        from invrad_wb.gui import display, runner
        runner.forget(doc.Name)
        display.forget(doc.Name)


def _install_observer():
    global _observer
    import FreeCAD
    if _observer is None:
        _observer = DocumentObserver()
        FreeCAD.addDocumentObserver(_observer)
