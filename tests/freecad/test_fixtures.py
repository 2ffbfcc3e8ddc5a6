"""Luminaires -> Arch Equipment "Light Fixture": placement, body, room, one undo step."""
import numpy as np

import FreeCAD

from fctest import FZK, FreeCADTestCase, make_walled_room, needs_fzk, needs_locate
from invrad_wb.app import classic, document, fixtures
from invrad_wb.app.aimsync import same_placement
from invrad_wb.core.model.luminaires import Luminaire
from invrad_wb.errors import LuminaireError, SceneError


def down(x, y, z=2.7, flux=1500.0, **kw):
    return Luminaire([x, y, z], [0, 0, -1], flux, **kw)


class TestFixtures(FreeCADTestCase):

    def setUp(self):
        super().setUp()
        self.space = make_walled_room(self.doc)

    def test_fixture_is_a_light_fixture_in_its_room(self):
        (fx,) = fixtures.insert_fixtures(self.doc, [(self.space, [down(2.0, 1.5, score=0.4)])])
        self.assertEqual(document.object_type(fx), "Equipment")
        self.assertEqual(fx.IfcType, "Light Fixture")
        self.assertEqual(fx.LuminousFlux, 1500.0)
        self.assertEqual(fx.Room, self.space)
        self.assertIn(fx, self.space.Group)
        self.assertEqual(fx.Generator, "invrad")
        self.assertAlmostEqual(fx.Score, 0.4)
        props = dict(fx.IfcProperties)
        self.assertEqual(props["LuminousFlux;;InvRad_Luminaire"], "IfcLuminousFluxMeasure;;1500.0")
        self.assertTrue(fx.IfcData["IfcUID"])
        self.assertTrue(self.space.IfcData["IfcUID"])
        self.assertEqual(fx.Label, "Luminaire Office 1")

    def test_a_designed_fixture_names_its_dimming_group(self):
        """A design dimmed apart letters its luminaires' groups (the report's plans): the
        fixture carries the letter as DimmingGroup and in its IFC set; one without none."""
        b = down(2.0, 1.5, flux=385.0, extra={"type": "DL-3500", "dimming_group": "D"})
        a, plain = fixtures.insert_fixtures(self.doc, [(self.space, [b, down(1.0, 1.0)])])
        self.assertEqual(a.DimmingGroup, "D")
        self.assertEqual(dict(a.IfcProperties)["DimmingGroup;;InvRad_Luminaire"],
                         "IfcLabel;;D")
        self.assertNotIn("DimmingGroup", plain.PropertiesList)
        self.assertNotIn("DimmingGroup;;InvRad_Luminaire", dict(plain.IfcProperties))

    def test_placement_mm_and_light_along_local_minus_z(self):
        normals = [[0, 0, -1], [1, 0, 0], [0, -1, 0], [0, 0, 1], [0.6, 0, -0.8]]
        lums = [Luminaire([1.0 + 0.5 * i, 1.2, 2.0], n, 800.0) for i, n in enumerate(normals)]
        objs = fixtures.insert_fixtures(self.doc, [(self.space, lums)])
        for obj, lum in zip(objs, lums):
            pl = obj.Placement
            np.testing.assert_allclose([pl.Base.x, pl.Base.y, pl.Base.z], lum.position * 1000,
                                       atol=1e-9)
            d = pl.Rotation.multVec(FreeCAD.Vector(0, 0, -1))
            np.testing.assert_allclose([d.x, d.y, d.z], lum.normal, atol=1e-9)
            ld = obj.LightDirection
            np.testing.assert_allclose([ld.x, ld.y, ld.z], lum.normal, atol=1e-9)
            back = fixtures.fixture_luminaire(obj)
            np.testing.assert_allclose(back.position, lum.position, atol=1e-12)
            np.testing.assert_allclose(back.normal, lum.normal, atol=1e-9)

    def test_aimed_fixture_tilted_along_its_aim_with_its_aim_point(self):
        from invrad_wb.core.model.aiming import tilt_pan
        pos = np.array([2.0, 1.5, 2.7])
        target = np.array([2.6, 0.1, 1.4])          # on the inner face of the wall y = 0
        aim = (target - pos) / np.linalg.norm(target - pos)
        tilt, pan = tilt_pan(aim, [0, 0, -1])
        lum = Luminaire(pos, aim, 900.0, extra={"mount_normal": [0, 0, -1],
                                               "tilt_deg": tilt, "pan_deg": pan})
        aimed, plain = fixtures.insert_fixtures(self.doc, [(self.space, [lum, down(1, 1)])])
        d = aimed.Placement.Rotation.multVec(FreeCAD.Vector(0, 0, -1))
        off = np.degrees(np.arccos(np.clip(np.dot([d.x, d.y, d.z], aim), -1, 1)))
        self.assertLess(off, 0.1)
        self.assertAlmostEqual(aimed.Tilt, tilt, places=9)
        self.assertAlmostEqual(aimed.Pan, pan, places=9)
        self.assertGreater(tilt, 40.0)
        a = aimed.AimPoint
        np.testing.assert_allclose([a.x, a.y, a.z], target * 1000, atol=1.0)
        self.assertNotIn("AimPoint", plain.PropertiesList)   # faces along its mount normal

    def _aimed_spot(self):
        """A ceiling spot at (2, 1.5, 2.7) aimed at (2.6, 0.1, 1.4) on the wall y = 0.1."""
        from invrad_wb.core.model.aiming import aimed_c0, tilt_pan
        pos = np.array([2.0, 1.5, 2.7])
        target = np.array([2.6, 0.1, 1.4])
        aim = (target - pos) / np.linalg.norm(target - pos)
        tilt, pan = tilt_pan(aim, [0, 0, -1])
        lum = Luminaire(pos, aim, 900.0, c0=aimed_c0([0, 0, -1], aim),
                        extra={"tilt_deg": tilt, "pan_deg": pan})
        (fx,) = fixtures.insert_fixtures(self.doc, [(self.space, [lum])])
        return fx, aim, target

    def _edit(self, fx, **props):
        self.doc.openTransaction("Edit")
        for k, v in props.items():
            setattr(fx, k, v)
        self.doc.commitTransaction()

    def test_a_moved_spot_keeps_its_aim_and_its_aim_point_follows_the_beam(self):
        fx, aim, target = self._aimed_spot()
        tilt, pan = fx.Tilt, fx.Pan
        pl0, aim0 = FreeCAD.Placement(fx.Placement), FreeCAD.Vector(fx.AimPoint)
        # 1 m along the lit wall: the beam lands 1 m further along it
        pl = FreeCAD.Placement(pl0)
        pl.Base = pl.Base + FreeCAD.Vector(1000, 0, 0)
        self._edit(fx, Placement=pl)
        a = fx.AimPoint
        np.testing.assert_allclose([a.x, a.y, a.z], (target + [1.0, 0, 0]) * 1000, atol=1.0)
        self.assertAlmostEqual(fx.Tilt, tilt, places=6)
        self.assertAlmostEqual(fx.Pan, pan, places=6)
        # 1 m towards the wall: the beam meets the wall higher up (not 1 m behind it)
        pl2 = FreeCAD.Placement(pl0)
        pl2.Base = pl2.Base + FreeCAD.Vector(0, -1000, 0)
        self._edit(fx, Placement=pl2)
        s = (1.5 - 1.0 - 0.1) / (-aim[1])                # metres along the beam
        hit = np.array([2.0, 0.5, 2.7]) + s * aim
        a = fx.AimPoint
        np.testing.assert_allclose([a.x, a.y, a.z], hit * 1000, atol=1.0)
        self.assertAlmostEqual(a.y, 100.0, delta=1.0)
        # each undo restores the placement and the aim point together
        self.doc.undo()
        self.assertTrue(same_placement(fx.Placement, pl))
        np.testing.assert_allclose([fx.AimPoint.x, fx.AimPoint.y, fx.AimPoint.z],
                                   (target + [1.0, 0, 0]) * 1000, atol=1.0)
        self.doc.undo()
        self.assertTrue(same_placement(fx.Placement, pl0))
        self.assertEqual(fx.AimPoint, aim0)
        self.assertEqual((fx.Tilt, fx.Pan), (tilt, pan))

    def test_a_turned_spot_gets_its_tilt_and_pan_and_an_edited_tilt_turns_it(self):
        from invrad_wb.app.fixturebody import fixture_rotation
        from invrad_wb.core.model.aiming import aim_from_tilt_pan, aimed_c0
        fx, aim, target = self._aimed_spot()
        tilt0, pan0, pl0 = fx.Tilt, fx.Pan, FreeCAD.Placement(fx.Placement)
        # the user edits the tilt: the placement turns to 20 degrees at the same pan, and
        # the beam lands on the floor
        self._edit(fx, Tilt=20.0)
        new = aim_from_tilt_pan([0, 0, -1], 20.0, pan0)
        d = fx.Placement.Rotation.multVec(FreeCAD.Vector(0, 0, -1))
        self.assertLess(np.degrees(np.arccos(np.clip(np.dot([d.x, d.y, d.z], new), -1, 1))),
                        1e-6)
        self.assertEqual(fx.Placement.Base, pl0.Base)
        self.assertEqual((fx.Tilt, fx.Pan), (20.0, pan0))
        hit = np.array([2.0, 1.5, 2.7]) + 2.7 / -new[2] * new
        np.testing.assert_allclose([fx.AimPoint.x, fx.AimPoint.y, fx.AimPoint.z],
                                   hit * 1000, atol=1.0)
        np.testing.assert_allclose([fx.LightDirection.x, fx.LightDirection.y,
                                    fx.LightDirection.z], new, atol=1e-9)
        # the user turns the placement (to tilt 30, pan 100): Tilt and Pan follow
        a = aim_from_tilt_pan([0, 0, -1], 30.0, 100.0)
        self._edit(fx, Placement=FreeCAD.Placement(pl0.Base, fixture_rotation(
            a, aimed_c0([0, 0, -1], a))))
        self.assertAlmostEqual(fx.Tilt, 30.0, places=6)
        self.assertAlmostEqual(fx.Pan, 100.0, places=6)
        self.doc.undo()
        self.doc.undo()
        self.assertTrue(same_placement(fx.Placement, pl0))
        self.assertEqual((fx.Tilt, fx.Pan), (tilt0, pan0))
        np.testing.assert_allclose([fx.AimPoint.x, fx.AimPoint.y, fx.AimPoint.z],
                                   target * 1000, atol=1.0)

    def test_body_hangs_from_the_ceiling_into_the_room(self):
        (fx,) = fixtures.insert_fixtures(self.doc, [(self.space, [down(2.0, 1.5)])])
        bb = fx.Shape.BoundBox
        self.assertAlmostEqual(bb.ZMax, 2700.0, places=6)
        self.assertAlmostEqual(bb.ZMin, 2660.0, places=6)
        self.assertAlmostEqual(bb.XLength, 300.0, places=6)       # default 0.15 m radius
        (fx2,) = fixtures.insert_fixtures(self.doc, [(self.space, [down(2, 1.5, radius_m=0.3)])])
        self.assertAlmostEqual(fx2.Shape.BoundBox.XLength, 600.0, places=6)
        self.assertAlmostEqual(fx2.EmitterRadius.Value, 300.0)

    def test_pendant_hangs_from_the_ceiling_on_a_rod(self):
        (fx,) = fixtures.insert_fixtures(self.doc, [(self.space, [down(2.0, 1.5, z=2.0)])])
        bb = fx.Shape.BoundBox
        self.assertAlmostEqual(bb.ZMin, 1960.0, places=3)       # the body below the point
        self.assertAlmostEqual(bb.ZMax, 2700.0, places=3)       # the rod reaches the ceiling
        self.assertEqual(len(fx.Shape.Solids), 1)               # one solid for IFC
        # the rod is thin: a section half way up is a small disc, not the body
        mid = fx.Shape.common(__import__("Part").makeBox(
            1000, 1000, 10, FreeCAD.Vector(1500, 1000, 2300)))
        self.assertLess(mid.Volume, 3.2 * 6.0 ** 2 * 10)
        self.assertAlmostEqual(fixtures.ceiling_drop_m(self.space, down(2.0, 1.5, z=2.0)),
                               0.7, places=6)
        # on the ceiling (a few cm below it: no rod) and facing sideways: no rod
        self.assertEqual(fixtures.ceiling_drop_m(self.space, down(2.0, 1.5, z=2.65)), 0.0)
        self.assertEqual(fixtures.ceiling_drop_m(
            self.space, Luminaire([0.1, 1.5, 2.0], [1, 0, 0], 900.0)), 0.0)
        # the mount a locate run found counts even close to the ceiling
        near = down(2.0, 1.5, z=2.65)
        near.extra["mount"] = "pendant"
        self.assertAlmostEqual(fixtures.ceiling_drop_m(self.space, near), 0.05, places=6)

    def test_body_sized_from_the_luminous_area(self):
        class Phot:
            luminous_area_m2 = 0.36
        panel = down(2.0, 1.5)
        panel.photometry = Phot()
        self.assertEqual(fixtures.fixture_size(panel), ("panel", 0.6, 0.6))
        small = down(1.0, 1.0)
        small.photometry = type("P", (), {"luminous_area_m2": np.pi * 0.075 ** 2})()
        kind, r = fixtures.fixture_size(small)
        self.assertEqual(kind, "disc")
        self.assertAlmostEqual(r, 0.075)
        self.assertEqual(fixtures.fixture_size(down(1, 1, radius_m=0.2)), ("disc", 0.2))
        fx = fixtures.insert_fixtures(self.doc, [(self.space, [panel, small])])
        bb = fx[0].Shape.BoundBox
        self.assertAlmostEqual(bb.XLength, 600.0, places=3)
        self.assertAlmostEqual(bb.YLength, 600.0, places=3)
        self.assertAlmostEqual(fx[1].Shape.BoundBox.XLength, 150.0, places=3)

    def test_rectangular_panel_lies_along_its_photometry_axes(self):
        """A 1.2 x 0.3 m opening (1.2 m along C0): on the ceiling its length runs along
        +X, the C0 axis of the intensity table there; on a wall facing +X along the
        wall's horizontal C0 axis (+Y), in the FreeCAD body and in the IFC placement."""
        from invrad_wb.app.ifcexport import fixture_matrix
        from invrad_wb.core.model.scene import plane_basis

        class Phot:
            luminous_area_m2 = 0.36
            luminous_extent_m = (1.2, 0.3)
        ceiling = down(2.0, 1.5)
        wall = Luminaire([0.0, 1.5, 1.8], [1.0, 0.0, 0.0], 2000.0)
        for lum in (ceiling, wall):
            lum.photometry = Phot()
            self.assertEqual(fixtures.fixture_size(lum), ("panel", 1.2, 0.3))
        fx = fixtures.insert_fixtures(self.doc, [(self.space, [ceiling, wall])])
        bb = fx[0].Shape.BoundBox
        self.assertAlmostEqual(bb.XLength, 1200.0, places=3)
        self.assertAlmostEqual(bb.YLength, 300.0, places=3)
        bb = fx[1].Shape.BoundBox
        self.assertAlmostEqual(bb.YLength, 1200.0, places=3)
        self.assertAlmostEqual(bb.ZLength, 300.0, places=3)
        self.assertLess(bb.XLength, 100.0)          # its thickness, off the wall
        for lum, obj in ((ceiling, fx[0]), (wall, fx[1])):
            u, _ = plane_basis(lum.normal)
            x = obj.Placement.Rotation.multVec(FreeCAD.Vector(1, 0, 0))
            np.testing.assert_allclose([x.x, x.y, x.z], u, atol=1e-9)
            np.testing.assert_allclose(fixture_matrix(lum)[:3, 0], u, atol=1e-12)
            mz = obj.Placement.Rotation.multVec(FreeCAD.Vector(0, 0, -1))
            np.testing.assert_allclose([mz.x, mz.y, mz.z], lum.normal, atol=1e-9)

    def test_label_names_room_and_catalogue_type(self):
        typed = down(2.0, 1.5)
        typed.extra["type"] = "DL-2000"
        objs = fixtures.insert_fixtures(self.doc, [(self.space, [down(1, 1), typed])])
        self.assertEqual([o.Label for o in objs],
                         ["Luminaire Office 1", "Luminaire Office 2 (DL-2000)"])
        self.assertEqual(objs[1].Model, "DL-2000")
        # listed in the tree under their room
        self.assertTrue(all(o in self.space.Group for o in objs))

    def test_insertion_is_one_undo_step(self):
        before = document.snapshot(self.doc)
        undo0 = self.doc.UndoCount
        objs = fixtures.insert_fixtures(self.doc, [(self.space, [down(1, 1), down(3, 2)])])
        self.assertEqual(len(objs), 2)
        self.assertEqual(self.doc.UndoCount, undo0 + 1)
        self.assertEqual(self.doc.UndoNames[0], "Insert luminaires")
        self.doc.undo()
        self.assertUnchanged(before)
        self.assertEqual(fixtures.room_fixtures(self.space), [])
        self.doc.redo()
        self.assertEqual(len(fixtures.room_fixtures(self.space)), 2)

    def test_rerun_replaces_generated_fixtures_only(self):
        import Arch
        manual = Arch.makeEquipment(name="Pendant by the architect")
        manual.IfcType = "Light Fixture"
        self.space.Proxy.addObject(self.space, manual)
        self.doc.recompute()
        fixtures.insert_fixtures(self.doc, [(self.space, [down(1, 1), down(3, 2)])])
        fixtures.insert_fixtures(self.doc, [(self.space, [down(2, 1.5)])])
        gen = fixtures.room_fixtures(self.space)
        self.assertEqual(len(gen), 1)
        self.assertIn(manual, self.space.Group)
        self.assertEqual(len(fixtures.room_fixtures(self.space, generated_only=False)), 2)
        fixtures.insert_fixtures(self.doc, [(self.space, [down(1, 1)])], replace=False)
        self.assertEqual(len(fixtures.room_fixtures(self.space)), 2)

    def test_bad_luminaire_leaves_document_unchanged(self):
        before = document.snapshot(self.doc)
        with self.assertRaisesMessage(LuminaireError, "luminaire 2", "Office", "flux"):
            fixtures.insert_fixtures(self.doc, [(self.space, [down(1, 1), down(2, 2, flux=0.0)])])
        with self.assertRaisesMessage(SceneError, "not a room"):
            fixtures.insert_fixtures(self.doc, [(self.space.Base or self.doc.Objects[0],
                                                 [down(1, 1)])])
        self.assertUnchanged(before)

    def test_failure_half_way_is_aborted(self):
        before = document.snapshot(self.doc)
        original = classic.make_fixture             # the classic backend makes them
        calls = []

        def failing(space, lum, label):
            calls.append(label)
            if len(calls) == 2:
                raise RuntimeError("disk full")
            return original(space, lum, label)
        classic.make_fixture = failing
        try:
            fixtures.insert_fixtures(self.doc, [(self.space, [down(1, 1)])])   # an old run
            before = document.snapshot(self.doc)
            with self.assertRaises(RuntimeError):
                fixtures.insert_fixtures(self.doc, [(self.space, [down(1, 1), down(2, 2)])])
        finally:
            classic.make_fixture = original
        self.assertUnchanged(before)
        self.assertEqual(len(fixtures.room_fixtures(self.space)), 1)

    def test_save_and_reload_keeps_fixtures(self):
        from invrad_wb.core.model.aiming import aim_from_tilt_pan, aimed_c0
        from invrad_wb.gui import beamaxis
        mount = np.array([0.0, 0.0, -1.0])
        aim = aim_from_tilt_pan(mount, 40.0, 120.0)         # a spot aimed at the wall y = 0
        spot = Luminaire([2.0, 1.5, 2.7], aim, 700.0, c0=aimed_c0(mount, aim),
                         extra={"tilt_deg": 40.0, "pan_deg": 120.0})
        fixtures.insert_fixtures(self.doc, [(self.space, [down(1, 1, score=0.7),
                                                          Luminaire([0.1, 1.5, 2.0], [1, 0, 0],
                                                                    900.0, 0.05), spot])])
        aim_point = fixtures.room_fixtures(self.space)[2].AimPoint
        path = self.path("lit.FCStd")
        self.doc.saveAs(path)
        name = self.doc.Name
        FreeCAD.closeDocument(name)
        doc = FreeCAD.openDocument(path)
        space = doc.getObjectsByLabel("Office")[0]
        fx = fixtures.room_fixtures(space)
        self.assertEqual(len(fx), 3)
        self.assertEqual(sorted(f.LuminousFlux for f in fx), [700.0, 900.0, 1500.0])
        # the aimed spot: its aim (placement), C0 axis, tilt, pan and aim point, and it is
        # among the fixtures whose beam axis the GUI draws again (gui_smoke checks the
        # drawing itself)
        (aimed,) = beamaxis.aimed_fixtures(doc)
        back = fixtures.fixture_luminaire(aimed)
        np.testing.assert_allclose(back.position, spot.position, atol=1e-12)
        self.assertLess(np.degrees(np.arccos(np.clip(back.normal @ aim, -1, 1))), 1e-6)
        np.testing.assert_allclose(back.c0, spot.c0, atol=1e-9)
        self.assertEqual(back.extra, {"tilt_deg": 40.0, "pan_deg": 120.0})
        self.assertEqual(aimed.AimPoint, aim_point)
        hit = spot.position * 1000 + aim * (1500.0 - 100.0) / -aim[1]   # wall y = 0.1 m
        np.testing.assert_allclose([aim_point.x, aim_point.y, aim_point.z], hit, atol=1e-6)
        fx = [f for f in fx if f is not aimed]
        for f in fx:
            self.assertEqual(f.Room, space)
            self.assertEqual(f.IfcType, "Light Fixture")
            self.assertFalse(f.Shape.isNull())
        wall = [f for f in fx if f.LuminousFlux == 900.0][0]
        lum = fixtures.fixture_luminaire(wall)
        np.testing.assert_allclose(lum.normal, [1, 0, 0], atol=1e-9)
        np.testing.assert_allclose(lum.position, [0.1, 1.5, 2.0], atol=1e-12)
        self.assertAlmostEqual(lum.radius_m, 0.05)
        doc.recompute()
        self.assertEqual(len(fixtures.room_fixtures(space)), 3)
        self.doc = doc


def wall_clearance_m(fx):
    """Plan distance (m) from a fixture's centre to the nearest wall face of its room, and
    whether the centre lies inside the room (1 mm along its light, off its surface)."""
    import Part
    lum = fixtures.fixture_luminaire(fx)
    shape = fx.Room.Shape
    p = FreeCAD.Vector(*(1000.0 * (lum.position + 0.001 * lum.normal)))
    inside = shape.isInside(p, 1e-3, True)
    walls = [f for f in shape.Faces if abs(f.normalAt(0.5, 0.5).z) < 0.1]
    v = Part.Vertex(p)
    return min(f.distToShape(v)[0] for f in walls) / 1000.0, inside


class TestFixturesInTheirRooms(FreeCADTestCase):
    """Located fixtures lie inside their rooms and clear of the walls; rooms do not overlap."""

    @needs_locate
    def test_located_ceiling_lights_keep_clear_of_the_walls(self):
        # a work plane reaching the walls pulled ceiling lights onto the ceiling's edge
        # (FZK-Haus: centres on the wall lines, bodies in the walls)
        from invrad_wb.app import pipeline, targets
        from invrad_wb.core.inverse.locate import MOUNT_CLEARANCE_M
        space = make_walled_room(self.doc)
        targets.set_work_plane(space, 500.0)
        pipeline.run(self.doc, pipeline.PipelineSettings(
            flux_lm=1500.0, resolution_m=0.3, interreflection=False, workers=1))
        fx = fixtures.room_fixtures(space)
        self.assertGreaterEqual(len(fx), 4)
        for f in fx:
            clear, inside = wall_clearance_m(f)
            self.assertTrue(inside, f.Label)
            if f.LightDirection.z < -0.99:                 # on the ceiling or hanging
                self.assertGreaterEqual(clear, MOUNT_CLEARANCE_M - 0.002, f.Label)

    @needs_fzk
    def test_fzk_rooms_do_not_overlap(self):
        from invrad_wb.app import ifcimport, rooms
        doc = ifcimport.open(FZK)
        spaces = rooms.find_spaces(doc)
        self.assertEqual(len(spaces), 7)
        touching = 0
        for i, a in enumerate(spaces):
            for b in spaces[i + 1:]:
                if not a.Shape.BoundBox.intersect(b.Shape.BoundBox):
                    continue
                common = a.Shape.common(b.Shape).Volume / 1e9
                self.assertLess(common, 1e-6, f"{a.Label} and {b.Label} share {common} m3")
                touching += a.Shape.distToShape(b.Shape)[0] < 1.0
        self.assertGreaterEqual(touching, 2)   # Küche, Wohnen and Flur share open borders
