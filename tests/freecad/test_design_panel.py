"""The design panel's catalogue form under freecadcmd (FreeCADGui stood in for: its form
loader only): what an architect types for an entry is what the design gets."""
from test_task_areas import PanelTestCase


class TestDesignPanelCatalogue(PanelTestCase):
    PARAM_GROUP = "InvRadDesignPanelTest"

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

    def test_a_rooms_keys_without_a_column_come_back_from_the_panel(self):
        # FZK's example gives rooms their own catalogue and a UGR limit: the panel rebuilt
        # each room from its row (type, Em, U0) and dropped them, so the GUI designed the
        # Bad with 600 mm panels and the Kueche without its UGR 22
        from invrad_wb.gui import designpanel
        panel = designpanel.DesignPanel(self.doc, [self.space])
        spec, _ = panel.check()
        names = [e["name"] for e in spec["catalogue"]]
        room = {"work_plane": {"lux": 400, "u0": 0.5}, "catalogue": names[:1],
                "ugr_max": 22, "walls": {"lux": 90, "u0": 0.2}, "operating_hours": 2000}
        panel.show_spec({**spec, "project": "Haus", "rooms": {"Office": room}})
        out, _ = panel.check()
        got = out["rooms"]["Office"]
        self.assertEqual(got["catalogue"], names[:1])
        self.assertEqual(got["ugr_max"], 22)
        self.assertEqual(got["walls"], {"lux": 90, "u0": 0.2})
        self.assertEqual(got["operating_hours"], 2000)
        self.assertEqual((got["work_plane"]["lux"], got["work_plane"]["u0"]), (400, 0.5))
        self.assertEqual(out["project"], "Haus")
        # the room type chosen in the panel still rules its Em and U0; the keys stay
        panel.widget("requirements").selectRow(0)
        panel.set_room_type(0, "office")
        got = panel.check()[0]["rooms"]["Office"]
        self.assertEqual((got["room_type"], got["ugr_max"]), ("office", 22))
        self.assertNotIn("lux", got["work_plane"])
