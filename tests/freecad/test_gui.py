"""The workbench's GUI part: resources, start-up, settings, display, selection, actions.

Most tests run headless under freecadcmd (the GUI modules import FreeCADGui, PySide and
pivy only inside their functions); :class:`TestGuiUnderXvfb` starts the real GUI under
Xvfb with ``tests/freecad/gui_smoke.py --quick`` (every command once, screenshots) and is
skipped where ``xvfb-run`` or ``freecad`` is missing or ``INVRAD_NO_GUI`` is set.
"""
import dataclasses
import json
import os
import shutil
import sys
import types
import xml.dom.minidom

import numpy as np

import FreeCAD

from fctest import (ROOT, FreeCADTestCase, down, make_box_space, make_walled_room,
                    needs_locate)
from invrad_wb.app import document, fixtures, pipeline, results, targets
from invrad_wb.app.pipeline import PipelineSettings
from invrad_wb.core.inverse.locate import LocateSettings
from invrad_wb.core.model.luminaires import Luminaire
from invrad_wb.errors import SceneError
from invrad_wb.gui import (commands, designpanel, display, messages, params, runner,
                           selection, taskpanel)

TEST_ROOT = "User parameter:BaseApp/Preferences/Mod/InvRadTest"


class ParamsIsolated(FreeCADTestCase):
    """Settings go to a parameter group of their own, removed afterwards."""

    def setUp(self):
        super().setUp()
        self._root = params.ROOT
        params.ROOT = TEST_ROOT
        params.reset()
        messages.LOG.clear()

    def tearDown(self):
        params.reset()
        FreeCAD.ParamGet("User parameter:BaseApp/Preferences/Mod").RemGroup("InvRadTest")
        params.ROOT = self._root
        super().tearDown()


def _ui_widgets(path):
    dom = xml.dom.minidom.parse(path)
    return {w.getAttribute("name"): w.getAttribute("class")
            for w in dom.getElementsByTagName("widget") if w.getAttribute("name")}


class TestResources(FreeCADTestCase):

    def test_every_command_has_an_svg_icon_and_texts(self):
        names = set()
        for cls in commands.COMMANDS:
            self.assertTrue(cls.NAME.startswith("InvRad_"), cls.NAME)
            res = cls().GetResources()
            self.assertTrue(res["MenuText"] and res["ToolTip"], cls.NAME)
            self.assertTrue(res["Pixmap"].endswith(".svg") and os.path.isfile(res["Pixmap"]),
                            res["Pixmap"])
            svg = xml.dom.minidom.parse(res["Pixmap"]).documentElement
            self.assertEqual(svg.tagName, "svg")
            names.add(cls.NAME)
        self.assertEqual(len(names), len(commands.COMMANDS))
        for entry in commands.TOOLBAR + commands.MENU + commands.CONTEXT:
            self.assertTrue(entry == "Separator" or entry in names, entry)
        self.assertTrue(os.path.isfile(commands.WORKBENCH_ICON))

    def test_no_two_widgets_share_a_layout_cell(self):
        # (a row moved between groups once landed on another's row: Qt then squeezed the
        # check box into the field column, its text cut)
        for ui in ("design.ui", "locate_settings.ui", "target.ui", "repeak.ui"):
            dom = xml.dom.minidom.parse(taskpanel.ui_path(ui))
            for lay in dom.getElementsByTagName("layout"):
                cells = set()
                for it in lay.childNodes:
                    if getattr(it, "tagName", "") != "item" or not it.getAttribute("row"):
                        continue
                    r, c = int(it.getAttribute("row")), int(it.getAttribute("column"))
                    for k in range(c, c + int(it.getAttribute("colspan") or 1)):
                        self.assertNotIn((r, k), cells, f"{ui}: row {r} column {k}")
                        cells.add((r, k))

    def test_locate_panel_has_a_widget_for_every_setting(self):
        widgets = _ui_widgets(taskpanel.ui_path("locate_settings.ui"))
        for f in dataclasses.fields(LocateSettings):
            self.assertIn(f.name, widgets, f"locate_settings.ui lacks {f.name}")
        for name in taskpanel.LocatePanel.RUN_FIELDS + ("rooms_label", "reset_defaults"):
            self.assertIn(name, widgets)
        for name, choices in params.CHOICES.items():
            self.assertEqual(widgets[name], "QComboBox", name)
        # optional settings: a spin box whose minimum reads "auto"
        dom = xml.dom.minidom.parse(taskpanel.ui_path("locate_settings.ui"))
        special = {w.getAttribute("name") for w in dom.getElementsByTagName("widget")
                   for p in w.childNodes
                   if getattr(p, "tagName", "") == "property"
                   and p.getAttribute("name") == "specialValueText"}
        self.assertEqual(special, set(params.OPTIONAL))

    def test_design_panel_form_and_default_spec(self):
        w = _ui_widgets(taskpanel.ui_path("design.ui"))
        for name in designpanel.DesignPanel.RUN_FIELDS + (
                "rooms_label", "catalogue", "requirements", "add_entry", "remove_entry",
                "load_spec", "save_spec", "maintenance_factor", "height_m", "margin_m",
                "mounting", "pendant_height_m"):
            self.assertIn(name, w)
        self.assertEqual((w["catalogue"], w["requirements"]), ("QTableWidget", "QTableWidget"))
        # the panel's first spec is one the core accepts
        from invrad_wb.app.design import spec_from_data
        spec = spec_from_data(params.load_design(), "default", ".")
        self.assertEqual(spec.room_spec(0, "any room").room_type, "office")
        params.save_design({"catalogue": [{"name": "X", "flux_lm": 1.0, "watts": 1.0}],
                            "rooms": {"*": {"work_plane": 100}}})
        self.assertEqual(params.load_design()["catalogue"][0]["name"], "X")

    def test_target_and_repeak_panels(self):
        w = _ui_widgets(taskpanel.ui_path("target.ui"))
        for name in ("kind", "lux", "centre_x", "centre_y", "centre_z", "radius_m",
                     "falloff", "image", "browse", "lux_scale", "height_m", "margin_m",
                     "group_spot", "group_texture", "group_work_plane", "room_label",
                     "faces_label"):
            self.assertIn(name, w)
        w = _ui_widgets(taskpanel.ui_path("repeak.ui"))
        self.assertEqual((w["threshold"], w["neighbourhood_m"]),
                         ("QDoubleSpinBox", "QDoubleSpinBox"))

    def test_package_xml_declares_the_workbench_and_its_python_dependencies(self):
        meta = FreeCAD.Metadata(os.path.join(ROOT, "package.xml"))
        self.assertTrue(meta.supportsCurrentFreeCAD())
        (wb,) = meta.Content["workbench"]
        self.assertEqual(wb.Classname, "InvRadWorkbench")
        self.assertEqual(wb.Subdirectory, "./")
        self.assertTrue(os.path.isfile(os.path.join(ROOT, wb.Icon)))
        self.assertTrue(os.path.isfile(os.path.join(ROOT, meta.Icon)))
        deps = {d["package"]: d for d in meta.Depend}
        # only what the Addon Manager installs itself (its allow-list); the rest is
        # invrad's own installer's (tests/test_packaging.py checks both)
        for name in ("numpy", "scipy", "matplotlib"):
            self.assertIn(name, deps)
        # no numpy<2 cap: FreeCAD 1.x brings numpy 2 (0.20's pin is the setup's business)
        self.assertFalse(deps["numpy"].get("version_lt"))
        self.assertEqual(deps["numpy"]["version_gte"], "1.24")


class _FakeWorkbench:
    def appendToolbar(self, name, cmds):        # noqa: N802 - FreeCAD's own names
        self.toolbar = (name, list(cmds))

    def appendMenu(self, name, cmds):           # noqa: N802
        self.menu = (name, list(cmds))


class TestInitGui(FreeCADTestCase):
    """InitGui.py as FreeCAD 0.20 runs it: exec() inside a function, no __file__."""

    def run_initgui(self):
        added = []
        fake = types.ModuleType("FreeCADGui")
        fake.Workbench = _FakeWorkbench
        fake.addWorkbench = added.append
        path = os.path.join(ROOT, "InitGui.py")
        saved_path, saved_mod = list(sys.path), sys.modules.get("FreeCADGui")
        sys.modules["FreeCADGui"] = fake
        before = set(sys.modules)

        def runner_like_freecad(Dir):            # noqa: N803 - FreeCAD's own name
            with open(path, encoding="utf-8") as f:
                exec(f.read())
        try:
            runner_like_freecad(ROOT)
            path_after = list(sys.path)
        finally:
            if saved_mod is None:
                sys.modules.pop("FreeCADGui", None)
            else:
                sys.modules["FreeCADGui"] = saved_mod
            sys.path[:] = saved_path
        self.path_after = path_after
        return added, {m for m in set(sys.modules) - before if m.startswith("invrad_wb")}

    def test_registers_the_workbench_without_importing_the_package(self):
        added, loaded = self.run_initgui()
        self.assertEqual(loaded, set(), "InitGui.py must not import the package")
        (wb,) = added
        self.assertEqual(type(wb).__name__, "InvRadWorkbench")
        self.assertEqual(wb.GetClassName(), "Gui::PythonWorkbench")
        self.assertEqual(wb.MenuText, "InvRad")
        self.assertTrue(os.path.isfile(wb.Icon), wb.Icon)

    def test_start_up_leaves_sys_path_alone_and_initialize_appends(self):
        """FreeCAD 0.20's GUI clears PYTHONPATH; the venv and $INVRAD_SITE_PACKAGES are
        appended on activation only, after everything else (other workbenches' imports
        stay what they were)."""
        os.environ["INVRAD_SITE_PACKAGES"] = self.tmp + os.pathsep + "/nonexistent/x"
        saved = list(sys.path)
        try:
            (wb,), _ = self.run_initgui()
            self.assertEqual(self.path_after, saved)
            wb.Initialize()
            after = list(sys.path)
        finally:
            del os.environ["INVRAD_SITE_PACKAGES"]
            sys.path[:] = saved
        self.assertEqual(after[:len(saved)], saved)
        self.assertIn(self.tmp, after[len(saved):])
        self.assertNotIn("/nonexistent/x", after)
        self.assertEqual(wb.toolbar[0], "InvRad")
        self.assertIn("InvRad_Locate", wb.menu[1])

    def test_register_does_nothing_without_a_gui(self):
        self.assertFalse(FreeCAD.GuiUp)
        self.assertEqual(commands.register(), [])


class TestParams(ParamsIsolated):

    def test_defaults_are_the_core_defaults(self):
        self.assertEqual(params.load_locate(), dataclasses.asdict(LocateSettings()))
        run = params.load_run()
        self.assertEqual(run["flux_lm"], 3000.0)
        self.assertTrue(run["interreflection"])
        from invrad_wb.app.pipeline import PipelineSettings
        self.assertIs(run["zones"], PipelineSettings(flux_lm=1.0).zones)
        self.assertIs(params.pipeline_settings().zones, True)
        params.save_run({"zones": False})
        self.assertIs(params.pipeline_settings().zones, False)

    def test_round_trip_of_every_kind(self):
        loc = dict(vote_model="ellipse", pixel_m=0.05, votes_per_m2=250.0,
                   weighting="both", occlusion=False, dummy_planes=False, dummy_count=3,
                   dummy_lowest_m=0.0, two_sided_dummies=True, threshold=100.0,
                   neighbourhood_m=0.5, refine=False, optimiser="es", indirect="none",
                   max_candidates=12, shade_limit_lux=5.0, seed=7)
        params.save_locate(loc)
        got = params.load_locate()
        for k, v in loc.items():
            self.assertEqual(got[k], v, k)
            self.assertEqual(type(got[k]), type(v), k)
        params.save_locate({"occlusion": True, "votes_per_m2": None, "dummy_count": None})
        got = params.load_locate()
        self.assertIs(got["occlusion"], True)
        self.assertIsNone(got["votes_per_m2"])
        self.assertIsNone(got["dummy_count"])
        LocateSettings.from_dict(got)

    def test_a_bad_stored_value_falls_back_to_its_default_only(self):
        params.save_locate({"threshold": 100.0, "seed": 3})
        params.group("Locate").SetFloat("threshold", 999.0)
        params.group("Locate").SetString("vote_model", "nonsense")
        got = params.load_locate()
        self.assertEqual(got["threshold"], LocateSettings().threshold)
        self.assertEqual(got["vote_model"], "exact")
        self.assertEqual(got["seed"], 3)

    def test_pipeline_settings(self):
        params.save_run({"flux_lm": 1234.0, "resolution_m": 0.25, "backend": "numpy"})
        s = params.pipeline_settings(rooms=["Space"], run={"replace": False},
                                     locate={"threshold": 50.0})
        self.assertIsInstance(s, PipelineSettings)
        self.assertEqual((s.flux_lm, s.resolution_m, s.backend, s.replace, s.rooms),
                         (1234.0, 0.25, "numpy", False, ["Space"]))
        self.assertEqual(s.locate["threshold"], 50.0)

    def test_design_and_verify_write_to_separate_report_folders(self):
        # unsaved, saved, and under a chosen report folder: never the same folder, so
        # a design's client report and a verification report never replace each other
        kinds = ("verify", "design")
        unsaved = [runner.default_report_dir(self.doc, k) for k in kinds]
        self.doc.saveAs(self.path("house.FCStd"))
        saved = [runner.default_report_dir(self.doc, k) for k in kinds]
        params.save_run({"report_dir": self.path("reports")})
        chosen = [runner.default_report_dir(self.doc, k) for k in kinds]
        for verify_dir, design_dir in (unsaved, saved, chosen):
            self.assertNotEqual(os.path.normpath(verify_dir), os.path.normpath(design_dir))
            self.assertFalse(design_dir.startswith(verify_dir + os.sep))
            self.assertFalse(verify_dir.startswith(design_dir + os.sep))
        self.assertEqual(saved, [self.path("house_invrad_report"),
                                 self.path("house_invrad_design")])
        self.assertTrue(all(d.startswith(self.path("reports")) for d in chosen))
        with self.assertRaises(ValueError):
            runner.default_report_dir(self.doc, "locate")

    def test_progress_messages_in_plain_words(self):
        from invrad_wb.gui.progress import PLAIN_WORDS, plain_words
        self.assertEqual(plain_words("Küche: vote maps"), "Küche: looking for positions")
        self.assertEqual(plain_words("cancelled: Office: votes"),
                         "cancelled: Office: weighing positions")
        self.assertEqual(plain_words("forward solve: 4 luminaire(s)"),
                         "computing the light: 4 luminaire(s)")
        self.assertEqual(plain_words("Office: design"), "Office: design")
        for method, _ in PLAIN_WORDS:
            said = plain_words(f"Bad: {method}").lower()
            self.assertNotIn("vote", said)
            self.assertNotIn("peak", said)


class TestDisplayNumpy(FreeCADTestCase):

    def test_colours(self):
        v = np.array([np.nan, 0.0, 250.0, 500.0, 900.0])
        rgb = display.colours(v, 500.0)
        np.testing.assert_allclose(rgb[0], display.NO_TARGET_RGB)
        np.testing.assert_allclose(rgb[1], display.SHADE_RGB)
        np.testing.assert_allclose(rgb[3], display.VIRIDIS[-1])
        np.testing.assert_allclose(rgb[4], display.VIRIDIS[-1])     # clipped
        np.testing.assert_allclose(rgb[2], display.VIRIDIS[4])
        # outside target mode, 0 is the bottom of the scale
        np.testing.assert_allclose(display.colours(v, 500.0, targets=False)[1],
                                   display.VIRIDIS[0])

    def test_colours_match_the_report_images(self):
        try:
            from invrad_wb.core.output import images
            ref = images.false_colour(np.linspace(0, 500, 11), 0.0, 500.0)
        except (ImportError, AttributeError, TypeError) as exc:
            self.skipTest(f"report images not available: {exc}")
        got = np.round(display.colours(np.linspace(0, 500, 11), 500.0, targets=False) * 255)
        np.testing.assert_allclose(got, ref, atol=1)

    def test_scale_and_legend(self):
        self.assertEqual([display.nice_max(x) for x in (0, 1, 480, 500, 501, 730, 9e3)],
                         [1.0, 1.0, 500.0, 500.0, 600.0, 800.0, 1e4])
        lay = display.legend_layout("Target\nilluminance (lx)", 500.0,
                                    [(display.SHADE_RGB, "0 (shade)")], over=True)
        ys = [y for y, _ in lay["ticks"]]
        self.assertEqual(ys, sorted(ys))
        self.assertEqual(lay["ticks"][-1][1], "500+")
        x0, y0, x1, y1 = lay["panel"]
        self.assertTrue(-1 <= x0 < x1 <= 1 and -1 <= y0 < y1 <= 1)
        for y, _, _ in lay["swatches"]:
            self.assertTrue(y0 < y < lay["bar"][1])

    def test_a_storey_view_cuts_just_under_the_ceilings(self):
        # two rooms of one storey under one flat ceiling: one plane, 3 cm under it,
        # keeping what lies below (coin keeps normal . p >= distance)
        a = make_walled_room(self.doc, size=(4.0, 3.0, 2.7))
        b = make_walled_room(self.doc, size=(4.0, 3.0, 2.7), origin=(4.0, 0.0, 0.0))
        self.doc.recompute()
        planes = display.ceiling_planes([a, b])
        self.assertEqual(len(planes), 1)
        normal, dist = planes[0]
        np.testing.assert_allclose(normal, [0.0, 0.0, -1.0], atol=1e-9)
        top = a.Shape.BoundBox.ZMax
        self.assertAlmostEqual(-dist, top - 1000.0 * display.STOREY_CLIP_BELOW_M, places=3)
        for z, kept in ((top - 100.0, True), (top + 10.0, False)):
            self.assertEqual(float(np.dot(normal, [1000.0, 1000.0, z])) >= dist, kept)

    def test_overlay_geometry_of_a_room(self):
        space = make_walled_room(self.doc, size=(4.0, 3.0, 2.7))
        targets.set_work_plane(space, 500.0)
        targets.add_uniform_target(space, "walls", 150.0)
        b = pipeline.prepare(self.doc, PipelineSettings(flux_lm=1.0, resolution_m=0.2))
        g = display.overlay_geometry(b, b.scene.vertex_lux, offset_m=0.01)
        sc = b.scene
        self.assertEqual(len(g["surfaces"]) + len(g["work_plane"]), len(sc.faces))
        self.assertEqual(g["vmax"], 500.0)
        # every point moved 10 mm into the room
        moved = g["points"] / 1000.0 - sc.vertices
        np.testing.assert_allclose(np.linalg.norm(moved, axis=1), 0.01, atol=1e-9)
        floor = (np.abs(sc.vertices[:, 2]) < 1e-9) & (sc.vertex_normals[:, 2] > 0.5)
        self.assertTrue(floor.any())
        np.testing.assert_allclose(g["points"][floor, 2], 10.0)
        # outlines: the floor's boundary is the room's perimeter (3.8 m x 2.8 m inside)
        groups = display.face_groups(b)
        p = b.rooms[0]
        floor_face = int(targets._faces_arg(space, "floor")[0][4:]) - 1
        sel = groups == floor_face
        e = display.boundary_edges(sc.faces[sel], groups[sel])
        length = np.linalg.norm(sc.vertices[e[:, 0]] - sc.vertices[e[:, 1]], axis=1).sum()
        self.assertAlmostEqual(length, 2 * (3.8 + 2.8), places=6)
        self.assertEqual(int((groups == groups.max()).sum()), p.n_work_plane)
        ((name, (x, y, z)),) = display.room_labels(b)
        self.assertEqual(name, "Office")
        # 0.3 m below the 2.7 m ceiling, in the room's open top seen from above; the name's
        # box is kept clear of the walls in the top and the isometric view at once, which
        # in an empty 4 x 3 m room leaves it near the middle
        self.assertAlmostEqual(z, 2400.0, places=6)
        self.assertLess(np.hypot(x - 2000.0, y - 1500.0), 250.0)


    def test_boundary_edges_per_group(self):
        faces = np.array([[0, 1, 2], [0, 2, 3]])
        def sides(e):
            return sorted(tuple(sorted(x)) for x in e.tolist())
        square = [(0, 1), (0, 3), (1, 2), (2, 3)]
        for big in (0, 3_000_000, 3_000_000_000):   # one int64 key; past it, rows
            for groups in ([5, 5], [-1, -1]):
                e = display.boundary_edges(faces + big, np.array(groups))
                self.assertEqual(sides(e - big), square)
            # two groups: each triangle whole, the diagonal once for each
            e = display.boundary_edges(faces + big, np.array([-1, 7]))
            self.assertEqual(sides(e - big), sorted(square + [(0, 2), (0, 2)]))

    def test_subdivide_is_conforming(self):
        # two triangles of a unit square; split one: its neighbour is split in two
        pts = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
        tris = np.array([[0, 1, 2], [0, 2, 3]])
        nrm = np.tile([0.0, 0.0, 1.0], (4, 1))
        p2, t2, parent, n2 = display.subdivide(pts, tris, np.array([True, False]), nrm)
        self.assertEqual(len(t2), 4 + 2)
        self.assertEqual(sorted(parent.tolist()), [0, 0, 0, 0, 1, 1])
        np.testing.assert_allclose(n2, np.tile([0.0, 0.0, 1.0], (len(p2), 1)))
        area = 0.5 * np.linalg.norm(np.cross(p2[t2[:, 1]] - p2[t2[:, 0]],
                                             p2[t2[:, 2]] - p2[t2[:, 0]]), axis=1)
        self.assertAlmostEqual(area.sum(), 1.0)
        self.assertTrue(np.all(np.cross(p2[t2[:, 1]] - p2[t2[:, 0]],
                                        p2[t2[:, 2]] - p2[t2[:, 0]])[:, 2] > 0))  # winding
        # no T-junction: every edge is used twice, or once on the square's outline
        e = np.sort(np.concatenate([t2[:, [0, 1]], t2[:, [1, 2]], t2[:, [2, 0]]]), axis=1)
        _, cnt = np.unique(e, axis=0, return_counts=True)
        self.assertEqual(int((cnt == 1).sum()), 6)    # 4 sides, the 2 of the split one halved
        self.assertTrue(np.all(cnt <= 2))

    def test_spot_edge_is_smooth_on_the_display_mesh(self):
        space = make_walled_room(self.doc, size=(4.0, 3.0, 2.7))
        wall = targets._faces_arg(space, "walls")[0]
        targets.set_work_plane(space, 500.0)
        b0 = pipeline.prepare(self.doc, PipelineSettings(flux_lm=1.0, resolution_m=0.2))
        p = b0.rooms[0]
        face = int(wall[4:]) - 1
        v = p.mesh.vertices[np.unique(p.mesh.triangles[p.mesh.triangle_face == face])]
        centre = 0.5 * (v.min(axis=0) + v.max(axis=0))
        targets.add_spot_target(space, wall, tuple(centre), 0.6, 600.0)
        b = pipeline.prepare(self.doc, PipelineSettings(flux_lm=1.0, resolution_m=0.2))
        vmax = display.lux_scale(b.scene.vertex_lux)
        self.assertEqual(vmax, 1000.0)                         # 1.5 x 600 lx, rounded up
        m = display.target_mesh(b, vmax)

        def rim(verts, faces, vals):
            """Largest distance from the spot's circle of a vertex of a triangle that
            crosses the spot's edge (the height of the stair steps)."""
            t = faces[display.edge_triangles(vals[faces], vmax)]
            d = np.linalg.norm(verts[np.unique(t)] - centre, axis=1)
            return np.max(np.abs(d - 0.6))
        before = rim(b.scene.vertices, b.scene.faces, b.scene.vertex_lux)
        after = rim(m["vertices"], m["faces"], m["values"])
        self.assertGreater(before, 0.1)
        self.assertLess(after, before / 5)
        # the same targets where the meshes meet, and the same surface area
        sc = b.scene
        def area(vv, ff):
            return 0.5 * np.linalg.norm(np.cross(vv[ff[:, 1]] - vv[ff[:, 0]],
                                                 vv[ff[:, 2]] - vv[ff[:, 0]]), axis=1).sum()
        self.assertAlmostEqual(area(m["vertices"], m["faces"]), area(sc.vertices, sc.faces),
                               places=6)
        self.assertEqual(int(m["virtual"].sum()), int(np.sum(sc.face_virtual)))
        g = display.overlay_geometry(b, m["values"], vmax=vmax, mesh=m)
        self.assertEqual(len(g["rgb"]), len(m["vertices"]))
        self.assertGreater(len(m["faces"]), len(sc.faces))
        self.assertLess(len(m["faces"]), 3 * len(sc.faces))    # refined along the rim only
        # the deviation view draws on this mesh: the achieved light is carried along,
        # interpolated linearly (exact for a linear field), and the deviation's edge is
        # the targets' smooth one
        ach = 300.0 + 100.0 * sc.vertices[:, 0] - 50.0 * sc.vertices[:, 2]
        m2 = display.target_mesh(b, vmax, carry=[ach])
        np.testing.assert_array_equal(m2["faces"], m["faces"])
        np.testing.assert_allclose(m2["carried"][0], 300.0 + 100.0 * m2["vertices"][:, 0]
                                   - 50.0 * m2["vertices"][:, 2], rtol=1e-12)
        dev = display.deviation(m2["values"], m2["carried"][0])
        np.testing.assert_array_equal(np.isfinite(dev), np.isfinite(m2["values"]))
        # a rim fading to 0 lx is judged against 10 % of the mean target, not its own lux
        pos = m2["values"][np.isfinite(m2["values"]) & (m2["values"] > 0)]
        self.assertLess(np.nanmax(np.abs(dev)),
                        (m2["carried"][0].max() + pos.max()) / (0.1 * pos.mean()))

    def test_room_names_per_storey_and_clear_of_objects(self):
        import Part
        down_ = make_walled_room(self.doc, size=(4.0, 3.0, 2.7), label="Flur")
        up = make_walled_room(self.doc, size=(4.0, 3.0, 2.7), origin=(0.0, 0.0, 3.0),
                              label="Galerie")
        for sp in (down_, up):
            targets.set_work_plane(sp, 200.0)
        # a stair in the middle of the room below
        stair = self.doc.addObject("Part::Feature", "Stair")
        stair.Shape = Part.makeBox(800, 800, 2500, FreeCAD.Vector(1600, 1100, 0))
        self.doc.recompute()
        b = pipeline.prepare(self.doc, PipelineSettings(flux_lm=1.0, resolution_m=0.25))
        labels = display.room_labels(b)
        self.assertEqual([n for n, _ in labels], ["Flur", "Galerie"])
        (_, (x0, y0, z0)), (_, (x1, y1, z1)) = labels
        self.assertAlmostEqual(z0, 2400.0)        # 0.3 m under each storey's ceiling
        self.assertAlmostEqual(z1, 5400.0)
        # the name below keeps clear of the stair (its box is 1.6..2.4 x 1.1..1.9 m)
        self.assertFalse(1500 < x0 < 2500 and 1000 < y0 < 2000, (x0, y0))
        self.assertTrue(100 < x0 < 3900 and 100 < y0 < 2900)
        self.assertAlmostEqual(x1, 2000.0, delta=1e-6)     # nothing in the room above
        # seen whole (no clipping plane): the storey above hides the room below and
        # only its name is drawn, not both on top of each other
        self.assertEqual(display.label_visibility(b, labels).tolist(), [False, True])
        # a plan cut below the upper storey (keeps z <= 2480 mm): only the name below
        cut = [((0.0, 0.0, -1.0), -2480.0)]
        self.assertEqual(display.label_visibility(b, labels, cut).tolist(), [True, False])
        # a cut above both storeys keeps both rooms; the upper one still covers the lower
        high = [((0.0, 0.0, -1.0), -9000.0)]
        self.assertEqual(display.label_visibility(b, labels, high).tolist(), [False, True])

    def test_room_names_clear_of_pendant_rods_and_stairs_from_above_and_isometric(self):
        # a pendant hanging 1 m below the ceiling and a stair: the name's box keeps clear
        # of the luminaire, its rod and the stair in plan and in FreeCAD's isometric view
        # (where a rod stands over the name's point when they line up along the view)
        import Part
        from invrad_wb.gui import roomlabels
        room = make_walled_room(self.doc, size=(6.0, 4.0, 2.7), label="Wohnen")
        targets.set_work_plane(room, 300.0)
        stair = self.doc.addObject("Part::Feature", "Stair")
        stair.Shape = Part.makeCylinder(700, 2700, FreeCAD.Vector(1500, 2500, 0))
        self.doc.recompute()
        pend = [Luminaire([x, 2.0, 1.7], [0, 0, -1], 1500.0) for x in (2.5, 3.5, 4.5)]
        fixtures.insert_fixtures(self.doc, [(room, pend)])
        b = pipeline.prepare(self.doc, PipelineSettings(flux_lm=1.0, resolution_m=0.25))
        (name, (x, y, z)), = display.room_labels(b)
        label = np.array([x, y, z]) / 1000.0
        # what the name must not cover: the rods (luminaire to ceiling), the stair
        rods = np.array([[p.position[0], p.position[1], h] for p in pend
                         for h in np.linspace(1.7, 2.7, 11)])
        ang = np.linspace(0, 2 * np.pi, 24, endpoint=False)
        drum = np.array([[1.5 + 0.7 * np.cos(a), 2.5 + 0.7 * np.sin(a), h]
                         for a in ang for h in np.linspace(0.0, 2.0, 5)])
        # the name's half box (the same rule as room_labels: ~7 px a character)
        char = 6.4 / 70.0
        hx, hy = 0.5 * char * len(name), char
        for what, pts in (("rods", rods), ("stair", drum)):
            for view, flat in (("above", pts[:, :2]),
                               ("isometric", roomlabels.iso_shadow(pts, label[2]))):
                d = np.abs(flat - label[:2])
                inside = (d[:, 0] < hx) & (d[:, 1] < hy)
                self.assertFalse(inside.any(), f"{name} over the {what} seen {view}:"
                                 f" label {label.round(2)}, {flat[inside][:3]}")
        self.assertTrue(0.1 < label[0] < 5.9 and 0.1 < label[1] < 3.9, label)
        # the isometric shadow: a point 1 m above the name's height appears where a
        # point 1 m along the view's horizontal direction at its height does
        sh = roomlabels.iso_shadow([[0.0, 0.0, 3.0]], 2.0)
        np.testing.assert_allclose(sh, [[-1.0, 1.0]])

    def test_views_framed_on_the_rooms_right_of_the_legend(self):
        # an orthographic view from above and an isometric one: the rooms (not a far-off
        # site) fill the picture's height or the width right of the legend, whole
        from pivy import coin
        room = make_walled_room(self.doc, size=(6.0, 4.0, 2.7), label="Room")
        site = self.doc.addObject("Part::Feature", "Site")
        import Part
        site.Shape = Part.makeBox(60000, 60000, 10, FreeCAD.Vector(-30000, -30000, -20))
        self.doc.recompute()
        bb = room.Shape.BoundBox
        corners = np.array([[x, y, z] for x in (bb.XMin, bb.XMax) for y in (bb.YMin, bb.YMax)
                            for z in (bb.ZMin, bb.ZMax)])

        class View:
            def __init__(self, rot):
                self.cam = coin.SoOrthographicCamera()
                self.cam.orientation.setValue(rot)

            def getCameraNode(self):
                return self.cam

        top = coin.SbRotation()
        iso = coin.SbRotation(coin.SbVec3f(0, 0, 1), coin.SbVec3f(1, -1, 1))
        aspect = 4.0 / 3.0
        for name, rot in (("top", top), ("isometric", iso)):
            v = View(rot)
            self.assertTrue(display.frame_rooms(self.doc, v, aspect=aspect))
            cam = v.cam
            r = cam.orientation.getValue()
            ax = np.array([list(r.multVec(coin.SbVec3f(*a)).getValue())
                           for a in ((1, 0, 0), (0, 1, 0))])
            p = (corners - np.array(cam.position.getValue().getValue())) @ ax.T
            h = cam.height.getValue()
            w = h * aspect
            # normalised view coordinates: x in [-1, 1] across the width, y up
            x, y = 2 * p[:, 0] / w, 2 * p[:, 1] / h
            self.assertTrue((x >= -1 + display.LEGEND_STRIP - 1e-6).all() and (x <= 1).all()
                            and (np.abs(y) <= 1).all(), (name, x, y))
            fill = max((y.max() - y.min()) / 2,
                       (x.max() - x.min()) / (2 - display.LEGEND_STRIP))
            self.assertGreater(fill, 0.8, name)

    def test_deviation_view_numbers_colours_and_legend(self):
        from invrad_wb.core.output import images
        dev = display.deviation([500.0, 0.0, np.nan, 250.0], [600.0, 75.0, 10.0, 125.0])
        np.testing.assert_allclose(dev, [0.2, 75.0 / 375.0, np.nan, -0.5])
        rgb = display.deviation_colours(np.array([-0.5, 0.0, 0.5, np.nan, -2.0]), 0.5)
        np.testing.assert_allclose(rgb[0], images.diverging(np.array([-0.5]))[0] / 255.0)
        self.assertTrue(np.all(rgb[1] > 0.9))                  # on target: near white
        self.assertGreater(rgb[2, 0], rgb[2, 2])               # too bright: red
        self.assertGreater(rgb[0, 2], rgb[0, 0])               # too dark: blue
        np.testing.assert_allclose(rgb[4], rgb[0])             # beyond the scale: its end
        np.testing.assert_allclose(rgb[3], np.array(images.NAN_GREY) / 255.0)
        lay = display.legend_layout("Deviation from\ntarget", 0.5, [], vmin=-0.5,
                                    fmt=display.percent)
        self.assertEqual([t for _, t in lay["ticks"]],
                         ["-50 %", "-25 %", "0 %", "+25 %", "+50 %"])
        ys = [y for y, _ in lay["ticks"]]
        self.assertEqual(ys, sorted(ys))
        self.assertAlmostEqual(ys[0], lay["bar"][1])
        self.assertAlmostEqual(ys[-1], lay["bar"][3])

    def test_one_lux_scale_for_target_and_achieved_views(self):
        doc = types.SimpleNamespace(Name="ScaleTest")
        try:
            self.assertEqual(display.document_scale(doc, [500.0, np.nan, 150.0]), 800.0)
            # the achieved view's building samples the same targets a little differently
            self.assertEqual(display.document_scale(doc, [510.0, 150.0]), 800.0)
            self.assertEqual(display.document_scale(doc, [480.0]), 800.0)
            # a brighter target than the scale can show with headroom: a new scale
            self.assertEqual(display.document_scale(doc, [900.0]), 1500.0)
            self.assertEqual(display.document_scale(doc, [500.0]), 800.0)     # an undo
            self.assertEqual(display.document_scale(doc, [100.0]), 150.0)
        finally:
            display.forget(doc.Name)


class TestDocumentObserver(FreeCADTestCase):
    """A shown targets' display is rebuilt when targets or rooms change, only its names
    placed again when a room's contents change (Locate and Design insert fixtures)."""

    def test_contents_of_a_room_are_not_its_targets(self):
        space = make_walled_room(self.doc, label="Office")
        targets.set_work_plane(space, 500.0)
        self.doc.recompute()
        obs = commands.DocumentObserver()
        self.assertTrue(obs._contents_only(space, "Group"))
        self.assertTrue(obs._contents_only(space, "IfcData"))
        self.assertTrue(obs._contents_only(space, "PerimeterLength"))   # FreeCAD 1.0
        target = next(o for o in self.doc.Objects
                      if document.object_type(o) == "InvRadTarget")
        self.assertFalse(obs._contents_only(target, "Group"))
        # the solid: nothing shown to compare with -> rebuilt
        self.assertFalse(obs._contents_only(space, "Shape"))
        st = display._doc_state(self.doc, create=True)
        try:
            st.overlay = {"rooms": {space.Name: display.room_signature(space)}}
            # recomputed to the same solid (after an insert): the names only
            fixtures.insert_fixtures(self.doc, [(space, [down(2.0, 1.5)])])
            self.assertTrue(obs._contents_only(space, "Shape"))
            self.assertTrue(obs._contents_only(space, "Placement"))
            # another solid than the display's: rebuilt
            sig = display.room_signature(space)
            st.overlay["rooms"][space.Name] = (sig[0] + 1.0,) + sig[1:]
            self.assertFalse(obs._contents_only(space, "Shape"))
        finally:
            st.overlay = None


class TestSelection(FreeCADTestCase):

    def setUp(self):
        super().setUp()
        self.space = make_walled_room(self.doc, label="Office")
        self.walls = [o for o in self.doc.Objects if getattr(o, "IfcType", "") == "Wall"][0]

    def test_space_faces_and_picked_point(self):
        p = FreeCAD.Vector(1000, 1000, 0)
        groups, point = selection.room_faces([(self.space, ["Face1", "Face3"], [p])])
        self.assertEqual(groups, [(self.space, ["Face1", "Face3"])])
        self.assertEqual(point, p)

    def test_wall_faces_map_to_the_room(self):
        subs = [f"Face{i + 1}" for i, f in enumerate(self.walls.Shape.Faces)
                if selection.matching_space_faces(f, [self.space])]
        self.assertEqual(len(subs), 4)
        groups, _ = selection.room_faces([(self.walls, subs)])
        self.assertEqual(sorted(groups[0][1]), sorted(targets._faces_arg(self.space,
                                                                          "walls")))

    def test_outer_faces_and_empty_selections_are_refused(self):
        outer = [f"Face{i + 1}" for i, f in enumerate(self.walls.Shape.Faces)
                 if abs(f.normalAt(0, 0).z) < 0.5
                 and not selection.matching_space_faces(f, [self.space])]
        with self.assertRaisesMessage(SceneError, "not on the boundary of any room"):
            selection.room_faces([(self.walls, outer[:1])])
        with self.assertRaisesMessage(SceneError, "select one or more faces of a room"):
            selection.room_faces([(self.space, [])])

    def test_rooms_of_targets_fixtures_and_faces(self):
        store = make_box_space(self.doc, (6, 0, 0), (9, 3, 2.5), label="Store")
        t = targets.add_uniform_target(store, "floor", 100.0)
        (fx,) = fixtures.insert_fixtures(
            self.doc, [(self.space, [Luminaire([1, 1, 2.7], [0, 0, -1], 1000.0)])])
        self.assertEqual(selection.rooms([(t, [])]), [store])
        self.assertEqual(selection.rooms([(fx, []), (self.space, ["Face2"]), (t, [])]),
                         [self.space, store])


class TestResults(FreeCADTestCase):
    """The app-side functions the Recalculate/Verify commands call."""

    def setUp(self):
        super().setUp()
        self.office = make_walled_room(self.doc, label="Office")
        targets.set_work_plane(self.office, 500.0)
        targets.add_uniform_target(self.office, "walls", 150.0)
        self.settings = PipelineSettings(flux_lm=2000.0, resolution_m=0.4,
                                         interreflection=False)

    def test_verify_reads_the_fixtures_of_the_document(self):
        fixtures.insert_fixtures(self.doc, [(self.office, [down(1.2, 1.5), down(2.8, 1.5)])])
        before = document.snapshot(self.doc)
        vr = results.verify(self.doc, self.settings)
        self.assertUnchanged(before)
        self.assertEqual(len(vr.luminaires), 2)
        parts = {r["part"]: r for r in vr.rows}
        self.assertEqual(set(parts), {"all targets", "work plane", "surfaces"})
        wp = parts["work plane"]
        self.assertAlmostEqual(wp["target_em"], 500.0)
        self.assertTrue(0 < wp["emin"] <= wp["em"] <= wp["emax"])
        self.assertAlmostEqual(wp["u0"], wp["emin"] / wp["em"])
        self.assertEqual(parts["all targets"]["luminaires"], 2)
        # moving a fixture by hand changes the verification
        fx = fixtures.room_fixtures(self.office)[0]
        fx.Placement.Base = FreeCAD.Vector(400, 400, 2700)
        vr2 = results.verify(self.doc, self.settings)
        self.assertNotAlmostEqual(vr2.achieved.sum(), vr.achieved.sum())

    def test_sheet_is_one_undo_step_and_is_not_exported(self):
        fixtures.insert_fixtures(self.doc, [(self.office, [down(2.0, 1.5)])])
        vr = results.verify(self.doc, self.settings)
        n = self.doc.UndoCount
        sheet = results.write_sheet(self.doc, vr.rows, note="Report: x")
        self.assertEqual(self.doc.UndoCount, n + 1)
        self.assertEqual(sheet.get("A1"), "Room")
        self.assertEqual(sheet.get("A2"), "Office")
        col = "ABCDEFGHIJKLMNOP"[[k for k, _ in results.SHEET_COLUMNS].index("em")]
        self.assertAlmostEqual(float(sheet.get(f"{col}2")), vr.rows[0]["em"],
                               delta=0.06 * vr.rows[0]["em"])
        results.write_sheet(self.doc, vr.rows)               # replaced, not added
        self.assertEqual(len(self.doc.findObjects("Spreadsheet::Sheet")), 1)
        from invrad_wb.app import ifcexport
        self.assertTrue(ifcexport._is_internal(sheet))
        self.doc.undo()
        self.doc.undo()
        self.assertIsNone(self.doc.getObject(results.SHEET_NAME))

    def test_metrics_fallback_without_a_report(self):
        b = pipeline.prepare(self.doc, self.settings)
        t = b.scene.vertex_lux
        rows = results.room_metrics(b, t, np.nan_to_num(t) * 1.1, [])
        wp = [r for r in rows if r["part"] == "work plane"][0]
        self.assertAlmostEqual(wp["em"], 550.0)
        self.assertAlmostEqual(wp["rmse_pct"], 10.0)
        self.assertAlmostEqual(wp["max_rel_dev_pct"], 10.0)
        self.assertEqual(wp["within_tol_pct"], 100.0)

    def test_insert_refuses_a_deleted_room(self):
        b = pipeline.prepare(self.doc, self.settings)
        self.doc.removeObject(self.office.Name)
        with self.assertRaisesMessage(SceneError, "was deleted"):
            results.insert(self.doc, b, [])


class TestRunnerHeadless(ParamsIsolated):
    """The commands' actions under freecadcmd: same code, no dialogs, no thread."""

    def test_errors_are_reported_and_leave_the_document_unchanged(self):
        self.doc.addObject("Part::Box", "Box")
        before = document.snapshot(self.doc)
        self.assertIsNone(runner.locate(self.doc))
        level, title, text = messages.LOG[-1]
        self.assertEqual((level, title), ("error", "Locate luminaires"))
        self.assertIn("no rooms (Arch Spaces)", text)
        self.assertIn("not changed", text)
        self.assertUnchanged(before)
        self.assertIsNone(runner.repeak(self.doc, threshold=50.0))
        self.assertIn("run Locate luminaires first", messages.LOG[-1][2])
        space = make_box_space(self.doc)
        targets.add_uniform_target(space, "floor", 300.0)
        before = document.snapshot(self.doc)
        self.assertIsNone(runner.locate(self.doc, run={"flux_lm": -5.0}))
        self.assertIn("flux", messages.LOG[-1][2])
        self.assertIsNone(runner.locate(self.doc, locate={"threshold": 999.0}))
        self.assertIn("threshold", messages.LOG[-1][2])
        self.assertUnchanged(before)

    def test_cancel_leaves_the_document_unchanged(self):
        from invrad_wb.gui import progress
        space = make_box_space(self.doc)
        targets.add_uniform_target(space, "floor", 300.0)
        before = document.snapshot(self.doc)
        orig = progress.Job.progress
        progress.Job.progress = lambda self, f, m: False
        try:
            self.assertIsNone(runner.locate(self.doc))
        finally:
            progress.Job.progress = orig
        self.assertEqual(messages.LOG[-1][0], "warning")
        self.assertIn("cancelled", messages.LOG[-1][2])
        self.assertUnchanged(before)

    @needs_locate
    def test_locate_repeak_verify(self):
        space = make_walled_room(self.doc, label="Office")
        targets.set_work_plane(space, 400.0)
        params.save_run({"resolution_m": 0.4, "interreflection": False})
        n = self.doc.UndoCount
        res = runner.locate(self.doc, run={"flux_lm": 2000.0})
        self.assertIsNotNone(res, messages.LOG[-1:])
        self.assertEqual(self.doc.UndoCount, n + 1)
        self.assertEqual(len(fixtures.room_fixtures(space)), len(res.luminaires))
        self.assertIs(runner.stored(self.doc).result, res)
        # a level on the work plane is a requirement: the message says per room whether
        # it is met, against what (the freecad command's words)
        v_loc = res.summary["rooms"][0]["verdict"]
        self.assertEqual(v_loc["targets"], "requirement")
        self.assertIn(f"{'met' if v_loc['met'] else 'NOT met'}: {v_loc['words']}",
                      messages.LOG[-1][2])
        self.assertIn("EN 12464-1 for 400 lx", messages.LOG[-1][2])
        lums = runner.repeak(self.doc, threshold=120.0, neighbourhood_m=0.5)
        self.assertIsNotNone(lums, messages.LOG[-1:])
        self.assertEqual(self.doc.UndoCount, n + 2)
        self.assertEqual(len(fixtures.room_fixtures(space)), len(lums))
        self.assertEqual(params.load_locate()["threshold"], 120.0)
        rep = self.path("report")
        vr = runner.verify(self.doc, report_dir=rep)
        self.assertIsNotNone(vr, messages.LOG[-1:])
        self.assertEqual(self.doc.UndoCount, n + 3)
        # Verify judges the same fixtures the same way (the level on its task area, not
        # the whole plane up to the walls)
        v_ver = vr.summary["rooms"][0]["verdict"]
        self.assertEqual(v_ver["targets"], "requirement")
        self.assertEqual(v_ver["met"], v_loc["met"])
        self.assertAlmostEqual(v_ver["em_lux"], v_loc["em_lux"], delta=0.01 * v_loc["em_lux"])
        self.assertIn(v_ver["words"], messages.LOG[-1][2])
        self.assertEqual(len(vr.luminaires), len(lums))
        self.assertTrue(os.path.isfile(os.path.join(rep, "summary.json")))
        with open(os.path.join(rep, "summary.json")) as fh:
            self.assertTrue(json.load(fh)["metrics"])
        self.assertIsNotNone(self.doc.getObject(results.SHEET_NAME))
        runner.forget(self.doc.Name)
        self.assertIsNone(runner.stored(self.doc))


def _gui_available():
    if os.environ.get("INVRAD_NO_GUI"):
        return "INVRAD_NO_GUI is set"
    for exe in ("xvfb-run", os.environ.get("INVRAD_FREECAD", "freecad")):
        if not shutil.which(exe):
            return f"{exe} not found"
    return None


class TestGuiUnderXvfb(FreeCADTestCase):
    """The real GUI: tests/freecad/gui_smoke.py --quick (about a minute)."""

    def test_smoke(self):
        why = _gui_available()
        if why:
            self.skipTest(why)
        import gui_smoke
        out = self.path("smoke")
        rc = gui_smoke.relaunch(["--quick", "--quiet", "--out", out, "--timeout", "600"])
        with open(os.path.join(out, "gui_smoke.json")) as fh:
            data = json.load(fh)
        failed = [c for c in data["checks"] if not c["ok"]]
        self.assertEqual(failed, [], f"messages: {data.get('messages', [])[-5:]}")
        self.assertTrue(data["finished"])
        self.assertEqual(rc, 0)
        self.assertGreaterEqual(len(data["checks"]), 40)
