"""Rooms: Arch Spaces -> closed solids -> sampling meshes (metres, inward normals)."""
import math

import numpy as np

import FreeCAD

from fctest import FreeCADTestCase, make_box_space, make_walled_room
from invrad_wb.app import rooms
from invrad_wb.core.geometry.meshing import edge_lengths, triangle_areas, triangle_normals
from invrad_wb.app.targets import set_reflectance
from invrad_wb.errors import InvradError, SceneError, SettingsError


class TestWalledRoom(FreeCADTestCase):
    """A room built from walls and slabs, meshed for sampling."""

    def setUp(self):
        super().setUp()
        self.space = make_walled_room(self.doc)
        self.mesh = rooms.mesh_room(self.space, resolution_m=0.25)

    def test_space_is_closed_solid_of_the_inner_volume(self):
        shape = rooms.room_shape(self.space)
        self.assertEqual(len(shape.Faces), 6)
        self.assertAlmostEqual(shape.Volume / 1e9, 3.8 * 2.8 * 2.7, places=6)

    def test_metres_and_extent(self):
        v = self.mesh.vertices
        np.testing.assert_allclose(v.min(0), [0.1, 0.1, 0.0], atol=1e-9)
        np.testing.assert_allclose(v.max(0), [3.9, 2.9, 2.7], atol=1e-9)
        self.assertAlmostEqual(self.mesh.volume, 3.8 * 2.8 * 2.7, places=6)

    def test_surface_kinds_and_areas(self):
        m = self.mesh
        self.assertEqual(sorted(m.face_kind), ["ceiling", "floor", "wall", "wall", "wall",
                                               "wall"])
        area = dict(floor=0.0, ceiling=0.0, wall=0.0)
        for k, a in zip(m.face_kind, m.face_area):
            area[k] += a
        self.assertAlmostEqual(area["floor"], 3.8 * 2.8, places=9)
        self.assertAlmostEqual(area["ceiling"], 3.8 * 2.8, places=9)
        self.assertAlmostEqual(area["wall"], 2 * (3.8 + 2.8) * 2.7, places=9)
        self.assertAlmostEqual(triangle_areas(m.vertices, m.triangles).sum(),
                               2 * 3.8 * 2.8 + 2 * (3.8 + 2.8) * 2.7, places=9)

    def test_normals_point_into_the_room(self):
        m = self.mesh
        n = triangle_normals(m.vertices, m.triangles)
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        centroid = m.vertices[m.triangles].mean(axis=1)
        to_centre = np.array([2.0, 1.5, 1.35]) - centroid
        self.assertTrue(np.all(np.einsum("ij,ij->i", n, to_centre) > 0))
        kinds = np.array(m.face_kind)[m.triangle_face]
        self.assertTrue(np.allclose(n[kinds == "floor"], [0, 0, 1]))
        self.assertTrue(np.allclose(n[kinds == "ceiling"], [0, 0, -1]))
        for i, k in enumerate(m.face_kind):
            self.assertTrue(np.allclose(n[m.triangle_face == i], m.face_normal[i]))

    def test_faces_stay_planar_and_triangles_small(self):
        m = self.mesh
        self.assertLessEqual(edge_lengths(m.vertices, m.triangles).max(), 0.25 + 1e-12)
        for i in range(m.n_faces):
            pts = m.vertices[np.unique(m.triangles[m.triangle_face == i])]
            d = (pts - pts[0]) @ m.face_normal[i]
            self.assertLess(np.abs(d).max(), 1e-12)

    def test_vertices_are_not_shared_between_faces(self):
        m = self.mesh
        owner = np.full(len(m.vertices), -1)
        owner[m.triangles.reshape(-1)] = np.repeat(m.triangle_face, 3)
        self.assertTrue(np.all(owner[m.triangles] == m.triangle_face[:, None]))

    def test_resolution_sets_the_triangle_count(self):
        counts = {}
        for res in (0.5, 0.25, 0.125):
            counts[res] = len(rooms.mesh_room(self.space, res).triangles)
        self.assertGreater(counts[0.25], 3 * counts[0.5])
        self.assertGreater(counts[0.125], 3 * counts[0.25])
        area = 2 * 3.8 * 2.8 + 2 * (3.8 + 2.8) * 2.7
        # longest-edge bisection: triangles about a quarter of res^2 in area
        self.assertLess(counts[0.25], 2.5 * area / (0.25 ** 2 / 4))

    def test_default_reflectance_per_surface_type(self):
        m = self.mesh
        for k, r in zip(m.face_kind, m.face_reflectance):
            self.assertEqual(r, {"floor": 0.25, "wall": 0.5, "ceiling": 0.7}[k])

    def test_reflectance_overrides(self):
        floor = rooms.faces_by_kind(self.space, "floor")
        wall = rooms.faces_by_kind(self.space, "walls")[0]
        set_reflectance(self.space, 0.1, surface_type="Walls")
        set_reflectance(self.space, 0.8, faces=[wall])
        from invrad_wb.app.targets import room_specs
        _, refl, _ = room_specs(self.space, 6)
        m = rooms.mesh_room(self.space, 0.5, refl)
        w = int(wall[4:]) - 1
        for i, k in enumerate(m.face_kind):
            expect = 0.8 if i == w else {"floor": 0.25, "wall": 0.1, "ceiling": 0.7}[k]
            self.assertEqual(m.face_reflectance[i], expect)
        self.assertEqual(len(floor), 1)

    def test_bad_reflectance_and_resolution(self):
        with self.assertRaisesMessage(SceneError, "reflectance", "[0, 1)", "percentage"):
            rooms.mesh_room(self.space, 0.5, {"wall": 50})
        with self.assertRaisesMessage(SettingsError, "resolution"):
            rooms.mesh_room(self.space, 0.0)
        with self.assertRaisesMessage(SettingsError, "resolution", "metres"):
            rooms.mesh_room(self.space, 250.0)


class TestSpaceFromSolid(FreeCADTestCase):

    def test_box_base_inward_and_in_metres(self):
        space = make_box_space(self.doc, (1, 2, 3), (5, 5, 5.5))
        m = rooms.mesh_room(space, 0.5)
        np.testing.assert_allclose(m.vertices.min(0), [1, 2, 3])
        np.testing.assert_allclose(m.vertices.max(0), [5, 5, 5.5])
        self.assertAlmostEqual(m.volume, 4 * 3 * 2.5)
        n = triangle_normals(m.vertices, m.triangles)
        c = m.vertices[m.triangles].mean(1)
        self.assertTrue(np.all(np.einsum("ij,ij->i", n, [3, 3.5, 4.25] - c) > 0))

    def test_curved_wall_normals_point_to_the_axis(self):
        import Arch
        import Part
        base = self.doc.addObject("Part::Feature", "Drum")
        base.Shape = Part.makeCylinder(2000, 2500)
        space = Arch.makeSpace(baseobj=base)
        self.doc.recompute()
        m = rooms.mesh_room(space, 0.3)
        self.assertEqual(sorted(set(m.face_kind)), ["ceiling", "floor", "wall"])
        wall = np.array(m.face_kind)[m.triangle_face] == "wall"
        n = triangle_normals(m.vertices, m.triangles)[wall]
        c = m.vertices[m.triangles[wall]].mean(1)
        radial = c[:, :2] / np.linalg.norm(c[:, :2], axis=1, keepdims=True)
        self.assertTrue(np.all(np.einsum("ij,ij->i", n[:, :2], radial) < 0))
        self.assertAlmostEqual(m.volume, math.pi * 4 * 2.5, delta=0.02 * math.pi * 10)

    def test_space_inside_a_part_is_meshed_in_global_coordinates(self):
        space = make_box_space(self.doc, (0, 0, 0), (3, 3, 2.5))
        part = self.doc.addObject("App::Part", "Wing")
        part.addObject(space)
        part.addObject(space.Base)
        part.Placement = FreeCAD.Placement(FreeCAD.Vector(1000, 0, 3000), FreeCAD.Rotation())
        self.doc.recompute()
        m = rooms.mesh_room(space, 0.5)
        np.testing.assert_allclose(m.vertices.min(0), [1.0, 0.0, 3.0], atol=1e-9)


class TestBadRooms(FreeCADTestCase):

    def test_open_room_names_the_space_and_free_edges(self):
        space = make_box_space(self.doc, open_top=True, label="Atrium")
        with self.assertRaisesMessage(SceneError, "Atrium", "not closed", "free edges",
                                      "RoomSolid"):
            rooms.mesh_room(space)

    def test_space_without_geometry(self):
        import Arch
        space = Arch.makeSpace()
        space.Label = "Nowhere"
        self.doc.recompute()
        with self.assertRaisesMessage(SceneError, "Nowhere", "no geometry"):
            rooms.mesh_room(space)

    def test_boundaries_that_do_not_close_a_room(self):
        import Arch
        import Part
        plate = self.doc.addObject("Part::Feature", "Plate")
        plate.Shape = Part.makeBox(4000, 3000, 10)
        space = Arch.makeSpace()
        space.Proxy.addSubobjects(space, [(plate, ["Face1"])])
        space.Label = "Leaky"
        self.doc.recompute()
        with self.assertRaises(InvradError) as ctx:
            rooms.mesh_room(space)
        self.assertIn("Leaky", str(ctx.exception))

    def test_get_space_lists_the_rooms(self):
        make_box_space(self.doc, label="Kitchen")
        make_box_space(self.doc, label="Hall")
        self.assertEqual(rooms.get_space(self.doc, "Hall").Label, "Hall")
        with self.assertRaisesMessage(SceneError, "no room 'Attic'", "Kitchen", "Hall"):
            rooms.get_space(self.doc, "Attic")

    def test_no_spaces(self):
        with self.assertRaisesMessage(SceneError, "no rooms"):
            rooms.get_space(self.doc, "Office")


class TestBackendChoice(FreeCADTestCase):
    """A document's backend is chosen once (classic here: Arch Spaces) and forgotten when
    the document closes. (NativeIFC documents: test_nativeifc.TestBackendChoice.)"""

    def test_a_classic_document_has_the_classic_backend_once(self):
        from invrad_wb.app import backend
        space = make_box_space(self.doc)
        be = backend.of(self.doc)
        self.assertIs(be, backend.CLASSIC)
        self.assertFalse(be.native)
        self.assertIs(backend.of(space), be)                  # an object: its document's
        self.assertIs(backend._CHOSEN[self.doc.Name][1], be)  # chosen once, kept
        self.assertEqual(rooms.find_spaces(self.doc), [space])
        self.assertFalse(rooms.is_native(space))
        name = self.doc.Name
        FreeCAD.closeDocument(name)
        self.assertNotIn(name, backend._CHOSEN)
