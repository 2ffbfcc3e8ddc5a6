"""The NativeIFC document backend (FreeCAD 1.x BIM): rooms from IfcSpace, fixtures written
to the IFC. It imports nothing of app above it (rooms, fixtures and the IFC export call
it; :func:`.ifcimport.open_ifc` opens a file with it).

In a NativeIFC document (FreeCAD 1.0's BIM workbench, ``nativeifc``) the document's objects
are views of the entities of an ifcopenshell file held in memory by the project object
(``project.Proxy.ifcfile``); saving writes that file. Invrad works there the native way:

* **Rooms** are the IfcSpace objects (``IfcClass == "IfcSpace"``). Their closed solid is
  made from the IfcSpace's own geometry with ifcopenshell (world coordinates, sewn and
  cleaned as in the classic import: :mod:`.ifcdata`), whatever the object's ShapeMode
  (NativeIFC shows spaces without a Part shape by default). Their name is the IfcSpace's
  LongName ("Wohnen"), else its Name.
* **Requirements** are read from ``Pset_SpaceLightingRequirements`` (IFC4) or
  ``Pset_SpaceLightingDesign`` (IFC4.3) ``Illuminance`` into WorkPlane targets when the
  document is opened by :func:`.ifcimport.open_ifc`, and written back there after a run.
* **Luminaires** become ``IfcLightFixture`` entities made with ``ifcopenshell.api``:
  ``root.create_entity``, ``spatial.assign_container`` (in their IfcSpace),
  ``geometry.edit_object_placement`` (local -Z along the light direction), a swept-disk
  ``Body`` representation, and the property sets ``InvRad_Luminaire`` (flux, type,
  photometry file, emitter radius, score) and ``Pset_LightFixtureTypeCommon``. Each gets a
  NativeIFC object (``ifc_tools.create_object``) in its space's Group.

**Undo.** NativeIFC 1.0 keeps no undo history of its ifcopenshell file. One invrad run is
ONE undo step of the FreeCAD document and ONE ifcopenshell transaction
(``file.begin_transaction``/``end_transaction``, ifcopenshell's own undo system): a hidden
:class:`IfcSyncProxy` object's ``Revision`` counts invrad's IFC transactions and is changed
in the same FreeCAD transaction; when FreeCAD's undo/redo changes it back (or removes or
restores the object), a document observer replays ``ifcfile.undo()``/``redo()`` until the
file's state matches it. The fixture objects tell NativeIFC's own observer not to delete
their entities on undo (``Proxy.nodelete``): the file's undo does that.

**ifcopenshell version.** FreeCAD 1.0.0's nativeifc uses ``entity_instance.wrapped_data``,
which ifcopenshell 0.9 removed; :func:`check_available` names the install command.
"""
import contextlib
import os

from invrad_wb.errors import InvradError, LuminaireError, SceneError
from invrad_wb.app import ifcdata
from invrad_wb.app import settings as S
from invrad_wb.app.document import describe, transaction
from invrad_wb.app import fixturebody
from invrad_wb.app.fixturebody import check_luminaire
# the requirement sets live in ifcdata (the classic export writes them too)
from invrad_wb.app.ifcdata import (  # noqa: F401 - nativeifc.read_requirement etc. as before
    PSET_REQ_IFC4, PSET_REQ_IFC4X3, PSET_RESULT, read_requirement, requirement_pset_name,
    write_requirement)

SYNC_TYPE = "InvRadIfcSync"
IFC_CLASS_SPACE = "IfcSpace"
IFC_CLASS_FIXTURE = "IfcLightFixture"
IFC08_REQUIREMENT = "ifcopenshell>=0.8.1,<0.9"


# --------------------------------------------------------------------------- availability
def available():
    """True when FreeCAD's BIM workbench has NativeIFC (FreeCAD 1.0 or later)."""
    import importlib.util
    try:
        return importlib.util.find_spec("nativeifc") is not None
    except (ImportError, ValueError):
        return False


def check_available():
    """Raise InvradError (with the fix) when NativeIFC cannot work in this FreeCAD."""
    if not available():
        raise InvradError("NativeIFC documents need FreeCAD 1.0 or later (its BIM workbench"
                          " has nativeifc); this FreeCAD has none: import the IFC file the"
                          " classic way (File > Import, or invrad's IFC import)")
    try:
        import ifcopenshell
    except ImportError as exc:
        raise InvradError(f"NativeIFC needs ifcopenshell ({exc}); install it with: pip"
                          f" install '{IFC08_REQUIREMENT}'")
    if not hasattr(ifcopenshell.file(), "wrapped_data") and _nativeifc_uses_wrapped_data():
        raise InvradError(
            f"this FreeCAD's NativeIFC needs ifcopenshell 0.8 (ifcopenshell"
            f" {getattr(ifcopenshell, 'version', '?')} removed entity_instance.wrapped_data"
            f" that it uses); install it with: pip install '{IFC08_REQUIREMENT}'")


def _nativeifc_uses_wrapped_data():
    import importlib.util
    spec = importlib.util.find_spec("nativeifc.ifc_tools")
    try:
        with open(spec.origin, "r", encoding="utf-8") as fh:
            return ".wrapped_data" in fh.read()
    except (OSError, AttributeError, TypeError):
        return False


# --------------------------------------------------------------------------- objects
def is_native(obj):
    """True for an object of a NativeIFC document (it has a StepId and an IfcClass)."""
    try:
        props = obj.PropertiesList
    except Exception:
        return False
    return "StepId" in props and "IfcClass" in props


def is_native_space(obj):
    return is_native(obj) and getattr(obj, "IfcClass", "") == IFC_CLASS_SPACE


def is_native_fixture(obj, generated_only=False):
    """A NativeIFC IfcLightFixture object (made by invrad only with ``generated_only``)."""
    if not (is_native(obj) and getattr(obj, "IfcClass", "") == IFC_CLASS_FIXTURE):
        return False
    if not generated_only:
        return True
    ent = entity(obj)
    return ent is not None and ifcdata._is_invrad_entity(ent)


def ifcfile(obj):
    """The ifcopenshell file behind a NativeIFC object (or document)."""
    from nativeifc import ifc_tools
    return ifc_tools.get_ifcfile(obj)


def project(obj):
    """The NativeIFC project of an object: an IfcProject object, or the document itself
    in NativeIFC's single-document (locked) mode."""
    from nativeifc import ifc_tools
    return ifc_tools.get_project(obj)


def entity(obj):
    """The IFC entity of a NativeIFC object, or None."""
    from nativeifc import ifc_tools
    try:
        return ifc_tools.get_ifc_element(obj)
    except Exception:
        return None


def space_name(obj):
    """A NativeIFC space's room name: its IfcSpace LongName, else Name (the Label)."""
    long_name = getattr(obj, "LongName", "") or ""
    return long_name if long_name and long_name != "None" else obj.Label


def space_uid(obj):
    """A NativeIFC space's IFC GlobalId (or '')."""
    return str(getattr(obj, "GlobalId", "") or "")


def document_is_native(doc):
    """True when the document holds a NativeIFC project: a project object (with its
    ``IfcFilePath``), or the document itself in locked mode."""
    if "IfcFilePath" in getattr(doc, "PropertiesList", ()):
        return True
    return any(is_native(o) or "IfcFilePath" in o.PropertiesList for o in doc.Objects)


def native_spaces(doc):
    return [o for o in doc.Objects if is_native_space(o)]


# --------------------------------------------------------------------------- rooms
_SOLIDS = {}


def space_solid(obj):
    """The closed solid (global mm) of a NativeIFC space, made from its IfcSpace.

    Cached per file, entity and geometry (placement and representation ids).

    Raises
    ------
    SceneError
        No IFC entity, no geometry, or an open surface (naming the room).
    """
    ent = entity(obj)
    who = f"room {describe(obj)}"
    if ent is None:
        raise SceneError(f"{who}: its IfcSpace is not in the IFC file", obj.Label)
    f = ifcfile(obj)
    key = (id(f), ent.id(), getattr(ent.ObjectPlacement, "id", lambda: 0)(),
           getattr(ent.Representation, "id", lambda: 0)())
    if key in _SOLIDS:
        return _SOLIDS[key].copy()
    import ifcopenshell.geom
    try:
        shp = ifcopenshell.geom.create_shape(ifcdata.geometry_settings(), ent)
        raw = ifcdata.brep_to_shape(shp.geometry.brep_data)
    except Exception as exc:
        raise SceneError(f"{who} has no geometry in the IFC file ({exc})", obj.Label)
    solid, free = ifcdata.closed_solid(raw)
    if solid is None:
        raise SceneError(f"{who} is not closed: its IfcSpace is an open surface ({free}"
                         " free edges)", obj.Label)
    _SOLIDS[key] = solid
    return solid.copy()


def face_count(obj):
    """Number of faces of a NativeIFC space's solid (0 without geometry)."""
    try:
        return len(space_solid(obj).Faces)
    except SceneError:
        return 0


# --------------------------------------------------------------------------- the undo step
@contextlib.contextmanager
def ifc_step(doc, obj, name):
    """ONE undo step that changes the IFC file of ``obj``'s project: a FreeCAD transaction
    (joining the caller's) holding one ifcopenshell transaction, counted by the project's
    sync object (:class:`IfcSyncProxy`) so that FreeCAD's undo/redo replays the file's.
    Yields the ifcopenshell file; on an exception the file's transaction is discarded and
    the document's aborted."""
    ifc = ifcfile(obj)
    proj = project(obj)
    install_observer()
    with transaction(doc, name):
        sync = sync_object(doc, proj)
        ifc.begin_transaction()
        try:
            yield ifc
        except BaseException:
            ifc.discard_transaction()
            raise
        ifc.end_transaction()
        sync.Proxy.commit(sync)


# --------------------------------------------------------------------------- fixtures
def fixture_luminaire(obj):
    """The Luminaire of a NativeIFC light fixture, read from its IFC entity (placement
    and ``InvRad_Luminaire``); LuminaireError when it has no flux."""
    import ifcopenshell.util.unit as U
    ent = entity(obj)
    lum = None
    if ent is not None:
        ifc = ifcfile(obj)
        lum = ifcdata.invrad_fixture_data(ent, U.calculate_unit_scale(ifc), ifc)
    if lum is None:
        raise LuminaireError(f"light fixture {describe(obj)} has no luminous flux"
                             f" ({S.IFC_LUMINAIRE_PSET}.LuminousFlux) in the IFC file")
    return lum


def fixture_room(obj):
    """The NativeIFC space whose Group holds a fixture (or None)."""
    for parent in obj.InList:
        if is_native_space(parent) and obj in parent.Group:
            return parent
    return None


def room_fixtures(space, generated_only=True):
    return [o for o in space.Group if is_native_fixture(o, generated_only)]


def _new_fixture_entity(ifc, space_ent, lum, label, ctx, unit_scale):
    import ifcopenshell.api.geometry as G
    import ifcopenshell.api.root as RT
    import ifcopenshell.api.spatial as SP
    ent = RT.create_entity(ifc, ifc_class=IFC_CLASS_FIXTURE, name=label,
                           predefined_type="POINTSOURCE")
    kind = lum.extra.get("type")
    ent.Description = (f"invrad luminaire, {kind}, {lum.flux_lm:.0f} lm" if kind
                       else f"invrad luminaire, {lum.flux_lm:.0f} lm")
    SP.assign_container(ifc, products=[ent], relating_structure=space_ent)
    G.edit_object_placement(ifc, product=ent, matrix=ifcdata.fixture_matrix(lum), is_si=True)
    ifcdata.add_body(ifc, ent, lum, ctx, unit_scale)
    ifcdata.luminaire_psets(ifc, ent, lum)
    return ent


#: The group of an aimed NativeIFC fixture's Tilt, Pan and AimPoint: NativeIFC writes a
#: property of any group but its own ("Base", "IFC", "Geometry") into a property set
#: of that name, and these only show what the IFC holds (placement, ``InvRad_Luminaire``).
AIM_GROUP = "Base"


def show_aim(obj, space, lum):
    """An aimed fixture's tilt, pan and aim point as (read-only) properties of its
    NativeIFC object, and its beam axis in the 3D view, as a classic fixture's; the IFC
    keeps them in its placement and property set (:func:`ifcdata.write_aim`). ``space``:
    its NativeIFC space (None: the axis ends 2 m out)."""
    tilt = fixturebody.aimed_tilt(lum)
    if tilt is None:
        return
    try:
        shape = space_solid(space) if space is not None else None
    except SceneError:         # the axis then ends 2 m out
        shape = None
    fixturebody.add_aim_properties(obj, lum, tilt, fixturebody.aim_point_mm(shape, lum),
                                   group=AIM_GROUP, readonly=True)
    fixturebody.draw_beam_axis(obj)


def insert_fixtures(doc, per_room, label, replace=True, name="Insert luminaires",
                    requirements=None):
    """Luminaires -> IfcLightFixture entities in their IfcSpace, as ONE undo step.

    Parameters
    ----------
    doc : FreeCAD document (NativeIFC)
    per_room : list of (NativeIFC space object, list of Luminaire)
    label : callable ``(space, i, luminaire) -> str``, each fixture's name
    replace : bool
        First remove the fixtures invrad put into these rooms before.
    requirements : dict, optional
        ``{space object Name: (lux, achieved dict or None)}`` written to the spaces'
        lighting set (:func:`write_requirement`) in the same step.

    Returns
    -------
    list of the new NativeIFC fixture objects.
    """
    from nativeifc import ifc_tools
    import ifcopenshell.api.root as RT
    import ifcopenshell.util.unit as U
    if not per_room:
        return []
    for space, lums in per_room:
        if not is_native_space(space):
            raise SceneError(f"{describe(space)} is not a NativeIFC room (IfcSpace)",
                             doc.Label)
        for i, lum in enumerate(lums):
            check_luminaire(lum, f"luminaire {i + 1} of room {describe(space)}")
    files = {id(ifcfile(sp)) for sp, _ in per_room}
    if len(files) != 1:
        raise SceneError("the rooms belong to more than one IFC project; run them one"
                         " project at a time", doc.Label)
    proj = project(per_room[0][0])
    out = []
    with ifc_step(doc, per_room[0][0], name) as ifc:
        unit_scale = U.calculate_unit_scale(ifc)
        ctx = ifcdata.body_context(ifc)
        for space, lums in per_room:
            if replace:
                for old in room_fixtures(space):
                    ent = entity(old)
                    if ent is not None:
                        RT.remove_product(ifc, product=ent)
                    doc.removeObject(old.Name)
            sp_ent = entity(space)
            if sp_ent is None:
                raise SceneError(f"room {describe(space)}: its IfcSpace is not in the"
                                 " IFC file", doc.Label)
            for i, lum in enumerate(lums):
                ent = _new_fixture_entity(ifc, sp_ent, lum, label(space, i, lum), ctx,
                                          unit_scale)
                # a Part shape (a small disk), shown whatever the spaces' mode: a new
                # object in NativeIFC's "Coin" mode was not drawn (FreeCAD 1.0)
                obj = ifc_tools.create_object(ent, doc, ifc, "Shape")
                obj.Proxy.nodelete = True      # the file's undo removes the entity
                obj.Proxy.cached = False       # a new entity: not in the file's cache
                obj.touch()
                space.Proxy.addObject(space, obj)
                show_aim(obj, space, lum)
                out.append(obj)
        _write_requirements(ifc, [sp for sp, _ in per_room], requirements)
        if hasattr(proj, "Modified"):
            proj.Modified = True
    return out


def _write_requirements(ifc, spaces, requirements):
    for sp in spaces:
        req = (requirements or {}).get(sp.Name)
        if req is not None:
            write_requirement(ifc, entity(sp), req[0], req[1])


def write_requirements(doc, requirements, name="Lighting requirements to IFC"):
    """Write ``{space object Name: (lux, achieved or None)}`` to the spaces' IfcSpace,
    as one undo step (an ifcopenshell transaction)."""
    spaces = [doc.getObject(n) for n in requirements]
    spaces = [s for s in spaces if s is not None and is_native_space(s)]
    if not spaces:
        return 0
    with ifc_step(doc, spaces[0], name) as ifc:
        _write_requirements(ifc, spaces, requirements)
    return len(spaces)


def save(proj, path=None):
    """Write the project's IFC file (to ``path``, else its own file), atomically."""
    import tempfile
    from nativeifc import ifc_tools
    path = path or proj.IfcFilePath
    folder = os.path.dirname(os.path.abspath(path)) or "."
    fd, tmp = tempfile.mkstemp(suffix=".ifc", dir=folder)
    os.close(fd)
    try:
        ifc_tools.get_ifcfile(proj).write(tmp)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)
    if path == proj.IfcFilePath and hasattr(proj, "Modified"):
        proj.Modified = False
    return path


# --------------------------------------------------------------------------- undo sync
class IfcSyncProxy:
    """Proxy of the hidden object whose ``Revision`` counts invrad's IFC transactions.

    ``applied`` (in memory) is how many of them the ifcopenshell file holds now; the
    observer makes the file follow ``Revision`` after FreeCAD's undo and redo.
    """

    Type = SYNC_TYPE

    def __init__(self, obj):
        obj.Proxy = self
        self.applied = 0
        obj.addProperty("App::PropertyInteger", "Revision", "InvRad",
                        "invrad's IFC changes in the project's file (undo follows it)")
        obj.addProperty("App::PropertyLinkHidden", "Project", "InvRad",
                        "The NativeIFC project (empty: the document is the project)")
        obj.setPropertyStatus("Revision", "ReadOnly")

    def commit(self, obj):
        """One more invrad transaction is in the file: count it (call inside the
        FreeCAD transaction that made it)."""
        self.applied = getattr(self, "applied", obj.Revision) + 1
        obj.Revision = self.applied

    def execute(self, obj):
        pass

    def onDocumentRestored(self, obj):
        self.applied = obj.Revision      # a re-opened file has no ifcopenshell history
        install_observer()

    def dumps(self):
        return None

    def loads(self, state):
        return None

    def __getstate__(self):
        return None

    def __setstate__(self, state):
        return None


def sync_object(doc, proj):
    """The document's sync object for ``proj`` (made on first use, in the caller's
    transaction: undoing that removes it, which the observer handles)."""
    import FreeCAD
    is_obj = isinstance(proj, FreeCAD.DocumentObject)    # else the document (locked mode)
    for o in doc.Objects:
        if getattr(getattr(o, "Proxy", None), "Type", None) == SYNC_TYPE:
            if o.Project == (proj if is_obj else None):
                return o
    obj = doc.addObject("App::FeaturePython", "InvRadIfcSync")
    IfcSyncProxy(obj)
    obj.Label = "InvRad IFC changes"
    if is_obj:
        obj.Project = proj
    if obj.ViewObject is not None:
        obj.ViewObject.ShowInTree = False
    return obj


def _sync_file(obj):
    proj = obj.Project if obj.Project is not None else obj.Document
    try:
        return ifcfile(proj)
    except Exception:
        return None


def reconcile(obj, revision=None):
    """Make the IFC file hold ``revision`` (default ``obj.Revision``) of invrad's
    transactions: ``ifcfile.undo()``/``redo()`` as many times as needed."""
    proxy = getattr(obj, "Proxy", None)
    if not isinstance(proxy, IfcSyncProxy):
        return
    target = obj.Revision if revision is None else revision
    applied = getattr(proxy, "applied", None)
    if applied is None:
        proxy.applied = target
        return
    if applied == target:
        return
    ifc = _sync_file(obj)
    if ifc is None:
        return
    while proxy.applied > target and ifc.history:
        ifc.undo()
        proxy.applied -= 1
    while proxy.applied < target and ifc.future:
        ifc.redo()
        proxy.applied += 1


class _Observer:
    """Replays ifcopenshell undo/redo when FreeCAD's undo/redo moves a sync object."""

    def slotChangedObject(self, obj, prop):
        if prop == "Revision" and _is_sync(obj):
            reconcile(obj)

    def slotDeletedObject(self, obj):
        if _is_sync(obj):
            reconcile(obj, 0)              # undone the step that made it
        elif is_native(obj) and getattr(getattr(obj, "Proxy", None), "nodelete", False) \
                and not getattr(obj.Document, "Transacting", True):
            # deleted by the user (not by undo): remove its entity, as NativeIFC would
            ent = entity(obj)
            if ent is not None:
                import ifcopenshell.api.root as RT
                RT.remove_product(ifcfile(obj), product=ent)

    def slotCreatedObject(self, obj):
        if _is_sync(obj):
            reconcile(obj)                 # redone the step that made it

    def slotUndoDocument(self, doc):
        self._all(doc)

    def slotRedoDocument(self, doc):
        self._all(doc)                     # a re-created sync object has its Revision now

    @staticmethod
    def _all(doc):
        for o in doc.Objects:
            if _is_sync(o):
                reconcile(o)


def _is_sync(obj):
    try:
        return getattr(getattr(obj, "Proxy", None), "Type", None) == SYNC_TYPE
    except Exception:
        return False


def install_observer():
    """Install the undo observer once per FreeCAD session."""
    import FreeCAD
    if getattr(FreeCAD, "_invrad_ifc_observer", None) is None:
        FreeCAD._invrad_ifc_observer = _Observer()
        FreeCAD.addDocumentObserver(FreeCAD._invrad_ifc_observer)
