"""IFC in and out: FZK-Haus rooms, lighting requirements, fixtures inside their IfcSpace."""
import os
import time

import numpy as np

import FreeCAD

from fctest import FZK, FZK_ROOMS, FreeCADTestCase, make_walled_room, needs_fzk
from invrad_wb.app import fixtures, ifcexport, ifcrooms, rooms, targets
from invrad_wb.core.model.luminaires import Luminaire
from invrad_wb.errors import SceneError


def read(path):
    import ifcopenshell
    return ifcopenshell.open(path)


def container_chain(entity):
    """[IfcSpace, IfcBuildingStorey, ...] names up from an element's container."""
    import ifcopenshell.util.element as E
    out = []
    cur = E.get_container(entity)
    while cur is not None:
        out.append((cur.is_a(), cur.Name, getattr(cur, "GlobalId", None)))
        cur = E.get_aggregate(cur)
    return out


def ceiling_luminaires(space, flux=1200.0, n=2):
    """n luminaires under the ceiling of a room, along its longest horizontal axis."""
    m = rooms.mesh_room(space, 0.5)
    ceil = np.array(m.face_kind)[m.triangle_face] == "ceiling"
    pts = m.vertices[m.triangles[ceil]].reshape(-1, 3)
    lo, hi = pts.min(0), pts.max(0)
    axis = int(np.argmax((hi - lo)[:2]))
    out = []
    for k in range(n):
        p = (lo + hi) / 2
        p[axis] = lo[axis] + (hi - lo)[axis] * (k + 1) / (n + 1)
        p[2] = pts[:, 2].min()
        out.append(Luminaire(p, [0, 0, -1], flux))
    return out


@needs_fzk
class TestFZKImport(FreeCADTestCase):

    def setUp(self):
        super().setUp()
        self.imp = ifcrooms.import_ifc(FZK, doc=self.doc)

    def test_seven_rooms_with_names_in_their_storeys(self):
        imp = self.imp
        self.assertEqual({s.Label for s in imp.spaces}, FZK_ROOMS)
        self.assertEqual(len(rooms.find_spaces(self.doc)), 7)
        self.assertEqual(imp.warnings, [])
        storeys = {bp.Label: bp for bp in imp.storeys.values()}
        self.assertEqual(set(storeys), {"Erdgeschoss", "Dachgeschoss"})
        self.assertIn(rooms.get_space(self.doc, "Galerie"), storeys["Dachgeschoss"].Group)
        self.assertIn(rooms.get_space(self.doc, "Küche"), storeys["Erdgeschoss"].Group)
        self.assertEqual([b.Label for b in imp.buildings], ["FZK-Haus"])
        for s in imp.spaces:
            self.assertEqual(len(rooms.space_uid(s)), 22)

    def test_every_room_meshes_closed_with_inward_normals(self):
        import ifcopenshell
        ifc = ifcopenshell.open(FZK)
        times = []
        for s in self.imp.spaces:
            t = time.perf_counter()
            m = rooms.mesh_room(s, 0.3)
            times.append(time.perf_counter() - t)
            self.assertIn("floor", m.face_kind, s.Label)
            self.assertIn("ceiling", m.face_kind, s.Label)
            q = ifc.by_guid(rooms.space_uid(s))
            import ifcopenshell.util.element as E
            vol = E.get_psets(q).get("BaseQuantities", {}).get("NetVolume") or \
                E.get_psets(q).get("BaseQuantities", {}).get("GrossVolume")
            if vol:
                self.assertAlmostEqual(m.volume, vol, delta=0.02 * vol, msg=s.Label)
            from invrad_wb.core.model.scene import Scene
            Scene(m.vertices, m.triangles, source=s.Label)   # refuses outward rooms
        print(f"\n    FZK meshing at 0.3 m: {sum(times):.2f} s for 7 rooms", end=" ")

    def test_import_is_one_undo_step(self):
        self.assertEqual(self.doc.UndoNames[0], f"Import {os.path.basename(FZK)}")
        self.doc.undo()
        self.assertEqual(rooms.find_spaces(self.doc), [])

    def test_lighting_requirement_is_read_into_a_work_plane(self):
        import ifcopenshell.api.pset as PS
        ifc = read(FZK)
        sp = [s for s in ifc.by_type("IfcSpace") if s.LongName == "Buero"][0]
        p = PS.add_pset(ifc, product=sp, name="Pset_SpaceLightingRequirements")
        PS.edit_pset(ifc, pset=p, properties={"Illuminance": 500.0})
        path = self.path("fzk_lux.ifc")
        ifc.write(path)
        imp = ifcrooms.import_ifc(path)
        self.doc2 = imp.doc
        office = rooms.get_space(imp.doc, "Buero")
        wp = targets.work_plane_target(office)
        self.assertIsNotNone(wp)
        self.assertEqual(wp.Lux, 500.0)
        self.assertEqual(wp.Height.Value, 750.0)
        self.assertIsNone(targets.work_plane_target(rooms.get_space(imp.doc, "Bad")))


@needs_fzk
class TestFZKExport(FreeCADTestCase):

    def setUp(self):
        super().setUp()
        self.imp = ifcrooms.import_ifc(FZK, doc=self.doc)
        self.kitchen = rooms.get_space(self.doc, "Küche")
        self.gallery = rooms.get_space(self.doc, "Galerie")
        self.lums = {"Küche": ceiling_luminaires(self.kitchen, 1200.0),
                     "Galerie": ceiling_luminaires(self.gallery, 2500.0, n=3)}
        fixtures.insert_fixtures(self.doc, [(self.kitchen, self.lums["Küche"]),
                                            (self.gallery, self.lums["Galerie"])])
        targets.set_work_plane(self.kitchen, 500.0)

    def check_fixtures(self, path, original_guids=True):
        import ifcopenshell.util.element as E
        import ifcopenshell.util.placement as P
        ifc = read(path)
        lf = ifc.by_type("IfcLightFixture")
        self.assertEqual(len(lf), 5)
        by_room = {}
        for e in lf:
            chain = container_chain(e)
            self.assertEqual(chain[0][0], "IfcSpace", chain)
            self.assertEqual(chain[1][0], "IfcBuildingStorey", chain)
            space = ifc.by_guid(chain[0][2])
            by_room.setdefault(space.LongName if original_guids else space.Name, []).append(e)
            psets = E.get_psets(e)
            self.assertEqual(psets["InvRad_Luminaire"]["Generator"], "invrad")
            self.assertEqual(psets["Pset_LightFixtureTypeCommon"]["NumberOfSources"], 1)
            m = np.asarray(P.get_local_placement(e.ObjectPlacement))
            np.testing.assert_allclose(-m[:3, 2], [0, 0, -1], atol=1e-9)
        self.assertEqual(sorted(len(v) for v in by_room.values()), [2, 3])
        for room, ents in by_room.items():
            self.assertIn(room, ("Küche", "Galerie"))
            storey = container_chain(ents[0])[1][1]
            self.assertEqual(storey, "Dachgeschoss" if room == "Galerie" else "Erdgeschoss")
            want = sorted(tuple(np.round(l.position, 6)) for l in self.lums[room])
            got = sorted(tuple(np.round(np.asarray(P.get_local_placement(e.ObjectPlacement))
                                        [:3, 3], 6)) for e in ents)
            np.testing.assert_allclose(got, want, atol=1e-6)
            flux = {E.get_psets(e)["InvRad_Luminaire"]["LuminousFlux"] for e in ents}
            self.assertEqual(flux, {1200.0 if room == "Küche" else 2500.0})
        req = {}
        for s in ifc.by_type("IfcSpace"):
            v = E.get_psets(s).get("Pset_SpaceLightingRequirements", {}).get("Illuminance")
            if v is not None:
                req[s.LongName if original_guids else s.Name] = v
        self.assertEqual(req, {"Küche": 500.0})
        return ifc

    def test_merge_into_the_source_ifc(self):
        out = self.path("fzk_lit.ifc")
        info = ifcexport.export_ifc(self.doc, out)
        self.assertEqual(info.mode, "merge")        # the document remembers its IFC file
        self.assertEqual(info.fixtures, 5)
        ifc = self.check_fixtures(out)
        src = read(FZK)
        for cls in ("IfcWall", "IfcSlab", "IfcWindow", "IfcDoor", "IfcSpace"):
            self.assertEqual(len(ifc.by_type(cls)), len(src.by_type(cls)), cls)
        for sp in src.by_type("IfcSpace"):
            self.assertEqual(ifc.by_guid(sp.GlobalId).LongName, sp.LongName)
        body = ifc.by_type("IfcLightFixture")[0].Representation.Representations[0]
        self.assertEqual(body.RepresentationIdentifier, "Body")

    def test_round_trip_keeps_fixtures_and_does_not_duplicate(self):
        out = self.path("fzk_lit.ifc")
        ifcexport.export_ifc(self.doc, out)
        guids = sorted(e.GlobalId for e in read(out).by_type("IfcLightFixture"))
        imp = ifcrooms.import_ifc(out)
        fx = fixtures.all_fixtures(imp.doc)
        self.assertEqual(len(fx), 5)
        self.assertEqual(sorted(f.IfcData["IfcUID"] for f in fx), guids)
        kitchen = rooms.get_space(imp.doc, "Küche")
        self.assertEqual(len(fixtures.room_fixtures(kitchen)), 2)
        self.assertEqual(targets.work_plane_target(kitchen).Lux, 500.0)
        out2 = self.path("fzk_lit2.ifc")
        ifcexport.export_ifc(imp.doc, out2)
        self.assertEqual(sorted(e.GlobalId for e in read(out2).by_type("IfcLightFixture")),
                         guids)

    def test_freecad_exporter_path(self):
        out = self.path("fzk_fc.ifc")
        info = ifcexport.export_ifc(self.doc, out, base_ifc=False)
        self.assertEqual(info.mode, "freecad")
        self.check_fixtures(out, original_guids=False)


class TestWalledRoomExport(FreeCADTestCase):

    def test_freecad_export_puts_fixtures_into_the_space(self):
        import Arch
        space = make_walled_room(self.doc)
        storey = Arch.makeBuildingPart()
        storey.IfcType = "Building Storey"
        storey.Label = "Ground floor"
        for o in self.doc.Objects:
            if o.TypeId != "App::GeometryPython" and not o.InList and o != storey:
                storey.addObject(o)
        targets.add_uniform_target(space, "floor", 300.0)      # must not be exported
        fixtures.insert_fixtures(self.doc, [(space, [Luminaire([2, 1.5, 2.7], [0, 0, -1],
                                                               1500.0)])])
        out = self.path("office.ifc")
        info = ifcexport.export_ifc(self.doc, out)
        self.assertEqual(info.mode, "freecad")
        ifc = read(out)
        (lf,) = ifc.by_type("IfcLightFixture")
        chain = container_chain(lf)
        self.assertEqual(chain[0][:2], ("IfcSpace", "Office"))
        self.assertEqual(chain[1][:2], ("IfcBuildingStorey", "Ground floor"))
        self.assertEqual(lf.GlobalId, fixtures.room_fixtures(space)[0].IfcData["IfcUID"])
        import ifcopenshell.util.element as E
        self.assertEqual(E.get_psets(lf)["InvRad_Luminaire"]["LuminousFlux"], 1500.0)
        self.assertGreaterEqual(len(ifc.by_type("IfcWall")), 1)
        names = {p.Name for p in ifc.by_type("IfcProduct")}
        self.assertFalse(any("target" in (n or "").lower() for n in names))

    def test_export_without_storey_still_contains_fixture_in_space(self):
        space = make_walled_room(self.doc)
        fixtures.insert_fixtures(self.doc, [(space, [Luminaire([2, 1.5, 2.7], [0, 0, -1],
                                                               1500.0)])])
        out = self.path("office.ifc")
        ifcexport.export_ifc(self.doc, out)
        ifc = read(out)                    # keep the file alive while using its entities
        (lf,) = ifc.by_type("IfcLightFixture")
        self.assertEqual(container_chain(lf)[0][:2], ("IfcSpace", "Office"))


class TestRequirementsWritten(FreeCADTestCase):
    """After a run, a classic room's requirement and what was achieved are in its IFC
    properties and in the exported file (the standard lighting set + invrad's own)."""

    def test_run_writes_requirement_and_achieved_values(self):
        import types
        import ifcopenshell.util.element as E
        from invrad_wb.app import pipeline
        space = make_walled_room(self.doc)
        targets.set_work_plane(space, 300.0)
        lums = [Luminaire([1.3, 1.5, 2.7], [0, 0, -1], 1500.0, room=0),
                Luminaire([2.7, 1.5, 2.7], [0, 0, -1], 1500.0, room=0)]
        given = lambda scene, **kw: types.SimpleNamespace(luminaires=lums)
        before = dict(space.IfcProperties)
        res = pipeline.run(self.doc, pipeline.PipelineSettings(
            flux_lm=1500.0, resolution_m=0.4, interreflection=False), locate=given)
        wp = res.summary["rooms"][0]["work_plane"]
        props = dict(space.IfcProperties)
        self.assertEqual(props["Illuminance;;Pset_SpaceLightingRequirements"],
                         "IfcIlluminanceMeasure;;300.0")
        em = float(props["AchievedEm;;InvRad_LightingResult"].split(";;")[1])
        self.assertAlmostEqual(em, wp["mean_achieved_lux"], places=6)
        # the same undo step as the fixtures
        self.doc.undo()
        self.assertEqual(dict(space.IfcProperties), before)
        self.assertEqual(fixtures.room_fixtures(space), [])
        self.doc.redo()
        out = self.path("office.ifc")
        ifcexport.export_ifc(self.doc, out)
        ifc = read(out)
        (sp,) = ifc.by_type("IfcSpace")
        ps = E.get_psets(sp)
        self.assertEqual(ps["Pset_SpaceLightingRequirements"]["Illuminance"], 300.0)
        self.assertAlmostEqual(ps["InvRad_LightingResult"]["AchievedEm"], em, places=6)
        self.assertAlmostEqual(ps["InvRad_LightingResult"]["AchievedU0"],
                               wp["min_achieved_lux"] / wp["mean_achieved_lux"], places=6)


class TestBadIfc(FreeCADTestCase):

    def test_missing_and_unreadable_files(self):
        with self.assertRaisesMessage(SceneError, "nope.ifc", "does not exist"):
            ifcrooms.import_ifc(self.path("nope.ifc"), doc=self.doc)
        bad = self.path("bad.ifc")
        with open(bad, "w") as fh:
            fh.write("this is not STEP\n")
        with self.assertRaisesMessage(SceneError, "bad.ifc", "not a readable IFC"):
            ifcrooms.import_ifc(bad, doc=self.doc)

    def test_file_without_spaces(self):
        import ifcopenshell
        import ifcopenshell.api.root as RT
        f = ifcopenshell.file(schema="IFC4")
        RT.create_entity(f, ifc_class="IfcProject", name="Empty")
        RT.create_entity(f, ifc_class="IfcWall", name="Lonely wall")
        p = self.path("nospace.ifc")
        f.write(p)
        with self.assertRaisesMessage(SceneError, "nospace.ifc", "no rooms (IfcSpace)"):
            ifcrooms.import_ifc(p, doc=self.doc)
        self.assertEqual(self.doc.Objects, [])


class TestAimedFixture(FreeCADTestCase):
    """An aimed spot (tilt 40 degrees, pan 120) is drawn tilted and its IFC placement
    carries the tilt: local -Z along the light (issue 23)."""

    def test_tilted_fixture_survives_ifc_export_and_read_back(self):
        import ifcopenshell.util.element as E
        import ifcopenshell.util.placement as P
        import ifcopenshell.util.unit as U
        from invrad_wb.core.model.aiming import aim_from_tilt_pan, aimed_c0
        down = np.array([0.0, 0.0, -1.0])
        aim = aim_from_tilt_pan(down, 40.0, 120.0)
        lum = Luminaire([2.0, 1.5, 2.6], aim, 900.0, c0=aimed_c0(down, aim),
                        extra={"tilt_deg": 40.0, "pan_deg": 120.0})
        space = make_walled_room(self.doc)
        (obj,) = fixtures.insert_fixtures(self.doc, [(space, [lum])])
        # drawn tilted: the light leaves along the fixture's local -Z
        d = obj.Placement.Rotation.multVec(FreeCAD.Vector(0, 0, -1))
        self.assertLess(np.linalg.norm(np.array([d.x, d.y, d.z]) - aim), 1e-9)
        out = self.path("aimed.ifc")
        ifcexport.export_ifc(self.doc, out)
        ifc = read(out)
        (lf,) = ifc.by_type("IfcLightFixture")
        m = np.asarray(P.get_local_placement(lf.ObjectPlacement), dtype=float)
        scale = 1000.0 if abs(m[2, 3]) > 100 else 1.0          # mm or m project units
        self.assertLess(np.linalg.norm(m[:3, 3] / scale - lum.position), 1e-3)
        z, x = m[:3, 2], m[:3, 0]
        self.assertLess(np.degrees(np.arccos(np.clip(-z @ aim, -1, 1))), 0.1)
        # the document's fixture and the file have its C0 (local X) as the luminaire's
        # c0 (FreeCAD 0.20's exporter wrote another X about the same Z, 30 degrees off
        # here, until the export set the placement again), which matters for a
        # rotationally asymmetric photometry
        xf = obj.Placement.Rotation.multVec(FreeCAD.Vector(1, 0, 0))
        self.assertLess(np.linalg.norm(np.array([xf.x, xf.y, xf.z]) - lum.c0), 1e-9)
        self.assertLess(np.linalg.norm(x / np.linalg.norm(x) - lum.c0), 1e-6)
        # tilt and pan in invrad's property set, in the file's angle unit
        pset = E.get_psets(lf)["InvRad_Luminaire"]
        deg = np.degrees(U.calculate_unit_scale(ifc, "PLANEANGLEUNIT"))
        self.assertAlmostEqual(pset["Tilt"] * deg, 40.0, places=6)
        self.assertAlmostEqual(pset["Pan"] * deg, 120.0, places=6)
        # and read back into a document: position, aim, C0, tilt and pan, aim point
        imp = ifcrooms.import_ifc(out)
        (fx,) = fixtures.all_fixtures(imp.doc)
        back = fixtures.fixture_luminaire(fx)
        self.assertLess(np.linalg.norm(back.position - lum.position), 1e-3)
        self.assertLess(np.degrees(np.arccos(np.clip(back.normal @ aim, -1, 1))), 0.1)
        self.assertLess(np.degrees(np.arccos(np.clip(back.c0 @ lum.c0, -1, 1))), 0.1)
        self.assertAlmostEqual(fx.Tilt, 40.0, places=6)
        self.assertAlmostEqual(fx.Pan, 120.0, places=6)
        a = fx.AimPoint
        self.assertLess(np.linalg.norm(np.array([a.x, a.y, a.z]) - obj.AimPoint), 1.0)
