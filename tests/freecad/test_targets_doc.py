"""Lighting targets stored in the document: creation, evaluation, save/reload, errors."""
import json
import math

import numpy as np

import FreeCAD

from fctest import FreeCADTestCase, face_of_kind, make_walled_room
from invrad_wb.app import document, rooms, targets
from invrad_wb.core.model import targets as CT
from invrad_wb.errors import SceneError


class TestTargetObjects(FreeCADTestCase):

    def setUp(self):
        super().setUp()
        self.space = make_walled_room(self.doc)
        self.floor = face_of_kind(self.space, "floor")
        self.walls = rooms.faces_by_kind(self.space, "walls")

    def add_all_kinds(self):
        img = self.path("wall.exr")
        import OpenImageIO as oiio
        out = oiio.ImageOutput.create(img)
        out.open(img, oiio.ImageSpec(4, 2, 1, oiio.FLOAT))
        out.write_image(np.full((2, 4, 1), 0.5, np.float32))
        out.close()
        return [
            targets.add_uniform_target(self.space, "floor", 300.0),
            targets.add_spot_target(self.space, self.walls[0], (0.1, 1.5, 1.5), 0.6, 900.0,
                                    falloff="gaussian"),
            targets.add_texture_target(self.space, self.walls[1], img, lux_scale=400.0),
            targets.add_shade_target(self.space, "ceiling"),
            targets.add_shade_target(self.space, "floor", centre_m=(3.0, 2.0, 0.0),
                                     radius_m=0.4),
            targets.set_work_plane(self.space, 500.0, margin_m=0.5),
            targets.set_reflectance(self.space, 0.3, surface_type="Floor"),
        ]

    def test_targets_are_objects_with_typed_properties(self):
        objs = self.add_all_kinds()
        self.assertEqual([o.Kind for o in objs], ["Uniform", "Spot", "Texture", "Shade",
                                                  "Shade", "WorkPlane", "Reflectance"])
        for o in objs:
            self.assertTrue(targets.is_target(o))
            self.assertEqual(o.Room, self.space)
            self.assertIn(o, targets.targets_group(self.doc).Group)
        spot = objs[1]
        self.assertEqual(spot.Faces, [(self.space, (self.walls[0],))])
        self.assertEqual(spot.Radius.Value, 600.0)
        self.assertEqual((spot.Centre.x, spot.Centre.y, spot.Centre.z), (100.0, 1500.0, 1500.0))
        self.assertEqual(spot.Falloff, "Gaussian")
        self.assertEqual(objs[5].Height.Value, 750.0)
        self.assertEqual(objs[5].Margin.Value, 500.0)

    def test_each_addition_is_one_undo_step(self):
        before = document.snapshot(self.doc)
        n = self.doc.UndoCount
        targets.add_uniform_target(self.space, "floor", 300.0)
        self.assertEqual(self.doc.UndoCount, n + 1)
        self.doc.undo()
        self.assertUnchanged(before)

    def test_specs_and_lux_per_vertex(self):
        self.add_all_kinds()
        specs, refl, wp = targets.room_specs(self.space, 6)
        self.assertEqual(refl, {"floor": 0.3})
        self.assertEqual((wp.lux, wp.height_m, wp.margin_m), (500.0, 0.75, 0.5))
        m = rooms.mesh_room(self.space, 0.2, refl)
        lux = CT.evaluate(m.vertices, m.triangles, m.triangle_face, specs, label=m.face_label)
        owner = np.full(len(m.vertices), -1)
        owner[m.triangles.reshape(-1)] = np.repeat(m.triangle_face, 3)
        kind = np.array(m.face_kind)[owner]
        floor = kind == "floor"
        d = np.linalg.norm(m.vertices - [3.0, 2.0, 0.0], axis=1)
        self.assertTrue(np.all(lux[floor & (d > 0.4)] == 300.0))
        self.assertTrue(np.all(lux[floor & (d <= 0.4)] == 0.0))
        self.assertTrue(np.all(lux[kind == "ceiling"] == 0.0))
        w0 = owner == int(self.walls[0][4:]) - 1
        self.assertAlmostEqual(np.nanmax(lux[w0]), 900.0, delta=60.0)
        w1 = owner == int(self.walls[1][4:]) - 1
        np.testing.assert_allclose(lux[w1], 200.0)
        self.assertTrue(np.all(np.isnan(lux[(kind == "wall") & ~w0 & ~w1])))

    def test_save_and_reload_keeps_targets(self):
        objs = self.add_all_kinds()
        specs0, refl0, wp0 = targets.room_specs(self.space, 6)
        path = self.path("targets.FCStd")
        self.doc.saveAs(path)
        FreeCAD.closeDocument(self.doc.Name)
        self.doc = FreeCAD.openDocument(path)
        space = self.doc.getObjectsByLabel("Office")[0]
        objs = targets.room_targets(space)
        self.assertEqual(len(objs), 7)
        self.assertTrue(all(isinstance(o.Proxy, targets.TargetProxy) for o in objs))
        specs1, refl1, wp1 = targets.room_specs(space, 6)
        self.assertEqual(refl0, refl1)
        self.assertEqual(wp0, wp1)
        self.assertEqual(len(specs0), len(specs1))
        for a, b in zip(specs0, specs1):
            self.assertEqual(type(a), type(b))
            self.assertEqual(a.name, b.name)
        self.doc.recompute()

    def test_missing_face_is_refused_when_added(self):
        before = document.snapshot(self.doc)
        with self.assertRaisesMessage(SceneError, "Face9", "Office", "Face1..Face6"):
            targets.add_uniform_target(self.space, ["Face9"], 100.0)
        self.assertUnchanged(before)

    def test_target_left_on_a_vanished_face_names_it(self):
        t = targets.add_uniform_target(self.space, "floor", 300.0, label="Desk")
        t.Faces = [(self.space, ["Face12"])]      # e.g. the room was remodelled
        with self.assertRaisesMessage(SceneError, "'Desk'", "Face12", "does not exist",
                                      "6 faces"):
            targets.room_specs(self.space, 6)

    def test_nan_and_negative_lux_name_the_target(self):
        t = targets.add_uniform_target(self.space, "floor", 300.0, label="Desk")
        for bad, words in ((float("nan"), "finite"), (-20.0, "negative")):
            t.Lux = bad
            with self.assertRaisesMessage(SceneError, "'Desk'", "Lux", words):
                targets.room_specs(self.space, 6)

    def test_faces_of_another_object(self):
        t = targets.add_uniform_target(self.space, "floor", 300.0, label="Desk")
        other = self.doc.getObjectsByLabel("Wall")[0]
        t.Faces = [(other, ["Face1"])]
        with self.assertRaisesMessage(SceneError, "'Desk'", "not of its room"):
            targets.room_specs(self.space, 6)

    def test_spot_without_radius_and_texture_without_file(self):
        s = targets.add_spot_target(self.space, self.floor, (1, 1, 0), 0.5, 200.0, label="Sp")
        s.Radius = 0
        with self.assertRaisesMessage(SceneError, "'Sp'", "Radius"):
            targets.room_specs(self.space, 6)
        s.Enabled = False
        tx = targets.add_texture_target(self.space, self.floor, self.path("none.exr"),
                                        label="Tx")
        with self.assertRaisesMessage(SceneError, "'Tx'", "none.exr", "does not exist"):
            targets.room_specs(self.space, 6)


class TestTargetsFile(FreeCADTestCase):

    def setUp(self):
        super().setUp()
        self.space = make_walled_room(self.doc, label="Office")

    def write(self, data):
        p = self.path("targets.json")
        with open(p, "w") as fh:
            json.dump(data, fh)
        return p

    def test_targets_file(self):
        p = self.write({"flux_lm": 2500, "rooms": {"Office": {
            "work_plane": {"lux": 400, "margin_m": 0.3},
            "reflectance": {"walls": 0.6, "Face1": 0.1},
            "targets": [{"kind": "uniform", "faces": "walls", "lux": 100},
                        {"kind": "spot", "face": "floor", "centre_m": [2, 1.5, 0],
                         "radius_m": 0.5, "peak_lux": 800},
                        {"kind": "shade", "faces": "ceiling"}]}}})
        n = self.doc.UndoCount
        opts = targets.apply_targets_file(self.doc, p)
        self.assertEqual(opts, {"flux_lm": 2500})
        self.assertEqual(self.doc.UndoCount, n + 1)
        objs = targets.room_targets(self.space)
        self.assertEqual(sorted(o.Kind for o in objs),
                         ["Reflectance", "Reflectance", "Shade", "Spot", "Uniform", "WorkPlane"])
        specs, refl, wp = targets.room_specs(self.space, 6)
        self.assertEqual(refl, {"wall": 0.6, 0: 0.1})
        self.assertEqual(wp.lux, 400)

    def test_bad_targets_file_leaves_document_unchanged(self):
        before = document.snapshot(self.doc)
        cases = [
            ({"rooms": {"Attic": {}}}, ["rooms.Attic", "no room 'Attic'", "Office"]),
            ({"rooms": {"Office": {"targets": [{"kind": "uniform", "faces": "floor",
                                                "lux": 1},
                                               {"kind": "glow"}]}}},
             ["targets[1]", "unknown kind"]),
            ({"rooms": {"Office": {"targets": [{"kind": "uniform", "faces": ["Face40"],
                                                "lux": 1}]}}}, ["Face40", "Face1..Face6"]),
            ({"rooms": {"Office": {"work_plane": {"lux": "bright"}}}}, ["work_plane.lux"]),
            ({"room": {}}, ['{"rooms"']),
        ]
        for data, words in cases:
            with self.assertRaisesMessage(SceneError, "targets.json", *words):
                targets.apply_targets_file(self.doc, self.write(data))
            self.assertUnchanged(before)
