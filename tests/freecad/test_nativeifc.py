"""NativeIFC documents (FreeCAD 1.x BIM): FZK-Haus opened natively, rooms from its IfcSpace
entities, Locate and Design on every room, luminaires written into the IFC as
IfcLightFixture in their IfcSpace with their property sets, in ONE undo step that also
undoes the IFC file; lighting requirements read from and written to the spaces' sets.

On FreeCAD 0.20 (no nativeifc) only the refusal is tested; the rest is skipped."""
import json
import os
import shutil
import time
import unittest

import numpy as np

import FreeCAD

from fctest import FZK, FZK_ROOMS, ROOT, FreeCADTestCase, needs_fzk
from invrad_wb.app import fixtures, ifcimport, nativeifc, pipeline, results, rooms, targets
from invrad_wb.app import design as app_design
from invrad_wb.app.document import snapshot
from invrad_wb.errors import InvradError

HAS_NATIVE = nativeifc.available()
needs_native = unittest.skipUnless(
    HAS_NATIVE, f"NativeIFC needs FreeCAD 1.0's BIM workbench (nativeifc); FreeCAD"
                f" {'.'.join(FreeCAD.Version()[:2])} has none")
TARGETS = os.path.join(ROOT, "examples", "fzk_targets.json")
DESIGN = os.path.join(ROOT, "examples", "fzk_design.json")


def read(path):
    import ifcopenshell
    return ifcopenshell.open(path)


def invrad_lights(ifc):
    import ifcopenshell.util.element as E
    return [e for e in ifc.by_type("IfcLightFixture")
            if "InvRad_Luminaire" in E.get_psets(e)]


@unittest.skipIf(HAS_NATIVE, "FreeCAD has NativeIFC")
class TestWithoutNativeIFC(unittest.TestCase):

    def test_refused_with_the_reason(self):
        with self.assertRaises(InvradError) as cm:
            nativeifc.check_available()
        self.assertIn("FreeCAD 1.0", str(cm.exception))
        self.assertFalse(nativeifc.is_native_space(object()))


@needs_native
@needs_fzk
class TestBackendChoice(FreeCADTestCase):
    """One backend per document: a document chosen classic becomes NativeIFC when a
    NativeIFC project comes into it, by NativeIFC's own import (File > Insert) too, and its
    rooms are then its IfcSpaces only."""

    def test_a_nativeifc_project_makes_the_document_nativeifc(self):
        from fctest import make_box_space
        from nativeifc import ifc_import
        from invrad_wb.app import backend
        arch = make_box_space(self.doc)
        self.assertIs(backend.of(self.doc), backend.CLASSIC)
        self.assertEqual(rooms.find_spaces(self.doc), [arch])
        src = self.path("fzk.ifc")
        shutil.copy(FZK, src)
        ifc_import.insert(src, self.doc.Name, strategy=1, shapemode=2, switchwb=False,
                          silent=True)                  # no invrad call: the observer
        be = backend.of(self.doc)
        self.assertIs(be, backend.NATIVE_IFC)
        self.assertTrue(be.native)
        found = rooms.find_spaces(self.doc)
        self.assertEqual({rooms.room_name(s) for s in found}, FZK_ROOMS)
        self.assertNotIn(arch, found)
        self.assertTrue(all(rooms.is_native(s) for s in found))


@needs_native
@needs_fzk
class TestNativeFZK(FreeCADTestCase):
    """One NativeIFC FZK-Haus per test (a copy: saving writes the project's file)."""

    def setUp(self):
        super().setUp()
        self.src = self.path("fzk.ifc")
        shutil.copy(FZK, self.src)
        # shape mode 2 (no Part shapes): rooms come from the IfcSpace geometry anyway
        self.ndoc, self.proj = ifcimport.open_ifc(self.src, doc=self.doc, shapemode=2)
        self.ifc = self.proj.Proxy.ifcfile

    def spaces(self):
        return {rooms.room_name(s): s for s in rooms.find_spaces(self.doc)}

    def test_rooms_are_the_ifc_spaces(self):
        import ifcopenshell.util.element as E
        sp = self.spaces()
        self.assertEqual(set(sp), FZK_ROOMS)
        for name, s in sp.items():
            with self.subTest(room=name):
                ent = nativeifc.entity(s)
                self.assertEqual(ent.is_a(), "IfcSpace")
                self.assertEqual(rooms.space_uid(s), ent.GlobalId)
                self.assertIs(rooms.get_space(self.doc, name), s)
                m = rooms.mesh_room(s, 0.3)
                self.assertEqual(m.label, name)
                self.assertTrue({"floor", "wall", "ceiling"} <= set(m.face_kind))
                q = E.get_psets(ent).get("BaseQuantities", {})
                vol = q.get("NetVolume") or q.get("GrossVolume")
                if vol:
                    self.assertAlmostEqual(m.volume, vol, delta=0.02 * vol)

    def test_locate_writes_light_fixtures_into_their_spaces(self):
        import ifcopenshell.util.element as E
        targets.apply_targets_file(self.doc, TARGETS)
        undo0 = self.doc.UndoCount
        t0 = time.perf_counter()
        res = pipeline.run(self.doc, pipeline.PipelineSettings(
            flux_lm=2000.0, resolution_m=0.4, interreflection=False,
            rooms=["Bad", "Buero"]))
        print(f"  NativeIFC FZK locate (Bad, Buero): {time.perf_counter() - t0:.1f} s,"
              f" {len(res.luminaires)} luminaires")
        self.assertEqual(self.doc.UndoCount - undo0, 1)
        fx = fixtures.all_fixtures(self.doc)
        self.assertEqual(len(fx), len(res.luminaires))
        self.assertEqual({rooms.room_name(fixtures.fixture_room(f)) for f in fx},
                         {"Bad", "Buero"})
        for f in fx:
            ent = nativeifc.entity(f)
            self.assertEqual(ent.is_a(), "IfcLightFixture")
            space = fixtures.fixture_room(f)
            self.assertEqual(E.get_container(ent).GlobalId, rooms.space_uid(space))
            self.assertAlmostEqual(fixtures.fixture_luminaire(f).flux_lm, 2000.0)
        # each found luminaire is an entity at its position, lighting the same way
        key = lambda l: tuple(np.round(l.position, 6))
        found = sorted(res.luminaires, key=key)
        stored = sorted((fixtures.fixture_luminaire(f) for f in fx), key=key)
        for a, b in zip(found, stored):
            np.testing.assert_allclose(a.position, b.position, atol=1e-6)
            np.testing.assert_allclose(a.normal, b.normal, atol=1e-6)
        # Verify reads them back (their flux is in the IFC entity, not a FreeCAD
        # property: it said '0 luminaire(s)', every fixture left out)
        lums, skipped = results.document_luminaires(res.building)
        self.assertEqual(skipped, [])
        self.assertEqual(sorted(l.extra["fixture"] for l in lums),
                         sorted(f.Label for f in fx))
        self.assertTrue(all(abs(l.flux_lm - 2000.0) < 1e-6 for l in lums))
        self.doc.undo()
        self.assertEqual(invrad_lights(self.ifc), [])

    def _run_and_save(self, settings, what, name):
        """One pipeline run (``what`` in the printed time): one undo step, a fixture per
        luminaire, in every FZK room and no other; the project saved to ``name`` and read
        back has an InvRad light per fixture. Returns (result, fixtures, the saved file
        read with ifcopenshell, its InvRad lights)."""
        undo0 = self.doc.UndoCount
        t0 = time.perf_counter()
        res = pipeline.run(self.doc, settings)
        print(f"  NativeIFC FZK {what}: {time.perf_counter() - t0:.1f} s,"
              f" {len(res.luminaires)} luminaires")
        self.assertEqual(self.doc.UndoCount - undo0, 1)
        fx = fixtures.all_fixtures(self.doc)
        self.assertEqual(len(fx), len(res.luminaires))
        self.assertEqual({rooms.room_name(fixtures.fixture_room(f)) for f in fx}, FZK_ROOMS)
        out = self.path(name)
        nativeifc.save(self.proj, out)
        ifc = read(out)
        lights = invrad_lights(ifc)
        self.assertEqual(len(lights), len(fx))
        return res, fx, ifc, lights

    def test_locate_on_every_room_is_saved_in_the_spaces_and_undone(self):
        # issue 9's check: Locate on all 7 rooms of the NativeIFC FZK-Haus, the saved IFC
        # read back with ifcopenshell has every fixture in its IfcSpace, undo restores
        import ifcopenshell.util.element as E
        targets.apply_targets_file(self.doc, TARGETS)
        before = snapshot(self.doc)
        n_entities = len(list(self.ifc))
        # direct light only, as in the two-room test: the check is where the fixtures go
        # and the undo, not the light (interreflection doubled the time)
        lights = self._run_and_save(pipeline.PipelineSettings(
            flux_lm=2000.0, resolution_m=0.4, interreflection=False), "locate, all rooms",
            "located.ifc")[3]
        per_room = {}
        for e in lights:
            c = E.get_container(e)
            self.assertTrue(c.is_a("IfcSpace"), c)
            per_room[c.LongName or c.Name] = per_room.get(c.LongName or c.Name, 0) + 1
        self.assertEqual(set(per_room), FZK_ROOMS)
        self.doc.undo()
        self.assertEqual(snapshot(self.doc), before)
        self.assertEqual(len(list(self.ifc)), n_entities)
        self.assertEqual(invrad_lights(self.ifc), [])

    def test_design_writes_fixtures_and_requirements_undone_in_one_step(self):
        import ifcopenshell.util.element as E
        spec = app_design.spec_from_targets_file(DESIGN)
        targets.apply_targets_file(self.doc, DESIGN)
        before = snapshot(self.doc)
        n_entities = len(list(self.ifc))
        res, fx, ifc, lights = self._run_and_save(
            pipeline.PipelineSettings(flux_lm=None, design=spec), "design", "out.ifc")
        # the saved IFC has them in their spaces, with flux and a Body; the requirements too
        names = {s.GlobalId: (s.LongName or s.Name) for s in ifc.by_type("IfcSpace")}
        req = json.load(open(DESIGN, encoding="utf-8"))["rooms"]
        for e in lights:
            c = E.get_container(e)
            self.assertEqual(c.is_a(), "IfcSpace")
            self.assertIn(names[c.GlobalId], FZK_ROOMS)
            ps = E.get_psets(e)
            self.assertGreater(ps["InvRad_Luminaire"]["LuminousFlux"], 0)
            self.assertEqual(ps["Pset_LightFixtureTypeCommon"]["NumberOfSources"], 1)
            reps = e.Representation.Representations
            self.assertEqual(reps[0].RepresentationIdentifier, "Body")
        for s in ifc.by_type("IfcSpace"):
            with self.subTest(space=s.LongName):
                ps = E.get_psets(s)
                self.assertEqual(ps["Pset_SpaceLightingRequirements"]["Illuminance"],
                                 req[s.LongName]["work_plane"]["lux"])
                self.assertTrue(ps["Pset_SpaceLightingRequirements"]["ArtificialLighting"])
                res_ps = ps["InvRad_LightingResult"]
                self.assertGreater(res_ps["AchievedEm"], 0)
                self.assertLessEqual(res_ps["AchievedEmin"], res_ps["AchievedEm"])
        # the design's catalogue types and figures
        cat = {e.name for e in spec.catalogue}
        for e in lights:
            ps = E.get_psets(e)
            self.assertIn(ps["InvRad_Luminaire"]["LuminaireType"], cat)
            self.assertEqual(ps["Pset_LightFixtureTypeCommon"]["Reference"],
                             ps["InvRad_Luminaire"]["LuminaireType"])
        design = {r["name"]: r for r in res.summary["design"]["rooms"]}
        # rooms dimmed apart: each fixture's IFC set names its group (the report's letters)
        letters = sorted(g["label"] for r in design.values() for g in r["groups"]
                         for _ in g["luminaires"] if g["label"])
        self.assertGreater(len(letters), 0)
        self.assertEqual(sorted(E.get_psets(e)["InvRad_Luminaire"]["DimmingGroup"]
                                for e in lights
                                if "DimmingGroup" in E.get_psets(e)["InvRad_Luminaire"]),
                         letters)
        # every room meets every EN 12464-1 item asked (work plane, walls, ceiling), its
        # UGR shown (the Flur's walls once failed U0 on a point in a 2 cm slot behind a beam)
        for name, r in design.items():
            with self.subTest(room=name):
                self.assertRoomMeetsDesign(r, req[name]["work_plane"])
                if req[name].get("ugr_max") is not None:     # the Buero's 19, the Küche's 22
                    self.assertEqual(r["ugr_limit"], req[name]["ugr_max"])
                    self.assertTrue(r["pass"]["UGR"])
        for s in ifc.by_type("IfcSpace"):
            r = E.get_psets(s)["InvRad_LightingResult"]
            self.assertAlmostEqual(r["AchievedEm"], design[s.LongName]["em_lux"], places=2)
            self.assertAlmostEqual(r["InstalledPower"], design[s.LongName]["watts"], places=2)
        # undo: the document and the IFC file as before; redo: back again
        self.doc.undo()
        self.assertEqual(snapshot(self.doc), before)
        self.assertEqual(invrad_lights(self.ifc), [])
        self.assertEqual(len(list(self.ifc)), n_entities)
        for s in self.ifc.by_type("IfcSpace"):
            self.assertNotIn("InvRad_LightingResult", E.get_psets(s))
        self.doc.redo()
        self.assertEqual(len(invrad_lights(self.ifc)), len(fx))
        self.assertEqual(len(fixtures.all_fixtures(self.doc)), len(fx))
        self.doc.undo()
        after = self.path("after_undo.ifc")
        nativeifc.save(self.proj, after)
        self.assertEqual(invrad_lights(read(after)), [])

    def test_a_second_insert_replaces_invrads_fixtures_in_the_room(self):
        from invrad_wb.core.model.luminaires import Luminaire
        sp = self.spaces()
        lums = [Luminaire([3.0 + 0.5 * k, 7.8, 2.4], [0, 0, -1], 800.0) for k in range(3)]
        fixtures.insert_fixtures(self.doc, [(sp["Buero"], lums), (sp["Bad"], lums[:1])])
        self.assertEqual(len(invrad_lights(self.ifc)), 4)
        fixtures.insert_fixtures(self.doc, [(sp["Buero"], lums[:2])])
        self.assertEqual(len(invrad_lights(self.ifc)), 3)          # Buero 2, Bad 1
        self.assertEqual(len(fixtures.room_fixtures(sp["Buero"])), 2)
        self.doc.undo()
        self.assertEqual(len(invrad_lights(self.ifc)), 4)
        self.assertEqual(len(fixtures.room_fixtures(sp["Buero"])), 3)
        self.doc.undo()
        self.assertEqual(invrad_lights(self.ifc), [])

    def test_a_failed_insert_leaves_document_and_file_unchanged(self):
        from invrad_wb.core.model.luminaires import Luminaire
        sp = self.spaces()
        before = snapshot(self.doc)
        n = len(list(self.ifc))
        lum = Luminaire([4.0, 7.8, 2.4], [0, 0, -1], 1000.0)
        calls = []
        from invrad_wb.app import ifcdata
        real = ifcdata.luminaire_psets

        def fail_second(*args):           # the second fixture's property sets fail
            calls.append(1)
            if len(calls) == 2:
                raise InvradError("injected failure")
            return real(*args)
        ifcdata.luminaire_psets = fail_second      # nativeifc looks it up per call
        try:
            with self.assertRaises(InvradError):
                fixtures.insert_fixtures(self.doc, [(sp["Buero"], [lum]), (sp["Bad"], [lum])])
        finally:
            ifcdata.luminaire_psets = real
        self.assertEqual(len(calls), 2)
        self.assertEqual(snapshot(self.doc), before)
        self.assertEqual(len(list(self.ifc)), n)
        self.assertEqual(invrad_lights(self.ifc), [])
        # and the file's undo history is unchanged: a later step still undoes alone
        fixtures.insert_fixtures(self.doc, [(sp["Buero"], [lum])])
        self.assertEqual(len(invrad_lights(self.ifc)), 1)
        self.doc.undo()
        self.assertEqual(invrad_lights(self.ifc), [])
        self.assertEqual(len(list(self.ifc)), n)


@needs_native
@needs_fzk
class TestNativeLockedDocument(FreeCADTestCase):
    """NativeIFC's single-document ("locked") mode, what File > Open does: the document
    itself is the project."""

    def test_fixtures_undo_and_save_when_the_document_is_the_project(self):
        import ifcopenshell.util.element as E
        from invrad_wb.core.model.luminaires import Luminaire
        src = self.path("fzk.ifc")
        shutil.copy(FZK, src)
        doc, proj = ifcimport.open_ifc(src, doc=self.doc, shapemode=2, singledoc=True)
        self.assertIs(proj, doc)
        ifc = doc.Proxy.ifcfile
        sp = {rooms.room_name(s): s for s in rooms.find_spaces(doc)}
        self.assertEqual(set(sp), FZK_ROOMS)
        from invrad_wb.app import ifcdata
        from invrad_wb.core.model.aiming import aim_from_tilt_pan, aimed_c0
        mount = np.array([0.0, 0.0, -1.0])
        aim = aim_from_tilt_pan(mount, 35.0, 200.0)          # the second one: a tilted spot
        lums = [Luminaire([3.0, 7.8, 2.4], mount, 800.0),
                Luminaire([3.5, 7.8, 2.4], aim, 800.0, c0=aimed_c0(mount, aim),
                          extra={"tilt_deg": 35.0, "pan_deg": 200.0})]
        plain, spot = fixtures.insert_fixtures(doc, [(sp["Buero"], lums)])
        self.assertEqual(len(invrad_lights(ifc)), 2)
        # the spot's aim in the document (as a classic fixture's) and read from its entity
        self.assertNotIn("Tilt", plain.PropertiesList)
        self.assertEqual((spot.Tilt, spot.Pan), (35.0, 200.0))
        self.assertIn("ReadOnly", spot.getPropertyStatus("Tilt"))
        back = fixtures.fixture_luminaire(spot)
        self.assertLess(np.degrees(np.arccos(np.clip(back.normal @ aim, -1, 1))), 1e-6)
        self.assertLess(np.linalg.norm(back.c0 - lums[1].c0), 1e-9)
        self.assertAlmostEqual(back.extra["tilt_deg"], 35.0, places=9)
        self.assertAlmostEqual(back.extra["pan_deg"], 200.0, places=9)
        for e in invrad_lights(ifc):
            self.assertEqual(E.get_container(e).GlobalId, rooms.space_uid(sp["Buero"]))
        doc.undo()
        self.assertEqual(invrad_lights(ifc), [])
        doc.redo()
        self.assertEqual(len(invrad_lights(ifc)), 2)
        out = nativeifc.save(proj, self.path("saved.ifc"))
        saved = read(out)
        self.assertEqual(len(invrad_lights(saved)), 2)
        # the saved file, read back: position within 1 mm, aim, tilt, pan within 0.1 deg
        import ifcopenshell.util.unit as U
        (e,) = [e for e in invrad_lights(saved)
                if "Tilt" in E.get_psets(e)["InvRad_Luminaire"]]
        got = ifcdata.invrad_fixture_data(e, U.calculate_unit_scale(saved), saved)
        self.assertLess(np.linalg.norm(got.position - lums[1].position), 1e-3)
        self.assertLess(np.degrees(np.arccos(np.clip(got.normal @ aim, -1, 1))), 0.1)
        self.assertLess(np.degrees(np.arccos(np.clip(got.c0 @ lums[1].c0, -1, 1))), 0.1)
        self.assertLess(abs(got.extra["tilt_deg"] - 35.0), 0.1)
        self.assertLess(abs(got.extra["pan_deg"] - 200.0), 0.1)


@needs_native
@needs_fzk
class TestRequirementsRead(FreeCADTestCase):

    def test_both_lighting_sets_become_work_planes(self):
        import ifcopenshell.api.pset as PS
        ifc = read(FZK)
        by = {s.LongName: s for s in ifc.by_type("IfcSpace")}
        p = PS.add_pset(ifc, product=by["Buero"], name="Pset_SpaceLightingRequirements")
        PS.edit_pset(ifc, pset=p, properties={"Illuminance": 500.0})
        # the IFC4.3 name of the same set, as other tools may write it
        p = ifc.create_entity("IfcPropertySet", GlobalId=__import__(
            "ifcopenshell.guid").guid.new(), Name="Pset_SpaceLightingDesign",
            HasProperties=[ifc.create_entity(
                "IfcPropertySingleValue", Name="Illuminance",
                NominalValue=ifc.create_entity("IfcIlluminanceMeasure", 150.0))])
        ifc.create_entity("IfcRelDefinesByProperties", GlobalId=__import__(
            "ifcopenshell.guid").guid.new(), RelatedObjects=[by["Flur"]],
            RelatingPropertyDefinition=p)
        path = self.path("req.ifc")
        ifc.write(path)
        ifcimport.open_ifc(path, doc=self.doc, shapemode=2)
        wp = {rooms.room_name(s): targets.work_plane_target(s)
              for s in rooms.find_spaces(self.doc)}
        self.assertEqual(wp["Buero"].Lux, 500.0)
        self.assertEqual(wp["Flur"].Lux, 150.0)
        self.assertIsNone(wp["Küche"])


@needs_native
@needs_fzk
class TestAimedFixturesOpenedFromTheIfc(FreeCADTestCase):
    """A NativeIFC document opened fresh from its saved ``.ifc`` (what File > Open does:
    NativeIFC makes objects for the building structure, a space's contents only when it is
    expanded): invrad's aimed fixtures are there with their Tilt, Pan and AimPoint read
    from the file, whether invrad makes them on opening or NativeIFC's expansion does."""

    def setUp(self):
        super().setUp()
        from invrad_wb.core.model.aiming import aim_from_tilt_pan, aimed_c0
        from invrad_wb.core.model.luminaires import Luminaire
        self.src = self.path("fzk.ifc")
        shutil.copy(FZK, self.src)
        doc, proj = ifcimport.open_ifc(self.src, doc=self.doc, shapemode=2)
        sp = {rooms.room_name(s): s for s in rooms.find_spaces(doc)}["Wohnen"]
        mount = np.array([0.0, 0.0, -1.0])
        self.lums = []
        for k, (tilt, pan) in enumerate(((40.0, 30.0), (25.0, 200.0))):
            aim = aim_from_tilt_pan(mount, tilt, pan)
            self.lums.append(Luminaire([3.0 + k, 5.0, 2.4], aim, 800.0,
                                       c0=aimed_c0(mount, aim),
                                       extra={"tilt_deg": tilt, "pan_deg": pan}))
        made = fixtures.insert_fixtures(doc, [(sp, self.lums)])
        self.aim_points = {f.GlobalId: f.AimPoint for f in made}
        nativeifc.save(proj)

    def opened(self, strategy, singledoc):
        from nativeifc import ifc_import
        doc = FreeCAD.newDocument("Reopened")
        name = doc.Name
        self.addCleanup(lambda: FreeCAD.closeDocument(name)
                        if name in FreeCAD.listDocuments() else None)
        ifc_import.insert(self.src, doc.Name, strategy=strategy, shapemode=2, switchwb=False,
                          silent=True, singledoc=singledoc)
        return doc

    def assertAimed(self, doc):
        got = {f.GlobalId: f for f in doc.Objects
               if nativeifc.is_native_fixture(f, generated_only=True)}
        self.assertEqual(set(got), set(self.aim_points))
        for lum, (uid, pt) in zip(self.lums, self.aim_points.items()):
            f = got[uid]
            with self.subTest(fixture=f.Label):
                self.assertLess(abs(f.Tilt - lum.extra["tilt_deg"]), 0.1)
                self.assertLess(abs(f.Pan - lum.extra["pan_deg"]), 0.1)
                self.assertLess((f.AimPoint - pt).Length, 1.0)
                self.assertIn("ReadOnly", f.getPropertyStatus("Tilt"))
                self.assertEqual(rooms.room_name(fixtures.fixture_room(f)), "Wohnen")
                back = fixtures.fixture_luminaire(f)
                self.assertLess(np.linalg.norm(back.position - lum.position), 1e-3)
                self.assertLess(np.degrees(np.arccos(np.clip(back.normal @ lum.normal,
                                                             -1, 1))), 0.1)
        return got

    def test_aimed_fixtures_have_their_aim_when_opened_and_when_expanded(self):
        from nativeifc import ifc_tools
        from invrad_wb.app import aimsync
        aimsync.install()           # (the workbench's InitGui.py does it in the GUI)
        # opened with its rooms ("building structure"; a project object, or the document
        # itself as File > Open does): invrad makes its aimed fixtures' objects
        for singledoc in (False, True):
            with self.subTest(singledoc=singledoc):
                self.assertAimed(self.opened(1, singledoc))
        # opened with its project only: the user expands the tree down to the Wohnen's
        # contents (NativeIFC's expansion: create_children, then a recompute)
        doc = self.opened(0, False)
        self.assertEqual([o for o in doc.Objects if nativeifc.is_native_fixture(o)], [])
        for _ in range(4):
            for o in list(doc.Objects):
                if getattr(o, "IfcClass", "") in ("IfcProject", "IfcSite", "IfcBuilding",
                                                  "IfcBuildingStorey") or (
                        nativeifc.is_native_space(o) and rooms.room_name(o) == "Wohnen"):
                    if ifc_tools.can_expand(o):
                        ifc_tools.create_children(o, recursive=False, assemblies=True)
            doc.recompute()
        self.assertAimed(doc)

    def test_a_moved_native_fixture_keeps_its_aim_in_the_document_and_the_ifc(self):
        import ifcopenshell.util.unit as U
        from invrad_wb.app import ifcdata
        from invrad_wb.app.aimsync import same_placement
        self.doc.recompute()
        fx = [f for f in self.doc.Objects if nativeifc.is_native_fixture(f, True)][0]
        ifc = nativeifc.ifcfile(fx)

        def stored():                  # the fixture as its IFC entity says
            return ifcdata.invrad_fixture_data(nativeifc.entity(fx),
                                               U.calculate_unit_scale(ifc), ifc)
        pl0, aim0, tilt0 = FreeCAD.Placement(fx.Placement), FreeCAD.Vector(fx.AimPoint), \
            fx.Tilt
        pl = FreeCAD.Placement(pl0)
        pl.Base = pl.Base + FreeCAD.Vector(1000, 0, 0)      # 1 m: its beam on the floor
        self.doc.openTransaction("Move")
        fx.Placement = pl
        self.doc.commitTransaction()
        self.assertLess((fx.AimPoint - aim0 - FreeCAD.Vector(1000, 0, 0)).Length, 1.0)
        self.assertEqual(fx.Tilt, tilt0)
        np.testing.assert_allclose(stored().position, self.lums[0].position + [1, 0, 0],
                                   atol=1e-6)
        self.doc.undo()
        self.assertTrue(same_placement(fx.Placement, pl0))
        self.assertLess((fx.AimPoint - aim0).Length, 1e-6)
        np.testing.assert_allclose(stored().position, self.lums[0].position, atol=1e-6)
        self.assertLess(abs(stored().extra["tilt_deg"] - tilt0), 1e-9)

    def test_a_native_fixture_turned_back_to_its_mount_normal_keeps_no_stale_tilt(self):
        import ifcopenshell.util.unit as U
        from invrad_wb.app import ifcdata
        self.doc.recompute()
        fx = [f for f in self.doc.Objects if nativeifc.is_native_fixture(f, True)][0]
        ifc = nativeifc.ifcfile(fx)

        def stored():
            return ifcdata.invrad_fixture_data(nativeifc.entity(fx),
                                               U.calculate_unit_scale(ifc), ifc)
        tilt0 = fx.Tilt
        self.assertGreater(tilt0, 1.0)
        # an edited tilt; then below the aimed threshold (0.5 degrees), and none
        for tilt in (20.0, 0.3, 0.0):
            self.doc.openTransaction("Edit")
            fx.Tilt = tilt
            self.doc.commitTransaction()
            self.assertLess(abs(stored().extra["tilt_deg"] - tilt), 1e-9)
            # the light now leaves within that tilt of straight down (a ceiling spot)
            self.assertLess(abs(np.degrees(np.arccos(np.clip(-stored().normal[2], -1, 1)))
                                - tilt), 1e-4)
        for _ in range(3):
            self.doc.undo()
        self.assertLess(abs(stored().extra["tilt_deg"] - tilt0), 1e-9)
