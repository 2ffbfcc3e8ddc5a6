"""Open borders: rooms that meet with no wall between them are located as one lighting zone.

Two Spaces whose faces coincide (a kitchen open to a living room) used to be two closed
rooms, each with an opaque, reflecting wall on the shared border, located apart: both put
luminaires along the border (a doubled row). Now the shared part is a virtual face (no
occlusion, reflection, targets or mounting) and the rooms are located together; each
luminaire then goes to the room that contains it.
"""
import itertools
import math

import numpy as np

import FreeCAD

from fctest import FZK, FreeCADTestCase, make_box_space, needs_fzk, needs_locate
from invrad_wb.app import fixtures, pipeline, rooms, targets
from invrad_wb.app.pipeline import PipelineSettings

FLUX = 2000.0
#: the zones' point-by-point fit (their work-plane levels are otherwise requirements, laid
#: out per room with their open borders as walls, as in a design)
EXACT = {"requirements": False}


def wall_between(doc, lo, hi):
    """An Arch Wall on a box solid (metres): the wall that rooms modelled to wall axes
    both overlap."""
    import Arch
    import Part
    lo_mm = FreeCAD.Vector(*(np.asarray(lo) * 1000))
    d = (np.asarray(hi) - np.asarray(lo)) * 1000
    base = doc.addObject("Part::Feature", "WallSolid")
    base.Shape = Part.makeBox(float(d[0]), float(d[1]), float(d[2]), lo_mm)
    wall = Arch.makeWall(base)
    doc.recompute()
    return wall


def inside(space, position_m, tol_mm=1.0):
    p = FreeCAD.Vector(*(np.asarray(position_m) * 1000.0))
    return rooms.room_shape(space).isInside(p, tol_mm, True)


class OpenPlan(FreeCADTestCase):
    """A kitchen (4 x 3 m) open to a living room (4 x 4.5 m) along x = 4 m (all of the
    kitchen's wall there, 3 m of the living room's 4.5 m); an office and a store 0.2 m
    apart (a wall's thickness); a bedroom and a study modelled to the axis of the wall
    between them (their faces coincide inside an Arch Wall)."""

    def setUp(self):
        super().setUp()
        self.kitchen = make_box_space(self.doc, (0, 0, 0), (4, 3, 2.7), label="Kitchen")
        self.living = make_box_space(self.doc, (4, 0, 0), (8, 4.5, 2.7), label="Living")
        self.office = make_box_space(self.doc, (0, 6, 0), (4, 9, 2.7), label="Office")
        self.store = make_box_space(self.doc, (4.2, 6, 0), (8, 9, 2.7), label="Store")
        self.bedroom = make_box_space(self.doc, (0, 11, 0), (4, 14, 2.7), label="Bedroom")
        self.study = make_box_space(self.doc, (4, 11, 0), (8, 14, 2.7), label="Study")
        self.wall = wall_between(self.doc, (3.9, 11, 0), (4.1, 14, 2.7))
        self.spaces = [self.kitchen, self.living, self.office, self.store, self.bedroom,
                       self.study]


class TestOpenBorders(OpenPlan):

    def test_only_the_open_border_is_found(self):
        found = rooms.open_borders(self.spaces, self.doc)
        self.assertEqual([(b.a, b.b) for b in found], [(0, 1)])
        b = found[0]
        self.assertAlmostEqual(b.area_m2, 3.0 * 2.7, places=3)
        for space, face, region in ((self.kitchen, b.face_a, b.region_a),
                                    (self.living, b.face_b, b.region_b)):
            f = rooms.room_shape(space).Faces[face]
            self.assertAlmostEqual(f.CenterOfMass.x, 4000.0, places=3)
            self.assertAlmostEqual(region.BoundBox.XMin, 4000.0, places=3)
            self.assertAlmostEqual(region.BoundBox.YLength, 3000.0, places=3)
        zones = rooms.lighting_zones(len(self.spaces), found)
        self.assertEqual(zones.tolist(), [0, 0, 2, 3, 4, 5])
        # without the wall object the bedroom and the study are open to each other
        self.doc.removeObject(self.wall.Name)
        self.doc.recompute()
        self.assertEqual([(b.a, b.b) for b in rooms.open_borders(self.spaces, self.doc)],
                         [(0, 1), (4, 5)])

    def test_the_border_is_virtual_and_the_rooms_one_zone(self):
        for sp in self.spaces:
            targets.set_work_plane(sp, 300.0)
        b = pipeline.prepare(self.doc, PipelineSettings(flux_lm=FLUX, **EXACT, resolution_m=0.4,
                                                                zones=True))
        self.assertEqual([p.zone for p in b.rooms], [0, 0, 2, 3, 4, 5])
        self.assertEqual(b.zone_names[0], "Kitchen + Living")
        sc, zs = b.scene, b.zone_scene
        self.assertIs(b.locate_scene, zs)
        np.testing.assert_array_equal(sc.vertices, zs.vertices)
        np.testing.assert_array_equal(sc.faces, zs.faces)
        self.assertEqual(sc.rooms.tolist(), [0, 1, 2, 3, 4, 5])
        self.assertEqual(zs.rooms.tolist(), [0, 2, 3, 4, 5])
        # the open faces: vertical, at x = 4, virtual, no target, no reflection
        wall = sc.face_virtual & (np.abs(sc.face_normals[:, 2]) < 0.1)
        cent = sc.face_centroids[wall]
        np.testing.assert_allclose(cent[:, 0], 4.0, atol=1e-9)
        self.assertLess(cent[:, 1].max(), 3.0)
        self.assertTrue(np.all(sc.face_reflectance[wall] == 0))
        self.assertTrue(np.all(np.isnan(sc.vertex_lux[np.unique(sc.faces[wall])])))
        for room, expect in ((0, 8.1), (1, 8.1)):
            area = sc.face_areas[wall & (sc.face_room == room)].sum()
            self.assertAlmostEqual(area, expect, places=6)
        # the living room's wall at x = 4 beyond y = 3 stays a real, reflecting wall
        real = ~sc.face_virtual & (sc.face_room == 1) & (np.abs(sc.face_centroids[:, 0] - 4) < 1e-9)
        self.assertAlmostEqual(sc.face_areas[real].sum(), 1.5 * 2.7, places=6)
        self.assertTrue(np.all(sc.face_reflectance[real] > 0))
        self.assertFalse(any(p.is_virtual for p in sc.planes
                             if p.room == 1 and abs(p.normal[2]) < 0.1
                             and set(p.faces) & set(np.flatnonzero(real))))
        # the false-colour overlay draws no open border (no wall where there is none),
        # on the sampling mesh (achieved view) and on the targets' display mesh
        from invrad_wb.gui import display
        np.testing.assert_array_equal(display.open_faces(b), wall)
        vals = np.nan_to_num(sc.vertex_lux)
        g = display.overlay_geometry(b, vals, vmax=500.0)
        drawn = np.concatenate([g["surfaces"], g["work_plane"]])
        self.assertEqual(len(drawn), len(sc.faces) - int(wall.sum()))
        key = {tuple(sorted(f)) for f in sc.faces[wall]}
        self.assertFalse(key & {tuple(sorted(f)) for f in drawn})
        m = display.target_mesh(b, 500.0)
        self.assertEqual(int(m["open"].sum()), int(wall.sum()))   # no target edge there
        g = display.overlay_geometry(b, m["values"], vmax=500.0, mesh=m)
        self.assertEqual(len(g["surfaces"]) + len(g["work_plane"]),
                         len(m["faces"]) - int(wall.sum()))
        # the walls of the other pairs are real; no zones asked: none made
        self.assertFalse((sc.face_virtual & (sc.face_room >= 2)
                          & (np.abs(sc.face_normals[:, 2]) < 0.1)).any())
        plain = pipeline.prepare(self.doc, PipelineSettings(flux_lm=FLUX, **EXACT,
                                                            resolution_m=0.4,
                                                            zones=False))
        self.assertIsNone(plain.zone_scene)
        self.assertFalse((plain.scene.face_virtual
                          & (np.abs(plain.scene.face_normals[:, 2]) < 0.1)).any())

    def test_a_zone_luminaire_goes_to_the_room_that_contains_it(self):
        from invrad_wb.core.model.luminaires import Luminaire
        for sp in (self.kitchen, self.living, self.office):
            targets.set_work_plane(sp, 300.0)
        b = pipeline.prepare(self.doc, PipelineSettings(flux_lm=FLUX, **EXACT, resolution_m=0.5,
                                                                zones=True))
        lums = [Luminaire([3.9, 1.5, 2.7], [0, 0, -1], FLUX, room=0),
                Luminaire([4.1, 1.5, 2.7], [0, 0, -1], FLUX, room=0),
                Luminaire([6.0, 4.0, 2.7], [0, 0, -1], FLUX, room=0),
                Luminaire([2.0, 7.5, 2.7], [0, 0, -1], FLUX, room=2)]
        got = pipeline.assign_rooms(b, lums)
        self.assertEqual([l.room for l in got], [0, 1, 1, 2])
        self.assertEqual([l.room for l in lums], [0, 0, 0, 2])     # copies
        self.assertEqual([l.room for l in b.to_zones(got)], [0, 0, 0, 2])


@needs_locate
class TestZoneLocate(OpenPlan):
    """The real locate on the open plan: no doubled row along the border."""

    def test_no_doubled_row_each_fixture_in_its_room_targets_met(self):
        lux = {self.kitchen: 500.0, self.living: 300.0}
        for sp, e in lux.items():
            targets.set_work_plane(sp, e)
        # the defaults: open borders make a lighting zone, seeded by its rooms alone
        res = pipeline.run(self.doc, PipelineSettings(flux_lm=FLUX, **EXACT, resolution_m=0.3,
                                                      report_dir=self.path("report")))
        self.assertIsNotNone(res.building.zone_scene)
        seeded = [t for run in res.locate_result.rooms for t in run.trace if "seeded" in t]
        self.assertEqual(len(seeded), 1, "the Kitchen + Living zone starts from its rooms")
        self.assertGreater(seeded[0]["of"], 0)
        names = {self.kitchen: "Kitchen", self.living: "Living"}
        placed = {}
        for sp in lux:
            fx = fixtures.room_fixtures(sp)
            self.assertTrue(fx, f"no fixture in {names[sp]}")
            placed[sp] = [fixtures.fixture_luminaire(o).position for o in fx]
            for pos in placed[sp]:
                self.assertTrue(inside(sp, pos), (names[sp], pos))
        self.assertEqual(sum(len(v) for v in placed.values()), len(res.luminaires))
        # a fixture of one room never stands next to one of the other: the spacing the
        # targets imply (each luminaire's flux spread on Phi / E square metres: 2 m here).
        # Located apart (zones=False), the rooms put rows 1.1 m apart along the border
        # (plan distance); together 2.6 m
        spacing = math.sqrt(FLUX / max(lux.values()))
        cross = min(np.linalg.norm((a - b)[:2]) for a, b in
                    itertools.product(placed[self.kitchen], placed[self.living]))
        self.assertGreater(cross, 0.75 * spacing, placed)
        # no fixture on the open border itself
        for pos in itertools.chain(*placed.values()):
            self.assertGreater(abs(pos[0] - 4.0), 0.05, pos)
        stats = {r["room"]: r["work_plane"] for r in res.summary["rooms"]}
        for sp, e in lux.items():
            wp = stats[names[sp]]
            self.assertAlmostEqual(wp["mean_target_lux"], e, delta=1e-6 * e)
            self.assertLess(abs(wp["mean_achieved_lux"] - e), 0.2 * e, (names[sp], wp))


@needs_fzk
class TestFzkOpenBorders(FreeCADTestCase):
    """FZK-Haus: Küche, Wohnen and Flur are open to each other; walls part the rest."""

    def test_open_borders_and_zones_of_fzk(self):
        from invrad_wb.app import ifcrooms
        imp = ifcrooms.import_ifc(FZK, doc=self.doc)
        names = [rooms.room_name(s) for s in imp.spaces]
        found = rooms.open_borders(imp.spaces, self.doc)
        pairs = {frozenset((names[b.a], names[b.b])): b.area_m2 for b in found}
        self.assertEqual(set(pairs), {frozenset(("Küche", "Wohnen")),
                                      frozenset(("Wohnen", "Flur")),
                                      frozenset(("Flur", "Küche"))})
        # Wohnen's wall to Küche is all open; Flur's south wall is open to both rooms
        self.assertAlmostEqual(pairs[frozenset(("Küche", "Wohnen"))], 9.275, places=2)
        self.assertAlmostEqual(pairs[frozenset(("Wohnen", "Flur"))]
                               + pairs[frozenset(("Flur", "Küche"))], 9.025, places=2)
        zones = rooms.lighting_zones(len(names), found)
        zone_of = dict(zip(names, zones))
        self.assertEqual(len({zone_of[n] for n in ("Küche", "Wohnen", "Flur")}), 1)
        self.assertEqual(len(set(zones)), len(names) - 2)
