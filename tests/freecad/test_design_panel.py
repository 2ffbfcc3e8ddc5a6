"""The design panel's catalogue form under freecadcmd (FreeCADGui stood in for: its form
loader only): what an architect types for an entry is what the design gets."""
import sys
import types

import FreeCAD

from fctest import FreeCADTestCase, make_box_space
from test_task_areas import _qt


class TestDesignPanelCatalogue(FreeCADTestCase):

    def setUp(self):
        super().setUp()
        qt = _qt()
        if qt is None:
            self.skipTest("no PySide QtUiTools")
        uitools, widgets = qt
        self.app = widgets.QApplication.instance() or widgets.QApplication([])
        from invrad_wb.gui import params
        self.params, self._root = params, params.ROOT
        params.ROOT = "User parameter:BaseApp/Preferences/Mod/InvRadDesignPanelTest"
        params.reset()
        fake = types.ModuleType("FreeCADGui")
        fake.PySideUic = types.SimpleNamespace(
            loadUi=lambda path: uitools.QUiLoader().load(path))
        self._saved = sys.modules.get("FreeCADGui")
        sys.modules["FreeCADGui"] = fake
        self.space = make_box_space(self.doc, hi=(6, 4, 2.7), label="Office")

    def tearDown(self):
        if self._saved is None:
            sys.modules.pop("FreeCADGui", None)
        else:
            sys.modules["FreeCADGui"] = self._saved
        self.params.reset()
        FreeCAD.ParamGet("User parameter:BaseApp/Preferences/Mod").RemGroup(
            "InvRadDesignPanelTest")
        self.params.ROOT = self._root
        super().tearDown()

    def test_luminous_size_is_shown_and_edited_for_each_entry(self):
        # UGR needs a luminous area: without one an entry is rated as a CIE 147 small
        # source (an upper bound no office limit of 19 admits). The panel kept the default
        # panels' 0.3 m radius hidden and gave an added entry none, with no field to say it
        from invrad_wb.gui import designpanel
        panel = designpanel.DesignPanel(self.doc, [self.space])
        size = panel.widget("entry_size")
        cat = panel.widget("catalogue")
        cat.selectRow(0)
        self.assertAlmostEqual(size.value(), 600.0)        # "Panel 1000 lm": r 0.3 m
        spec, _ = panel.check()
        self.assertEqual([e.get("radius_m") for e in spec["catalogue"]], [0.3, 0.3, 0.3])
        panel.add_entry()                      # a new entry: selected, a point until given
        new = cat.rowCount() - 1
        self.assertEqual(size.value(), 0.0)
        self.assertEqual(size.specialValueText(), "point")
        self.assertNotIn("radius_m", panel.check()[0]["catalogue"][new])
        size.setValue(200.0)                   # a downlight's 200 mm opening
        spec, _ = panel.check()
        self.assertAlmostEqual(spec["catalogue"][new]["radius_m"], 0.1)
        cat.selectRow(1)                       # another entry: its own size, unchanged
        self.assertAlmostEqual(size.value(), 600.0)
        size.setValue(0.0)                     # "point": the key goes, none is invented
        self.assertNotIn("radius_m", panel.check()[0]["catalogue"][1])
        self.assertAlmostEqual(panel.check()[0]["catalogue"][new]["radius_m"], 0.1)
