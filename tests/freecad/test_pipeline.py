"""The headless pipeline: rooms + targets -> locate -> verify -> report -> fixtures."""
import json
import math
import os

import numpy as np

import FreeCAD

from fctest import (FreeCADTestCase, down, fake_locate, make_box_space,
                    make_walled_room, needs_locate)
from invrad_wb.app import document, fixtures, pipeline, rooms, targets
from invrad_wb.app.pipeline import PipelineSettings
from invrad_wb.core.model import targets as CT
from invrad_wb.errors import Cancelled, InvradError, SceneError, SettingsError


class TestPipelineMechanics(FreeCADTestCase):
    """With a stand-in for locate: what the pipeline does around it."""

    def setUp(self):
        super().setUp()
        self.office = make_walled_room(self.doc, label="Office")
        self.store = make_box_space(self.doc, (6, 0, 0), (9, 3, 2.5), label="Store")
        targets.set_work_plane(self.office, 500.0)
        targets.add_uniform_target(self.office, "walls", 150.0)

    def settings(self, **kw):
        kw.setdefault("flux_lm", 2000.0)
        kw.setdefault("interreflection", False)
        kw.setdefault("resolution_m", 0.4)
        return PipelineSettings(**kw)

    def test_prepare_builds_one_scene_with_a_virtual_work_plane(self):
        b = pipeline.prepare(self.doc, self.settings())
        self.assertEqual(b.room_names, ["Office"])             # Store has no targets
        sc = b.scene
        self.assertEqual(int(sc.face_virtual.sum()), b.rooms[0].n_work_plane)
        wp = np.unique(sc.faces[sc.face_virtual])
        np.testing.assert_allclose(sc.vertices[wp, 2], 0.75)
        np.testing.assert_allclose(sc.vertex_lux[wp], 500.0)
        self.assertTrue(np.all(sc.face_reflectance[sc.face_virtual] == 0))
        self.assertTrue(any(p.is_virtual for p in sc.planes))
        real = np.unique(sc.faces[~sc.face_virtual])
        walls = np.abs(sc.vertex_normals[real][:, 2]) < 0.5
        np.testing.assert_allclose(sc.vertex_lux[real][walls], 150.0)

    def test_two_rooms_get_two_room_ids(self):
        targets.add_uniform_target(self.store, "floor", 200.0)
        b = pipeline.prepare(self.doc, self.settings())
        self.assertEqual(b.room_names, ["Office", "Store"])
        self.assertEqual(b.scene.rooms.tolist(), [0, 1])

    def test_run_inserts_fixtures_as_one_undo_step_and_reports(self):
        before = document.snapshot(self.doc)
        n = self.doc.UndoCount
        loc = fake_locate({0: [down(1.2, 1.5), down(2.8, 1.5)]})
        steps = []
        rep = self.path("report")
        res = pipeline.run(self.doc, self.settings(report_dir=rep, interreflection=True),
                           progress=lambda f, m: steps.append((f, m)) or True, locate=loc)
        self.assertEqual(len(loc.calls), 1)
        self.assertEqual(len(res.fixtures), 2)
        self.assertEqual(self.doc.UndoCount, n + 1)
        self.assertEqual(len(fixtures.room_fixtures(self.office)), 2)
        fr = [f for f, _ in steps]
        self.assertEqual(fr, sorted(fr))
        self.assertEqual(fr[-1], 1.0)
        with open(os.path.join(rep, "summary.json")) as fh:
            summary = json.load(fh)
        self.assertEqual(summary["rooms"][0]["room"], "Office")
        self.assertEqual(len(summary["luminaires"]), 2)
        self.assertEqual(summary["luminaires"][0]["fixture"], "Luminaire Office 1")
        wp = summary["rooms"][0]["work_plane"]
        self.assertGreater(wp["mean_achieved_lux"], 0)
        self.assertTrue(math.isfinite(wp["rms_relative_error"]))
        # the verification is a real forward solve: compare with the analytic direct light
        sc = res.building.scene
        v = np.unique(sc.faces[sc.face_virtual])
        direct = np.zeros(len(v))
        for lum in res.luminaires:
            d = lum.position - sc.vertices[v]
            r2 = np.einsum("ij,ij->i", d, d)
            direct += lum.flux_lm * (d[:, 2] / np.sqrt(r2)) ** 2 / (math.pi * r2)
        self.assertTrue(np.all(res.achieved[v] >= direct - 1e-6))
        self.doc.undo()
        self.assertUnchanged(before)

    def test_rerun_replaces_the_previous_run(self):
        pipeline.run(self.doc, self.settings(), locate=fake_locate({0: [down(1, 1), down(3, 2)]}))
        pipeline.run(self.doc, self.settings(), locate=fake_locate({0: [down(2, 1.5)]}))
        self.assertEqual(len(fixtures.room_fixtures(self.office)), 1)

    def test_insert_false_only_computes(self):
        before = document.snapshot(self.doc)
        res = pipeline.run(self.doc, self.settings(insert=False),
                           locate=fake_locate({0: [down(1, 1)]}))
        self.assertEqual(res.fixtures, [])
        self.assertUnchanged(before)

    def test_cancel_leaves_the_document_unchanged(self):
        before = document.snapshot(self.doc)
        for stage in ("mesh and targets", "fake locate", "verify", "insert fixtures"):
            with self.assertRaisesMessage(Cancelled, stage):
                pipeline.run(self.doc, self.settings(),
                             progress=lambda f, m, s=stage: s not in m,
                             locate=fake_locate({0: [down(1, 1)]}))
            self.assertUnchanged(before)

    def test_failing_locate_leaves_the_document_unchanged(self):
        before = document.snapshot(self.doc)
        with self.assertRaises(RuntimeError):
            pipeline.run(self.doc, self.settings(),
                         locate=fake_locate({}, fail=RuntimeError("device lost")))
        self.assertUnchanged(before)


class TestBadDocuments(FreeCADTestCase):
    """Clear messages naming the object, and the document left as it was."""

    def run_expecting(self, exc_type, *words, doc=None, **kw):
        doc = doc or self.doc
        before = document.snapshot(doc)
        kw.setdefault("flux_lm", 1000.0)
        with self.assertRaisesMessage(exc_type, *words) as ctx:
            pipeline.run(doc, PipelineSettings(interreflection=False, **kw),
                         locate=fake_locate({0: [down(1, 1)]}))
        self.assertIsInstance(ctx.exception, InvradError)
        self.assertUnchanged(before, doc)

    def test_no_spaces(self):
        self.doc.addObject("Part::Box", "Box")
        self.run_expecting(SceneError, "no rooms (Arch Spaces)")

    def test_spaces_without_targets(self):
        make_walled_room(self.doc)
        make_box_space(self.doc, (6, 0, 0), (8, 2, 2.5), label="Store")
        self.run_expecting(SceneError, "none of the 2 rooms has lighting targets")

    def test_open_room(self):
        import Part
        space = make_box_space(self.doc, label="Atrium")
        targets.add_uniform_target(space, "floor", 300.0)
        box = space.Base.Shape
        space.Base.Shape = Part.Shell([f for f in box.Faces if f.CenterOfMass.z < 2600])
        self.doc.recompute()
        self.run_expecting(SceneError, "Atrium", "not closed")

    def test_target_on_a_missing_face(self):
        space = make_walled_room(self.doc)
        t = targets.add_uniform_target(space, "floor", 300.0, label="Desk")
        t.Faces = [(space, ["Face12"])]
        self.run_expecting(SceneError, "'Desk'", "Face12", "does not exist")

    def test_nan_and_negative_lux(self):
        space = make_walled_room(self.doc)
        t = targets.add_uniform_target(space, "floor", 300.0, label="Desk")
        t.Lux = float("nan")
        self.run_expecting(SceneError, "'Desk'", "Lux is nan")
        t.Lux = -1.0
        self.run_expecting(SceneError, "'Desk'", "negative")
        t.Lux = 300.0
        wp = targets.set_work_plane(space, 500.0)
        wp.Lux = float("nan")
        self.run_expecting(SceneError, "Work plane Office", "Lux is nan")

    def test_flux(self):
        space = make_walled_room(self.doc)
        targets.add_uniform_target(space, "floor", 300.0)
        for flux in (0.0, -100.0, float("nan"), "lots"):
            self.run_expecting(SettingsError, "flux", flux_lm=flux)

    def test_unknown_room_and_room_without_targets(self):
        space = make_walled_room(self.doc)
        make_box_space(self.doc, (6, 0, 0), (8, 2, 2.5), label="Store")
        targets.add_uniform_target(space, "floor", 300.0)
        self.run_expecting(SceneError, "no room 'Attic'", rooms=["Attic"])
        self.run_expecting(SceneError, "'Store'", "no lighting targets", rooms=["Store"])

    def test_work_plane_above_the_ceiling(self):
        space = make_walled_room(self.doc)
        targets.set_work_plane(space, 500.0, height_m=3.0)
        self.run_expecting(SceneError, "Office", "not below the ceiling")


def office_with_two_lights(doc, folder):
    """A black walled office whose floor and wall targets are the direct light of two
    known 2000 lm ceiling luminaires: (space, true luminaires)."""
    space = make_walled_room(doc, label="Office")
    targets.set_reflectance(space, 0.0, surface_type="All")
    truth = [down(1.15, 1.5, 2.7, 2000.0), down(2.85, 1.5, 2.7, 2000.0)]
    faces = rooms.faces_by_kind(space, "floor") + rooms.faces_by_kind(space, "walls")
    texture_targets_from(space, truth, faces, folder)
    return space, truth


def texture_targets_from(space, lums, faces, folder, px=48):
    """Target images on ``faces``: the direct light of known luminaires (forward solver)."""
    import OpenImageIO as oiio
    from invrad_wb.core.forward.direct import direct_illuminance
    m = rooms.mesh_room(space, 0.5)
    frames = CT.surface_frames(m.vertices, m.triangles, m.triangle_face)
    for face in faces:
        i = int(face[4:]) - 1
        fr = frames[i]
        ext = fr.hi - fr.lo
        w = max(8, int(round(px * ext[0] / max(ext))))
        h = max(8, int(round(px * ext[1] / max(ext))))
        s = (np.arange(w) + 0.5) / w
        t = 1.0 - (np.arange(h) + 0.5) / h
        S, T = np.meshgrid(s, t)
        uv = fr.lo + np.stack([S, T], axis=-1) * ext
        c = m.vertices[m.triangles[m.triangle_face == i][0, 0]] @ fr.normal
        pts = (uv[..., :1] * fr.u + uv[..., 1:] * fr.v + c * fr.normal).reshape(-1, 3)
        lux = direct_illuminance(pts, np.tile(fr.normal, (len(pts), 1)), lums,
                                 occlusion=False, backend="numpy").reshape(h, w)
        path = os.path.join(folder, f"{face}.exr")
        out = oiio.ImageOutput.create(path)
        out.open(path, oiio.ImageSpec(w, h, 1, oiio.FLOAT))
        out.write_image(lux[..., None].astype(np.float32))
        out.close()
        targets.add_texture_target(space, face, path)


@needs_locate
class TestLocateKnownAnswer(FreeCADTestCase):
    """The full pipeline with the real locate finds luminaires where they were."""

    def test_rooms_on_worker_processes_give_the_same_fixtures(self):
        # inside freecadcmd the executable is FreeCAD: the workers run the Python it embeds
        from invrad_wb.core.accel.workers import worker_python
        office = make_walled_room(self.doc, label="Office")
        store = make_box_space(self.doc, (6, 0, 0), (9, 3, 2.5), label="Store")
        targets.set_work_plane(office, 300.0)
        targets.set_work_plane(store, 200.0)
        self.assertIsNotNone(worker_python())
        found = {}
        for w in (1, 2):
            res = pipeline.run(self.doc, PipelineSettings(flux_lm=2000.0, resolution_m=0.4,
                                                          interreflection=False, workers=w,
                                                          insert=False))
            found[w] = [(tuple(l.position), l.flux_lm, l.room) for l in res.luminaires]
        self.assertEqual(found[1], found[2])
        self.assertEqual({r for _, _, r in found[1]}, {0, 1})

    def test_two_ceiling_luminaires_are_found(self):
        space, truth = office_with_two_lights(self.doc, self.tmp)
        res = pipeline.run(self.doc, PipelineSettings(flux_lm=2000.0, resolution_m=0.2,
                                                      interreflection=False,
                                                      report_dir=self.path("report")))
        found = sorted(res.luminaires, key=lambda l: l.position[0])
        self.assertEqual(len(found), 2, [l.position for l in found])
        for f, t in zip(found, truth):
            self.assertLess(np.linalg.norm(f.position - t.position), 0.05,
                            (f.position, t.position))
            self.assertGreater(f.normal @ t.normal, 0.99)
        fx = sorted(fixtures.room_fixtures(space), key=lambda o: o.Placement.Base.x)
        self.assertEqual(len(fx), 2)
        for obj, f in zip(fx, found):
            np.testing.assert_allclose(fixtures.fixture_luminaire(obj).position, f.position,
                                       atol=1e-9)
        st = res.summary["rooms"][0]["surfaces"]
        self.assertAlmostEqual(st["mean_achieved_lux"], st["mean_target_lux"],
                               delta=0.02 * st["mean_target_lux"])
        # (not the RMS: texels at the top of the walls, in the luminaires' own plane, give
        # small non-zero targets where the true light is 0)
        self.assertLess(st["median_relative_error"], 0.05)
