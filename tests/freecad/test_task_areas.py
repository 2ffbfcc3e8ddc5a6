"""Task areas entered in FreeCAD: outlines drawn on the plan become the task areas of a
room's work plane (metres in the design spec), from a selection or a targets file."""
import json
import sys
import types
import unittest

import numpy as np

import FreeCAD

from fctest import FreeCADTestCase, make_box_space
from invrad_wb.app import design, document, targets
from invrad_wb.app.rooms import room_name
from invrad_wb.errors import SceneError

CATALOGUE = [{"name": "DL", "flux_lm": 2000, "watts": 16}]


def _rectangle(doc, x0, y0, x1, y1, z=0.0, label=None):
    """A Draft rectangle drawn on the plan, corners in mm."""
    import Draft
    pl = FreeCAD.Placement(FreeCAD.Vector(x0, y0, z), FreeCAD.Rotation())
    r = Draft.makeRectangle(x1 - x0, y1 - y0, placement=pl)
    if label:
        r.Label = label
    doc.recompute()
    return r


def _shape(doc, shape, label):
    obj = doc.addObject("Part::Feature", "Outline")
    obj.Shape = shape
    obj.Label = label
    doc.recompute()
    return obj


class TestTaskAreas(FreeCADTestCase):

    def setUp(self):
        super().setUp()
        self.space = make_box_space(self.doc, hi=(6, 4, 2.7), label="Office")
        self.desks = _rectangle(self.doc, 800, 800, 3200, 2400, z=0.0, label="desk row")

    def _spec(self, room):
        """The DesignSpec the design receives for a room dict (as the design panel builds
        it: its label as the key, then the document's task areas put in)."""
        room = design.with_task_areas(room, self.space)
        data = {"catalogue": CATALOGUE, "rooms": {room_name(self.space): room}}
        spec = design.spec_from_data(data, "design panel", self.tmp)
        return room, spec.room_spec(self.space.Name, room_name(self.space))

    def test_selected_outlines_reach_the_design_spec_in_metres(self):
        import Part
        targets.set_work_plane(self.space, 500.0, margin_m=0.5)
        table = _shape(self.doc, Part.Face(Part.Wire(Part.makeCircle(
            400.0, FreeCAD.Vector(4800, 2000, 750)))), "round table")
        n = self.doc.UndoCount
        space, outlines = targets.task_area_selection(
            self.doc, [(self.space, []), (self.desks, []), (table, [])])
        self.assertIs(space, self.space)
        wp = targets.set_task_areas(space, outlines, lux=[None, 300.0])
        self.assertEqual(self.doc.UndoCount, n + 1)               # one undo step
        room, rs = self._spec({"work_plane": {"lux": 500, "u0": 0.6, "height_m": 0.75,
                                              "margin_m": 0.5}})
        self.assertNotIn("margin_m", room["work_plane"])     # the areas replace the margin
        areas = {a.name: a for a in rs.work_plane.task_areas}
        self.assertEqual(set(areas), {"desk row", "round table"})
        np.testing.assert_allclose(sorted(map(tuple, areas["desk row"].polygon)),
                                   [(0.8, 0.8), (0.8, 2.4), (3.2, 0.8), (3.2, 2.4)],
                                   atol=1e-9)
        self.assertIsNone(areas["desk row"].lux)                # the work plane's 500 lx
        self.assertEqual(rs.work_plane.lux, 500.0)
        self.assertEqual(areas["round table"].lux, 300.0)
        r = np.hypot(*(np.asarray(areas["round table"].polygon) - (4.8, 2.0)).T)
        np.testing.assert_allclose(r, 0.4, atol=0.006)        # the circle, within 5 mm
        self.assertAlmostEqual(areas["round table"].area_m2, np.pi * 0.16, delta=0.01)
        # the outline follows the drawing: moved 1 m, the area moves
        self.desks.Placement.Base = FreeCAD.Vector(1800, 800, 0)
        self.doc.recompute()
        _, rs = self._spec({"room_type": "office"})
        moved = [a for a in rs.work_plane.task_areas if a.name == "desk row"][0]
        self.assertAlmostEqual(min(x for x, _ in moved.polygon), 1.8, places=9)
        self.doc.undo()
        self.doc.undo()
        self.assertEqual(list(wp.TaskAreas), [])
        self.assertEqual(design.with_task_areas({"room_type": "office"}, self.space),
                         {"room_type": "office"})

    def test_bad_selection_names_the_object_and_leaves_the_document(self):
        import Part
        targets.set_work_plane(self.space, 500.0)
        before = document.snapshot(self.doc)
        wall = _shape(self.doc, Part.makePlane(1000, 1000, FreeCAD.Vector(0, 0, 0),
                                               FreeCAD.Vector(1, 0, 0)), "wall sketch")
        line = _shape(self.doc, Part.makePolygon([FreeCAD.Vector(0, 0, 0),
                                                  FreeCAD.Vector(1000, 0, 0),
                                                  FreeCAD.Vector(1000, 900, 0)]), "open line")
        box = _shape(self.doc, Part.makeBox(500, 500, 500), "cabinet")
        before = document.snapshot(self.doc)
        for obj, words in ((wall, "is not horizontal"), (line, "not one closed outline"),
                           (box, "not one closed outline")):
            with self.assertRaisesMessage(SceneError, obj.Label, words):
                targets.set_task_areas(self.space, [self.desks, obj])
        with self.assertRaisesMessage(SceneError, "Face9", "cabinet"):
            targets.set_task_areas(self.space, [(box, ["Face9"])])
        self.assertUnchanged(before)
        # a box's top face is a task area (a desk modelled as a solid)
        targets.set_task_areas(self.space, [(box, ["Face6"])])
        self.assertEqual(targets.task_areas_m(targets.work_plane_target(self.space))[0]
                         ["name"], "cabinet Face6")

    def test_selection_needs_its_room_and_the_room_a_work_plane(self):
        with self.assertRaisesMessage(SceneError, "Office", "has no work plane"):
            targets.set_task_areas(self.space, [self.desks])
        make_box_space(self.doc, lo=(7, 0, 0), hi=(9, 3, 2.7), label="Store")
        with self.assertRaisesMessage(SceneError, "select the room", "2 rooms"):
            targets.task_area_selection(self.doc, [(self.desks, [])])
        with self.assertRaisesMessage(SceneError, "task-area outlines", "Office"):
            targets.task_area_selection(self.doc, [(self.space, [])])

    def test_a_deleted_or_broken_outline_is_refused_naming_the_target(self):
        targets.set_work_plane(self.space, 500.0)
        counter = _rectangle(self.doc, 4400, 2900, 5600, 3600, label="counter")
        wp = targets.set_task_areas(self.space, [self.desks, counter], lux=[None, 300.0])
        self.doc.removeObject(self.desks.Name)     # which lux was whose is now unknown
        self.doc.recompute()
        with self.assertRaisesMessage(SceneError, wp.Label, "TaskAreaLux has 2 values",
                                      "Set task areas"):
            design.with_task_areas({"room_type": "office"}, self.space)
        wp.TaskAreaLux = [300.0]
        areas = targets.task_areas_m(wp)
        self.assertEqual([(a["name"], a["lux"]) for a in areas], [("counter", 300.0)])
        # an outline turned upright after it was chosen: refused at design time
        counter.Placement.Rotation = FreeCAD.Rotation(FreeCAD.Vector(1, 0, 0), 90)
        self.doc.recompute()
        with self.assertRaisesMessage(SceneError, wp.Label, "counter", "not horizontal"):
            design.with_task_areas({"room_type": "office"}, self.space)

    def test_targets_file_task_areas_become_outlines_in_one_step(self):
        path = self.path("targets.json")
        rooms = {"Office": {"room_type": "office", "work_plane": {
            "height_m": 0.8, "task_areas": [
                {"name": "desks", "rect": [0.8, 0.8, 3.2, 2.4]},
                {"name": "counter", "polygon": [[4.4, 2.9], [5.6, 2.9], [5.6, 3.6],
                                                [4.4, 3.6]], "lux": 300}]}}}
        with open(path, "w") as fh:
            json.dump({"catalogue": CATALOGUE, "rooms": rooms}, fh)
        n = self.doc.UndoCount
        targets.apply_targets_file(self.doc, path)
        self.assertEqual(self.doc.UndoCount, n + 1)
        wp = targets.work_plane_target(self.space)
        self.assertEqual(wp.Lux, 500.0)                    # the office's Em
        self.assertEqual([o.Label for o, _ in wp.TaskAreas], ["desks", "counter"])
        self.assertEqual(list(wp.TaskAreaLux), [0.0, 300.0])
        for o, _ in wp.TaskAreas:          # drawn at the work plane's height
            self.assertAlmostEqual(o.Shape.BoundBox.ZMin, 800.0, places=6)
        areas = targets.task_areas_m(wp)
        self.assertEqual(areas[1], {"name": "counter", "polygon": [[4.4, 2.9], [5.6, 2.9],
                                                                   [5.6, 3.6], [4.4, 3.6]],
                                    "lux": 300.0})
        # the design run reads the file's spec itself: the same areas, in metres
        rs = design.spec_from_targets_file(path).room_spec(self.space.Name, "Office")
        self.assertEqual([a.name for a in rs.work_plane.task_areas], ["desks", "counter"])
        # saved and re-opened, the links hold
        self.doc.saveAs(self.path("room.FCStd"))
        space_name = self.space.Name
        FreeCAD.closeDocument(self.doc.Name)
        self.doc = FreeCAD.openDocument(self.path("room.FCStd"))
        sp = self.doc.getObject(space_name)
        self.assertEqual(targets.task_areas_m(targets.work_plane_target(sp)), areas)
        # replace: the file's outlines go with the old work plane
        with open(path, "w") as fh:
            json.dump({"rooms": {"Office": {"replace": True, "work_plane": 300}}}, fh)
        targets.apply_targets_file(self.doc, path)
        self.assertEqual([o for o in self.doc.Objects if o.Name.startswith("TaskArea")], [])

    def test_targets_file_errors_name_the_task_area(self):
        path = self.path("bad.json")
        before = document.snapshot(self.doc)
        for wp, words in (({"lux": 500, "margin_m": 0.5, "task_areas": [
                            {"name": "desks", "rect": [0, 0, 1, 1]}]}, "not both"),
                          ({"lux": 500, "task_areas": [{"name": "desks",
                                                        "rect": [2, 0, 1, 1]}]},
                           "task_areas.desks.rect")):
            with open(path, "w") as fh:
                json.dump({"rooms": {"Office": {"work_plane": wp}}}, fh)
            with self.assertRaisesMessage(SceneError, "rooms.Office", words):
                targets.apply_targets_file(self.doc, path)
        self.assertUnchanged(before)


def _qt():
    """(QtUiTools, QtWidgets) of the PySide FreeCAD runs on, or None."""
    for mod in ("PySide6", "PySide2"):
        try:
            uitools = __import__(f"{mod}.QtUiTools", fromlist=["x"])
            widgets = __import__(f"{mod}.QtWidgets", fromlist=["x"])
            return uitools, widgets
        except ImportError:
            continue
    return None


class PanelTestCase(FreeCADTestCase):
    """A task panel under freecadcmd, FreeCADGui stood in for (its form loader; a test may
    add more to ``self.fake_gui``), the panel's settings in a group of their own
    (``PARAM_GROUP``) and a 6 x 4 m space labelled Office."""
    PARAM_GROUP = "InvRadPanelTest"

    def setUp(self):
        super().setUp()
        qt = _qt()
        if qt is None:
            self.skipTest("no PySide QtUiTools")
        uitools, widgets = qt
        self.app = widgets.QApplication.instance() or widgets.QApplication([])
        from invrad_wb.gui import params
        self.params, self._root = params, params.ROOT
        params.ROOT = f"User parameter:BaseApp/Preferences/Mod/{self.PARAM_GROUP}"
        params.reset()
        self.fake_gui = types.ModuleType("FreeCADGui")
        self.fake_gui.PySideUic = types.SimpleNamespace(
            loadUi=lambda path: uitools.QUiLoader().load(path))
        self._saved = sys.modules.get("FreeCADGui")
        sys.modules["FreeCADGui"] = self.fake_gui
        self.space = make_box_space(self.doc, hi=(6, 4, 2.7), label="Office")

    def tearDown(self):
        if self._saved is None:
            sys.modules.pop("FreeCADGui", None)
        else:
            sys.modules["FreeCADGui"] = self._saved
        self.params.reset()
        FreeCAD.ParamGet("User parameter:BaseApp/Preferences/Mod").RemGroup(
            self.PARAM_GROUP)
        self.params.ROOT = self._root
        super().tearDown()


class TestTaskAreasGui(PanelTestCase):
    """The command and the design panel under freecadcmd, FreeCADGui stood in for (its
    form loader, selection and doCommand; the panel's settings in a group of their own)."""
    PARAM_GROUP = "InvRadTaskAreasTest"

    def setUp(self):
        super().setUp()
        self.lines, console = [], {"App": FreeCAD, "FreeCAD": FreeCAD}

        def do(line):              # FreeCAD's Python console: one namespace for all lines
            self.lines.append(line)
            exec(line, console)
        self.fake_gui.doCommand = do
        self.desks = _rectangle(self.doc, 800, 800, 3200, 2400, label="desk row")

    def _select(self, *items):
        from invrad_wb.gui import selection
        sel = [types.SimpleNamespace(Object=o, SubElementNames=list(subs))
               for o, subs in items]
        saved = selection.current
        selection.current = lambda: sel
        self.addCleanup(setattr, selection, "current", saved)

    def test_command_records_set_task_areas_and_the_panel_designs_for_them(self):
        from invrad_wb.gui import commands, designpanel, messages
        targets.set_work_plane(self.space, 500.0)
        self._select((self.space, []), (self.desks, []))
        messages.LOG.clear()
        commands.TaskAreas().Activated()
        self.assertEqual(messages.LOG, [])
        self.assertTrue(any("set_task_areas(" in ln for ln in self.lines), self.lines)
        wp = targets.work_plane_target(self.space)
        self.assertEqual([o for o, _ in wp.TaskAreas], [self.desks])
        panel = designpanel.DesignPanel(self.doc, [self.space])
        spec, _ = panel.check()
        wpd = spec["rooms"]["Office"]["work_plane"]
        self.assertNotIn("margin_m", wpd)
        self.assertEqual(wpd["task_areas"], [{"name": "desk row", "polygon": [
            [0.8, 0.8], [3.2, 0.8], [3.2, 2.4], [0.8, 2.4]]}])

    def test_command_with_a_bad_selection_says_why_and_changes_nothing(self):
        from invrad_wb.gui import commands, messages
        targets.set_work_plane(self.space, 500.0)
        before = document.snapshot(self.doc)
        self._select((self.space, []))
        messages.LOG.clear()
        commands.TaskAreas().Activated()
        self.assertEqual(len(messages.LOG), 1, messages.LOG)
        level, title, text = messages.LOG[0]
        self.assertEqual((level, title), ("error", "Set task areas"))
        self.assertIn("select the task-area outlines of room 'Office'", text)
        self.assertUnchanged(before)
