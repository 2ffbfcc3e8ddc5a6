"""Aimed fixtures kept whole in the document: a document observer that

* **completes NativeIFC fixtures made lazily.** A NativeIFC document opened from an
  ``.ifc`` file makes objects for the building structure only (sites, storeys, spaces);
  an IfcSpace's contents, its light fixtures too, become objects when the user expands it
  (NativeIFC's ``create_children``, followed by a recompute). So when a NativeIFC project
  comes into a document (the file opened or inserted), the fixtures that invrad aimed
  (``InvRad_Luminaire`` with ``Tilt``: :mod:`.ifcdata`) are made into objects in their
  space, as NativeIFC's expansion would make them, and every NativeIFC IfcLightFixture
  object made later (expanded by the user) that is an aimed one gets its ``Tilt``, ``Pan``
  and ``AimPoint`` (read from its entity) and, in the GUI, its beam axis. Only light
  fixtures with invrad's property set are read, once per project: opening a large file
  costs one pass over its IfcLightFixture entities.
* **keeps an aimed fixture's aim consistent with its placement.** The placement is the
  fixture (its local -Z is the light), ``Tilt``/``Pan`` and ``AimPoint`` say what it
  means:

  - moved or turned (its ``Placement`` changed, the user dragged it): ``Tilt`` and
    ``Pan`` are the new light axis against the fixture's mounting normal, and
    ``AimPoint`` is where the beam axis now first meets the room (a spot moved along the
    ceiling lights a new place: a gimbal spot keeps its tilt and pan when its track or
    its ceiling box is moved, so the light moves with it, and the aim point shows where
    it lands; a point carried along with the fixture would float off the wall or sink
    into it as soon as the move is not parallel to the lit surface);
  - ``Tilt`` or ``Pan`` edited (a classic fixture; a NativeIFC one's are read-only, its
    placement is the IFC's): the placement turns about its base to that aim, with the
    luminaire's C0 axis carried by the tilt (:func:`invrad_wb.core.model.aiming.aimed_c0`).

  These updates are made inside the change that caused them, so they join its undo step
  (one undo restores the placement and the aim together); nothing happens while the
  document undoes, redoes or is being read, and an object being updated is not updated
  again by its own changes (no recursion).

The mounting normal of a fixture is its hidden ``MountNormal`` property (written with its
aim, :func:`.fixturebody.add_aim_properties`), else worked out from its placement and
``Tilt``/``Pan`` before the change (:func:`mount_normal`).

This module imports nothing at its top: :func:`install` is called where fixtures are
made (:mod:`.fixtures`), where an IFC file is opened natively (:mod:`.ifcimport`) and by
the workbench's start-up observer (:mod:`invrad_wb.gui.beamaxis`), for every document.
"""
#: The properties whose change moves the aim.
WATCHED = ("Placement", "Tilt", "Pan")
#: Beam axes shorter than this (mm) from the fixture are not where it lands (its own body).
MIN_THROW_MM = 5.0
#: Throw (mm) of a beam axis that meets nothing (an open room, no room).
DEFAULT_THROW_MM = 2000.0
_ANGLE_EPS_DEG = 1e-7
_POINT_EPS_MM = 1e-6


# --------------------------------------------------------------------------- geometry
def _vec(v):
    import numpy as np
    return np.array([v.x, v.y, v.z], dtype=np.float64)


def light_axes(placement):
    """(aim, c0): the unit light direction (local -Z) and C0 axis (local X) of a fixture's
    placement, as (3,) arrays."""
    import FreeCAD
    import numpy as np
    r = placement.Rotation
    a = _vec(r.multVec(FreeCAD.Vector(0, 0, -1)))
    x = _vec(r.multVec(FreeCAD.Vector(1, 0, 0)))
    return a / np.linalg.norm(a), x / np.linalg.norm(x)


def mount_normal(obj, placement=None, tilt=None, pan=None):
    """(3,) the mounting normal of an aimed fixture: its ``MountNormal`` property, else
    from ``placement``, ``tilt`` and ``pan`` (default its own: consistent ones, i.e. from
    before a change) by :func:`.fixturebody.mount_normal_of`; straight down (a ceiling) when neither
    gives one."""
    import numpy as np
    mn = getattr(obj, "MountNormal", None)
    if mn is not None and mn.Length > 0.5:
        m = _vec(mn)
        return m / np.linalg.norm(m)
    pl = obj.Placement if placement is None else placement
    a, c0 = light_axes(pl)
    from invrad_wb.app.fixturebody import mount_normal_of
    m = mount_normal_of(a, c0, float(obj.Tilt if tilt is None else tilt),
                        float(obj.Pan if pan is None else pan))
    return m if m is not None else np.array([0.0, 0.0, -1.0])


def room_shape(obj):
    """The closed shape (global mm) of an aimed fixture's room, or None: a classic
    fixture's ``Room`` Space, a NativeIFC fixture's IfcSpace (its solid)."""
    from invrad_wb.app import nativeifc
    try:
        if nativeifc.is_native(obj):
            space = nativeifc.fixture_room(obj)
            return nativeifc.space_solid(space) if space is not None else None
        room = getattr(obj, "Room", None)
        shape = getattr(room, "Shape", None)
        return shape if shape is not None and not shape.isNull() else None
    except Exception:          # no geometry, a broken room: the axis ends at its throw
        return None


def beam_hit_mm(shape, base, aim, throw_mm=DEFAULT_THROW_MM):
    """Where the ray from ``base`` (FreeCAD Vector, mm) along the unit ``aim`` (3,) first
    meets ``shape`` (FreeCAD Vector, mm); ``throw_mm`` along it when it meets nothing."""
    import FreeCAD
    import Part
    d = FreeCAD.Vector(*(float(x) for x in aim))
    hits = []
    if shape is not None:
        try:
            seg = Part.LineSegment(base, base + d * 1e5).toShape()
            hits = [(v.Point - base).Length for v in seg.section(shape).Vertexes]
        except Exception:      # a broken solid
            hits = []
    hits = [h for h in hits if h > MIN_THROW_MM]
    return base + d * (min(hits) if hits else throw_mm)


# --------------------------------------------------------------------------- updates
def _set(obj, name, value, same):
    """Set ``obj.name = value`` unless ``same(old, value)`` (no needless touch)."""
    if name in obj.PropertiesList and not same(getattr(obj, name), value):
        setattr(obj, name, value)


def _same_float(a, b):
    return abs(float(a) - float(b)) < _ANGLE_EPS_DEG


def _same_vec(a, b):
    return (a - b).Length < _POINT_EPS_MM


def same_placement(a, b, tol=1e-9):
    """Two placements equal within ``tol`` (their matrices; FreeCAD 0.20's Placement has
    no ``isSame``)."""
    return max(abs(x - y) for x, y in zip(a.toMatrix().A, b.toMatrix().A)) <= tol


def follow_placement(obj, old_placement=None, old_tilt=None, old_pan=None, old_aim=None):
    """An aimed fixture whose placement changed: ``Tilt``/``Pan`` from its new light axis
    against its mounting normal (from its state before: ``old_*``), ``AimPoint`` where the
    beam axis now meets its room (when it meets nothing: as far as before)."""
    import FreeCAD
    from invrad_wb.core.model.aiming import tilt_pan
    m = mount_normal(obj, old_placement, old_tilt, old_pan)
    aim, _ = light_axes(obj.Placement)
    tilt, pan = tilt_pan(aim, m)
    turned = not (_same_float(tilt, obj.Tilt) and (tilt <= 1e-6 or _same_float(pan, obj.Pan)))
    throw = DEFAULT_THROW_MM
    if old_aim is not None and old_placement is not None:
        throw = max((old_aim - old_placement.Base).Length, MIN_THROW_MM * 2)
    hit = beam_hit_mm(room_shape(obj), FreeCAD.Vector(obj.Placement.Base), aim, throw)
    _set(obj, "Tilt", tilt, _same_float)
    if tilt > 1e-6:                    # an untilted spot keeps its pan
        _set(obj, "Pan", pan, _same_float)
    _set(obj, "AimPoint", hit, _same_vec)
    if "LightDirection" in obj.PropertiesList:
        _set(obj, "LightDirection", FreeCAD.Vector(*(float(x) for x in aim)), _same_vec)
    if turned:
        _write_ifc_aim(obj)
    from invrad_wb.app.fixturebody import draw_beam_axis
    draw_beam_axis(obj)                # its new length (GUI only)


def follow_aim(obj, old_tilt=None, old_pan=None):
    """An aimed fixture whose ``Tilt`` or ``Pan`` was edited: its placement turned about
    its base to that aim (C0 carried by the tilt), then :func:`follow_placement`."""
    import FreeCAD
    from invrad_wb.app.fixturebody import fixture_rotation
    from invrad_wb.core.model.aiming import aim_from_tilt_pan, aimed_c0
    old = FreeCAD.Placement(obj.Placement)
    m = mount_normal(obj, old, old_tilt, old_pan)
    aim = aim_from_tilt_pan(m, float(obj.Tilt), float(obj.Pan))
    rot = fixture_rotation(aim, aimed_c0(m, aim))
    new = FreeCAD.Placement(old.Base, rot)
    if not same_placement(old, new, 1e-12):
        obj.Placement = new
    tilt, pan = float(obj.Tilt), float(obj.Pan)
    follow_placement(obj, old, old_tilt, old_pan, FreeCAD.Vector(obj.AimPoint))
    # the user's own figures stand (tilt_pan's round-off, a pan at zero tilt)
    _set(obj, "Tilt", tilt, _same_float)
    _set(obj, "Pan", pan, _same_float)
    # follow_placement saw the edited Tilt/Pan already in place (nothing "turned" for it):
    # the IFC's set gets the user's figures here
    _write_ifc_aim(obj)


def _write_ifc_aim(obj):
    """A NativeIFC fixture's tilt and pan into its ``InvRad_Luminaire`` set (its placement
    NativeIFC writes itself), so that the saved file says the same."""
    from invrad_wb.app import ifcdata, nativeifc
    if not nativeifc.is_native(obj):
        return
    ent = nativeifc.entity(obj)
    if ent is None:
        return
    from invrad_wb.core.model.luminaires import Luminaire
    import numpy as np
    aim, _ = light_axes(obj.Placement)
    lum = Luminaire(np.zeros(3), aim, 1.0, extra={"tilt_deg": float(obj.Tilt),
                                                   "pan_deg": float(obj.Pan)})
    try:
        ifcdata.write_aim(nativeifc.ifcfile(obj), ent, lum)
    except Exception as exc:           # never break the user's move
        import FreeCAD
        FreeCAD.Console.PrintWarning(f"invrad: aim of {obj.Label} not written to the IFC"
                                     f" file: {exc}\n")


# --------------------------------------------------------------------------- NativeIFC
def complete_native_fixture(obj):
    """Give a NativeIFC IfcLightFixture object that invrad aimed its ``Tilt``, ``Pan``,
    ``AimPoint`` (read from its entity, :func:`.nativeifc.fixture_luminaire`) and beam
    axis; False when it is not one or has them already."""
    from invrad_wb.app import fixturebody, nativeifc
    if not nativeifc.is_native_fixture(obj) or fixturebody.is_aimed_fixture(obj):
        return False
    try:
        lum = nativeifc.fixture_luminaire(obj)
    except Exception:          # not invrad's (LuminaireError: no flux), no entity
        return False
    if fixturebody.aimed_tilt(lum) is None:
        return False
    nativeifc.show_aim(obj, nativeifc.fixture_room(obj), lum)
    return True


def aimed_fixture_entities(ifc):
    """The IfcLightFixture entities of ``ifc`` that invrad aimed (its property set with a
    ``Tilt``)."""
    import ifcopenshell.util.element as E
    from invrad_wb.app import settings as S
    out = []
    for ent in ifc.by_type("IfcLightFixture"):
        pset = E.get_pset(ent, S.IFC_LUMINAIRE_PSET)
        if pset and pset.get("Tilt") is not None:
            out.append(ent)
    return out


def expand_aimed_fixtures(doc, project):
    """Make objects for the aimed fixtures of a NativeIFC ``project`` (an object, or the
    document in locked mode) that have none, in their space's object, as NativeIFC's own
    expansion of the space would (``ifc_tools.create_object``, the space's ``addObject``),
    and complete them (:func:`complete_native_fixture`). Fixtures whose space has no object
    (a file opened with only its project) stay for NativeIFC's expansion. The new objects."""
    from nativeifc import ifc_tools
    from invrad_wb.app import nativeifc
    ifc = nativeifc.ifcfile(project)
    if ifc is None:
        return []
    ents = aimed_fixture_entities(ifc)
    if not ents:
        return []
    import ifcopenshell.util.element as E
    by_step = {}
    for o in doc.Objects:
        if nativeifc.is_native(o):
            by_step.setdefault(o.StepId, []).append(o)
    out = []
    for ent in ents:
        if ent.id() in by_step:
            continue
        cont = E.get_container(ent)
        spaces = [o for o in by_step.get(cont.id(), ()) if nativeifc.ifcfile(o) is ifc] \
            if cont is not None else []
        if not spaces:
            continue
        space = spaces[0]
        obj = ifc_tools.create_object(ent, doc, ifc, getattr(space, "ShapeMode", "Coin"))
        space.Proxy.addObject(space, obj)
        by_step[ent.id()] = [obj]
        out.append(obj)
    return out


# --------------------------------------------------------------------------- observer
class _Observer:
    """The document observer (one per FreeCAD session, :func:`install`)."""

    def __init__(self):
        self.created = {}      # doc name -> names of objects made since its last recompute
        self.projects = set()  # (doc name, project name or "") already expanded
        self.before = {}       # (doc name, obj name) -> state before a watched change
        self.busy = set()      # (doc name, obj name) being updated here

    # ---- lazily made NativeIFC objects
    def slotCreatedObject(self, obj):
        try:
            if obj.TypeId.endswith("FeaturePython"):
                self.created.setdefault(obj.Document.Name, []).append(obj.Name)
        except Exception:
            pass

    def slotDeletedDocument(self, doc):
        self.created.pop(doc.Name, None)
        self.projects = {p for p in self.projects if p[0] != doc.Name}

    def slotRecomputedDocument(self, doc):
        names = self.created.pop(doc.Name, None)
        if not names:
            return
        try:
            complete_created(doc, names, self.projects)
        except Exception as exc:       # never break opening or expanding a document
            import FreeCAD
            FreeCAD.Console.PrintWarning(f"invrad: aimed fixtures of {doc.Label} not"
                                         f" completed: {exc}\n")

    # ---- the aim follows the placement, the placement the aim
    def slotBeforeChangeObject(self, obj, prop):
        if prop not in WATCHED:
            return
        key = _key(obj)
        if key is None or key in self.busy or not _live_aimed(obj):
            return
        import FreeCAD
        self.before[key] = (FreeCAD.Placement(obj.Placement), float(obj.Tilt),
                            float(obj.Pan), FreeCAD.Vector(obj.AimPoint))

    def slotChangedObject(self, obj, prop):
        if prop not in WATCHED:
            return
        key = _key(obj)
        if key is None or key in self.busy:
            return
        old = self.before.pop(key, None)
        if old is None or not _live_aimed(obj):
            if prop != "Placement" and _undone_native(obj):
                _write_ifc_aim(obj)    # the IFC's set as the undone (or redone) document's
            return
        pl, tilt, pan, aim = old
        self.busy.add(key)
        try:
            if prop == "Placement":
                if not same_placement(obj.Placement, pl):
                    follow_placement(obj, pl, tilt, pan, aim)
            elif not _same_float(getattr(obj, prop), tilt if prop == "Tilt" else pan):
                follow_aim(obj, tilt, pan)
        except Exception as exc:       # never break the user's edit
            import FreeCAD
            FreeCAD.Console.PrintWarning(f"invrad: aim of {obj.Label} not updated: {exc}\n")
        finally:
            self.busy.discard(key)


def _key(obj):
    try:
        return obj.Document.Name, obj.Name
    except Exception:
        return None


def _undone_native(obj):
    """A NativeIFC aimed fixture whose document undoes or redoes (NativeIFC writes its
    placement back into the IFC itself; invrad's set, not)."""
    from invrad_wb.app import nativeifc
    from invrad_wb.app.fixturebody import is_aimed_fixture
    try:
        return bool(obj.Document.Transacting) and nativeifc.is_native(obj) and \
            is_aimed_fixture(obj)
    except Exception:
        return False


def _live_aimed(obj):
    """An aimed fixture changed by the user (not by undo, redo, reading a file or invrad
    writing its aim)."""
    from invrad_wb.app.fixturebody import WRITING_AIM, is_aimed_fixture
    try:
        doc = obj.Document
        # (a recompute's placement is the object's own geometry: NativeIFC sets it so)
        if doc.Transacting or doc.Restoring or doc.Recomputing or \
                (doc.Name, obj.Name) in WRITING_AIM:
            return False
    except Exception:
        return False
    return is_aimed_fixture(obj)


def complete_created(doc, names, done_projects=None):
    """After a recompute of ``doc`` that followed the making of the objects ``names``: a
    NativeIFC project among them (or the document, in locked mode) has its aimed fixtures
    made into objects, once (:func:`expand_aimed_fixtures`; ``done_projects`` remembers
    which); every new NativeIFC aimed fixture gets its aim (:func:`complete_native_fixture`).
    The number of fixtures completed."""
    from invrad_wb.app import nativeifc
    objs = [o for o in (doc.getObject(n) for n in names) if o is not None]
    native = [o for o in objs if nativeifc.is_native(o)]
    if not native and not any("IfcFilePath" in o.PropertiesList for o in objs):
        return 0
    done = set() if done_projects is None else done_projects
    projects = [o for o in objs if "IfcFilePath" in o.PropertiesList]
    if "IfcFilePath" in doc.PropertiesList and native:
        projects.append(doc)
    new = []
    for proj in projects:
        key = (doc.Name, "" if proj is doc else proj.Name)
        if key in done:
            continue
        done.add(key)
        new += expand_aimed_fixtures(doc, proj)
    for obj in new:        # their geometry and placement first (the recompute has been)
        obj.recompute()
    n = 0
    for obj in native + new:
        if complete_native_fixture(obj):
            n += 1
    return n


def install():
    """Install the observer once per FreeCAD session; the observer."""
    import FreeCAD
    obs = getattr(FreeCAD, "_invrad_aim_observer", None)
    if obs is None:
        obs = FreeCAD._invrad_aim_observer = _Observer()
        FreeCAD.addDocumentObserver(obs)
    return obs
