"""Base TestCase and model builders for the FreeCAD tests (run under freecadcmd)."""
import contextlib
import importlib.util
import os
import shutil
import sys
import tempfile
import unittest

import numpy as np

import FreeCAD

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
EXAMPLES = os.path.join(ROOT, "examples")


def _find_fzk():
    """The FZK-Haus sample: $INVRAD_FZK_IFC, ../shared/data, or the copy in tests/data."""
    for path in (os.environ.get("INVRAD_FZK_IFC"),
                 os.path.join(ROOT, "..", "shared", "data", "AC20-FZK-Haus.ifc"),
                 os.path.join(ROOT, "tests", "data", "AC20-FZK-Haus.ifc")):
        if path and os.path.isfile(path):
            return os.path.abspath(path)
    return os.path.join(ROOT, "tests", "data", "AC20-FZK-Haus.ifc")


FZK = _find_fzk()
FZK_ROOMS = {"Schlafzimmer", "Bad", "Buero", "Wohnen", "Flur", "Küche", "Galerie"}


def has_module(name):
    try:
        return importlib.util.find_spec(name) is not None
    except (ImportError, ValueError):
        return False


needs_locate = unittest.skipUnless(has_module("invrad_wb.core.inverse.locate"),
                                   "needs the locate core (invrad_wb.core.inverse.locate)")
needs_radiosity = unittest.skipUnless(has_module("invrad_wb.core.forward.radiosity"),
                                      "needs the radiosity model (invrad_wb.core.forward.radiosity)")
needs_fzk = unittest.skipUnless(os.path.isfile(FZK), f"sample building {FZK} not found")


@contextlib.contextmanager
def fzk_document():
    """The FZK-Haus imported into a new document (``ifcrooms.import_ifc``), closed after."""
    from invrad_wb.app import ifcrooms
    doc = ifcrooms.import_ifc(FZK).doc
    try:
        yield doc
    finally:
        FreeCAD.closeDocument(doc.Name)


def fzk_stair_and_opening():
    """FZK-Haus's spiral stair and the slab opening over the Wohnen as ``[(name, (plan
    min, plan max) metres, (underside, top) z of the opening / top of the stair)]``, read
    from the IFC file with ifcopenshell."""
    import ifcopenshell
    import ifcopenshell.geom
    ifc = ifcopenshell.open(FZK)
    settings = ifcopenshell.geom.settings()
    settings.set(settings.USE_WORLD_COORDS, True)
    out = []
    for name, el in (("stair", ifc.by_type("IfcStair")[0]),
                     ("opening", next(r.RelatedOpeningElement
                                      for r in ifc.by_type("IfcRelVoidsElement")
                                      if r.RelatingBuildingElement.is_a("IfcSlab")))):
        shape = ifcopenshell.geom.create_shape(settings, el)
        v = np.array(shape.geometry.verts, dtype=np.float64).reshape(-1, 3)   # a copy: see
        del shape                                                 # roomzones.body_vertices
        out.append((name, (v[:, :2].min(0), v[:, :2].max(0)),
                    v[:, 2].max() if name == "stair" else (v[:, 2].min(), v[:, 2].max()),
                    _plan_hull(v[:, :2])))
    return out


def _plan_hull(xy):
    """Convex hull (h, 2), counter-clockwise, of plan points (Andrew's monotone chain)."""
    pts = sorted(set(map(tuple, np.round(xy, 9))))

    def half(seq):
        h = []
        for p in seq:
            while len(h) >= 2 and ((h[-1][0] - h[-2][0]) * (p[1] - h[-2][1])
                                   - (h[-1][1] - h[-2][1]) * (p[0] - h[-2][0])) <= 0:
                h.pop()
            h.append(p)
        return h
    lower, upper = half(pts), half(pts[::-1])
    return np.array(lower[:-1] + upper[:-1])


def _in_hull(hull, p, margin=0.0):
    """(k,) bool: plan points p (k, 2) inside a counter-clockwise convex hull or within
    ``margin`` of it."""
    a, b = hull, np.roll(hull, -1, axis=0)
    cross = ((b[:, 0] - a[:, 0])[None] * (p[:, 1:2] - a[:, 1][None])
             - (b[:, 1] - a[:, 1])[None] * (p[:, 0:1] - a[:, 0][None]))
    ab = b - a
    t = np.clip(((p[:, None, :] - a[None]) * ab[None]).sum(-1) / (ab * ab).sum(-1)[None], 0, 1)
    dist = np.linalg.norm(p[:, None, :] - (a[None] + t[..., None] * ab[None]), axis=-1)
    return np.all(cross > 0, axis=1) | (dist.min(axis=1) < margin)


class FreeCADTestCase(unittest.TestCase):
    """Each test gets a fresh document (undo on) and a temporary folder; both go away."""

    def setUp(self):
        self._docs_before = set(FreeCAD.listDocuments())
        self.doc = FreeCAD.newDocument(f"T{id(self) % 100000}")
        self.doc.UndoMode = 1
        FreeCAD.setActiveDocument(self.doc.Name)
        self.tmp = tempfile.mkdtemp(prefix="invrad-fctest-")

    def tearDown(self):
        for name in set(FreeCAD.listDocuments()) - self._docs_before:
            FreeCAD.closeDocument(name)
        shutil.rmtree(self.tmp, ignore_errors=True)

    def path(self, name):
        return os.path.join(self.tmp, name)

    def assertUnchanged(self, snapshot, doc=None):
        """The document is as :func:`invrad_wb.app.document.snapshot` saw it."""
        from invrad_wb.app.document import snapshot as snap
        now = snap(doc or self.doc)
        if now != snapshot:
            added = sorted(set(now) - set(snapshot))
            removed = sorted(set(snapshot) - set(now))
            changed = sorted(k for k in set(now) & set(snapshot) if now[k] != snapshot[k])
            detail = {k: {p: (snapshot[k].get(p), now[k].get(p)) for p in
                          set(now[k]) | set(snapshot[k]) if now[k].get(p) != snapshot[k].get(p)}
                      for k in changed[:3]}
            self.fail(f"document changed: added {added}, removed {removed}, changed"
                      f" {changed} {detail}")

    def assertRoomMeetsDesign(self, room, work_plane):
        """A design summary's room meets every EN 12464-1 item asked (work plane level and
        U0, walls, ceiling) and shows its UGR; ``work_plane`` is the requirement's item."""
        self.assertTrue(room["compliant"], (room["pass"], room["notes"]))
        self.assertTrue(all(room["pass"].values()), room["pass"])
        self.assertEqual(set(room["surfaces"]), {"walls", "ceiling", "surroundings"})
        self.assertGreaterEqual(room["em_lux"], work_plane["lux"] - 0.5)
        self.assertGreaterEqual(room["u0"], work_plane["u0"] - 0.005)
        self.assertIsNotNone(room["ugr"])

    def assertClearOfFZKStairAndOpening(self, positions):
        """FZK-Haus: no luminaire (positions (k, 3) metres) over the spiral stair, and none
        on the ceiling's level over the slab opening above the Wohnen (no ceiling there:
        only pendants hung below it). Both read from the IFC file, not from invrad."""
        p = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
        for name, (lo, hi), z_top, hull in fzk_stair_and_opening():
            inside = np.all((p[:, :2] > lo) & (p[:, :2] < hi), axis=1)
            if name == "stair":     # over the stair: within its plan (the spiral's hull),
                inside = _in_hull(hull, p[:, :2], margin=0.1)   # or a body's width of it
                self.assertFalse(inside.any(), f"luminaire over the stair: {p[inside]}")
            else:      # at the Wohnen's ceiling or in the slab (the Galerie's roof is higher)
                bad = inside & (p[:, 2] > z_top[0] - 0.1) & (p[:, 2] < z_top[1] + 0.1)
                self.assertFalse(bad.any(), f"luminaire in the slab opening: {p[bad]}")

    def assertRaisesMessage(self, exc_type, *fragments):
        """Context manager: raises ``exc_type`` whose message contains every fragment."""
        test = self

        class _Ctx:
            def __enter__(self):
                return self

            def __exit__(self, et, ev, tb):
                if et is None:
                    test.fail(f"{exc_type.__name__} not raised")
                if not issubclass(et, exc_type):
                    return False
                msg = str(ev)
                for frag in fragments:
                    test.assertIn(frag, msg, f"message {msg!r} lacks {frag!r}")
                self.exception = ev
                return True
        return _Ctx()


def make_walled_room(doc, size=(4.0, 3.0, 2.7), wall=0.2, slab=0.2, origin=(0.0, 0.0, 0.0),
                     label="Office"):
    """A room as an architect models it: 4 walls on a closed outline, a floor slab and a
    ceiling slab (Arch Structures from rectangles), and an Arch Space whose boundaries are
    the walls' inner faces, the slab's top face and the ceiling's bottom face.

    ``size`` is the outline (wall axes) and the storey height in metres; the room inside
    is ``(x - wall, y - wall, z)``. Returns the Space.
    """
    import Arch
    import Draft
    V = FreeCAD.Vector
    sx, sy, h = (s * 1000 for s in size)
    ox, oy, oz = (o * 1000 for o in origin)
    w, t = wall * 1000, slab * 1000
    FreeCAD.setActiveDocument(doc.Name)
    outline = Draft.makeWire([V(ox, oy, oz), V(ox + sx, oy, oz), V(ox + sx, oy + sy, oz),
                              V(ox, oy + sy, oz)], closed=True, face=False)
    walls = Arch.makeWall(outline, width=w, height=h, align="Center")
    floor = Arch.makeStructure(Draft.makeRectangle(
        sx + 2 * w, sy + 2 * w, placement=FreeCAD.Placement(V(ox - w, oy - w, oz - t),
                                                            FreeCAD.Rotation())), height=t)
    ceiling = Arch.makeStructure(Draft.makeRectangle(
        sx + 2 * w, sy + 2 * w, placement=FreeCAD.Placement(V(ox - w, oy - w, oz + h),
                                                            FreeCAD.Rotation())), height=t)
    floor.IfcType = ceiling.IfcType = "Slab"
    doc.recompute()
    inner = lambda c: (ox + w / 4 < c.x < ox + sx - w / 4 and oy + w / 4 < c.y < oy + sy - w / 4
                       and oz - 1 < c.z < oz + h + 1)
    bounds = []
    for obj in (walls, floor, ceiling):
        for i, f in enumerate(obj.Shape.Faces):
            n = f.normalAt(0, 0)
            if obj is walls and abs(n.z) > 0.5:
                continue
            if inner(f.CenterOfMass):
                bounds.append((obj, [f"Face{i + 1}"]))
    space = Arch.makeSpace(bounds)
    space.Label = label
    doc.recompute()
    return space


def make_box_space(doc, lo=(0, 0, 0), hi=(4, 3, 2.7), label="Box room", open_top=False):
    """A Space on a Part box solid (mm); ``open_top`` removes the top face (an open shell)."""
    import Arch
    import Part
    lo_mm = FreeCAD.Vector(*(np.asarray(lo) * 1000))
    d = (np.asarray(hi) - np.asarray(lo)) * 1000
    box = Part.makeBox(float(d[0]), float(d[1]), float(d[2]), lo_mm)
    shape = box
    if open_top:
        shape = Part.Shell([f for f in box.Faces if f.CenterOfMass.z < lo_mm.z + d[2] - 1])
    base = doc.addObject("Part::Feature", "RoomSolid")
    base.Shape = shape
    FreeCAD.setActiveDocument(doc.Name)
    space = Arch.makeSpace(baseobj=base)
    space.Label = label
    doc.recompute()
    return space


def face_of_kind(space, kind):
    """The first 'FaceN' of a Space of one kind (floor, walls, ceiling)."""
    from invrad_wb.app.rooms import faces_by_kind
    return faces_by_kind(space, kind)[0]


def down(x, y, z=2.7, flux=2000.0):
    """A luminaire at (x, y, z), metres, aimed straight down."""
    from invrad_wb.core.model.luminaires import Luminaire
    return Luminaire([x, y, z], [0, 0, -1], flux)


class FakeLocateResult:
    def __init__(self, luminaires):
        self.luminaires = luminaires
        self.settings = {}
        self.timings = {}


def fake_locate(luminaires_by_room, fail=None):
    """A locate stand-in returning known luminaires: ``{room id: [Luminaire, ...]}``."""
    calls = []

    def locate(scene, flux_lm, settings=None, progress=None, backend="auto", room_names=None):
        calls.append(scene)
        if progress is not None:
            progress(0.5, "fake locate")
        if fail is not None:
            raise fail
        out = []
        for room, lums in luminaires_by_room.items():
            for l in lums:
                l.room = room
                out.append(l)
        return FakeLocateResult(out)
    locate.calls = calls
    return locate
