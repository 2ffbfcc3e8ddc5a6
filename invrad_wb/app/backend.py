"""One document backend per document: what invrad needs of a FreeCAD document, behind one
interface, whichever way the document holds its BIM model.

* :class:`ClassicBackend` (:mod:`.classic`): Arch/BIM objects, FreeCAD 0.20 and 1.x. Rooms
  are Arch Spaces, fixtures Arch Equipment, requirements the Spaces' ``IfcProperties``; an
  edit is one FreeCAD transaction.
* :class:`NativeIfcBackend` (:mod:`.nativeifc`): FreeCAD 1.x NativeIFC. Rooms are IfcSpace
  objects, fixtures IfcLightFixture entities, requirements the IfcSpaces' lighting sets; an
  edit is one FreeCAD transaction holding one ifcopenshell transaction
  (:func:`.nativeifc.ifc_step`), which FreeCAD's undo replays.

:func:`of` chooses once per document: NativeIFC when the document holds a NativeIFC
project (a project object, or the document itself in locked mode), else classic. The
choice is kept until a NativeIFC project appears in or leaves the document (a document
observer forgets it then). A document is one or the other: in a NativeIFC document the
rooms are its IfcSpaces. :mod:`.rooms`, :mod:`.fixtures`, the IFC export and the pipeline
ask the backend and never branch on an object's kind.
"""
from invrad_wb.app import classic, nativeifc


class DocumentBackend:
    """The interface. Rooms: :meth:`is_room`, :meth:`rooms`, :meth:`room_name`,
    :meth:`room_uid`, :meth:`room_solid`, :meth:`face_count`. Fixtures in and out:
    :meth:`is_fixture`, :meth:`room_fixtures`, :meth:`fixture_room`,
    :meth:`fixture_luminaire`, :meth:`insert_fixtures`. Requirements:
    :meth:`write_requirements`. Each edit is one undo step of the document."""

    #: shown to the user ("classic (Arch)", "NativeIFC")
    name = ""
    native = False

    def is_room(self, obj):
        """True for a room of this backend."""
        raise NotImplementedError

    def rooms(self, doc):
        """The document's rooms, in document order."""
        return [o for o in doc.Objects if self.is_room(o)]

    def room_name(self, space):
        """The room's name shown to the user."""
        raise NotImplementedError

    def room_uid(self, space):
        """The room's IFC GlobalId, or ''."""
        raise NotImplementedError

    def room_solid(self, space):
        """The room's closed solid in global mm, checked (SceneError naming the room)."""
        raise NotImplementedError

    def face_count(self, space):
        """The number of faces of the room's solid (0 without geometry)."""
        raise NotImplementedError

    def is_fixture(self, obj, generated_only=False):
        """True for a light fixture (made by invrad only, with ``generated_only``)."""
        raise NotImplementedError

    def room_fixtures(self, space, generated_only=True):
        """The light fixtures in a room."""
        raise NotImplementedError

    def fixture_room(self, obj):
        """The room of a fixture, or None."""
        raise NotImplementedError

    def fixture_luminaire(self, obj):
        """The Luminaire a fixture stands for (LuminaireError without a flux)."""
        raise NotImplementedError

    def insert_fixtures(self, doc, per_room, label, replace=True, name="Insert luminaires",
                        requirements=None):
        """``[(room, [Luminaire])]`` -> light fixtures in their rooms, with
        ``requirements`` (``{room Name: (lux, achieved or None)}``), as ONE undo step; the
        new objects. ``label(room, i, luminaire)`` names each fixture; ``replace`` first
        removes invrad's earlier fixtures of these rooms."""
        raise NotImplementedError

    def write_requirements(self, doc, requirements, name="Lighting requirements"):
        """``{room Name: (lux, achieved or None)}`` into the rooms' IFC data, as one undo
        step; the number of rooms written."""
        raise NotImplementedError


class ClassicBackend(DocumentBackend):
    name = "classic (Arch)"
    is_room = staticmethod(classic.is_space)
    room_name = staticmethod(classic.room_name)
    room_uid = staticmethod(classic.space_uid)
    room_solid = staticmethod(classic.space_solid)
    face_count = staticmethod(classic.face_count)
    is_fixture = staticmethod(classic.is_fixture)
    room_fixtures = staticmethod(classic.room_fixtures)
    fixture_room = staticmethod(classic.fixture_room)
    fixture_luminaire = staticmethod(classic.fixture_luminaire)
    insert_fixtures = staticmethod(classic.insert_fixtures)
    write_requirements = staticmethod(classic.write_requirements)


class NativeIfcBackend(DocumentBackend):
    name = "NativeIFC"
    native = True
    is_room = staticmethod(nativeifc.is_native_space)
    room_name = staticmethod(nativeifc.space_name)
    room_uid = staticmethod(nativeifc.space_uid)
    room_solid = staticmethod(nativeifc.space_solid)
    face_count = staticmethod(nativeifc.face_count)
    is_fixture = staticmethod(nativeifc.is_native_fixture)
    room_fixtures = staticmethod(nativeifc.room_fixtures)
    fixture_room = staticmethod(nativeifc.fixture_room)
    fixture_luminaire = staticmethod(nativeifc.fixture_luminaire)
    insert_fixtures = staticmethod(nativeifc.insert_fixtures)
    write_requirements = staticmethod(nativeifc.write_requirements)


CLASSIC = ClassicBackend()
NATIVE_IFC = NativeIfcBackend()

#: document Name -> (the document, its backend); the document itself is kept to tell a
#: closed document from a later one of the same name
_CHOSEN = {}
#: the property of a NativeIFC project (an object's, or a locked document's): its coming or
#: going may turn a document into a NativeIFC one or back
_NATIVE_PROPS = ("IfcFilePath",)


def of(doc_or_obj):
    """The backend of a document (or of the document an object is in), chosen once per
    document; an object outside any document gets the classic one."""
    doc = doc_or_obj if hasattr(doc_or_obj, "Objects") else getattr(doc_or_obj, "Document",
                                                                     None)
    if doc is None:
        return CLASSIC
    hit = _CHOSEN.get(doc.Name)
    if hit is not None and hit[0] is doc:
        return hit[1]
    chosen = NATIVE_IFC if nativeifc.document_is_native(doc) else CLASSIC
    _install_observer()
    _CHOSEN[doc.Name] = (doc, chosen)
    return chosen


def forget(doc):
    """Choose again at the next :func:`of` (a NativeIFC project came or went)."""
    _CHOSEN.pop(getattr(doc, "Name", None), None)


class _Observer:
    """Forgets a document's choice when a NativeIFC project appears in it or leaves it,
    and when the document closes."""

    def slotChangedObject(self, obj, prop):
        if prop in _NATIVE_PROPS:
            forget(obj.Document)

    def slotDeletedObject(self, obj):
        try:
            if any(p in obj.PropertiesList for p in _NATIVE_PROPS):
                forget(obj.Document)
        except Exception:
            pass

    def slotChangedDocument(self, doc, prop):
        if prop in _NATIVE_PROPS:
            forget(doc)

    def slotDeletedDocument(self, doc):
        forget(doc)


def _install_observer():
    try:
        import FreeCAD
    except ImportError:
        return
    if getattr(FreeCAD, "_invrad_backend_observer", None) is None \
            and hasattr(FreeCAD, "addDocumentObserver"):
        FreeCAD._invrad_backend_observer = _Observer()
        FreeCAD.addDocumentObserver(FreeCAD._invrad_backend_observer)
