"""Opening IFC files: FreeCAD's import hooks (``open``/``insert``, registered by
``Init.py``) for the classic import, and :func:`open_ifc` for a NativeIFC document.

The hooks only wrap :func:`invrad_wb.app.ifcrooms.import_ifc` (with building elements,
since a user opening a file wants to see the building). :func:`open_ifc` opens the file
with FreeCAD 1.x's NativeIFC (the backend in :mod:`invrad_wb.app.nativeifc`) and turns the
spaces' lighting requirements into WorkPlane targets.
"""
import os

from invrad_wb.errors import SceneError
from invrad_wb.app import backend
from invrad_wb.app.document import activate, transaction
from invrad_wb.app.ifcdata import read_requirement


def open(filename):          # noqa: A001  (FreeCAD's import-module interface)
    """File > Open: a new document with the file's rooms and elements."""
    from invrad_wb.app.ifcrooms import import_ifc
    return import_ifc(filename, elements=True).doc


def insert(filename, docname):
    """File > Import: the file's rooms and elements into the document ``docname``."""
    import FreeCAD
    from invrad_wb.app.ifcrooms import import_ifc
    try:
        doc = FreeCAD.getDocument(docname)
    except NameError:
        doc = FreeCAD.newDocument(docname)
    return import_ifc(filename, doc=doc, elements=True).doc


def open_ifc(path, doc=None, shapemode=None, requirements=True, singledoc=False):
    """Open an IFC file as a NativeIFC document, with its building structure and spaces.

    FreeCAD 1.0's own importer (``nativeifc.ifc_import.insert``) is used, headless-safe
    (no dialog): strategy "building structure" (site, building, storeys, spaces),
    a project object in ``doc``. Rooms with a lighting requirement get a WorkPlane target
    (one undo step).

    Parameters
    ----------
    path : str
    doc : FreeCAD document, optional (a new one named after the file)
    shapemode : int, optional
        NativeIFC shape mode: 0 full shape, 1 coin only, 2 none; None: the user's
        preference (BIM > NativeIFC).
    requirements : bool
        Turn lighting requirements into WorkPlane targets.
    singledoc : bool
        NativeIFC's "locked" mode (what *File > Open* does): the document itself is the
        project, no project object.

    Returns
    -------
    (doc, project): the project object, or the document in locked mode
    """
    import FreeCAD
    from invrad_wb.app.nativeifc import check_available, entity, native_spaces
    from invrad_wb.app.targets import set_work_plane
    check_available()
    path = os.path.abspath(path)
    if not os.path.isfile(path):
        raise SceneError("file does not exist", path)
    from nativeifc import ifc_import
    if doc is None:
        doc = FreeCAD.newDocument()
        doc.Label = os.path.splitext(os.path.basename(path))[0]
    activate(doc)
    # invrad's aimed fixtures made into objects with their aim when NativeIFC's import ends
    from invrad_wb.app import aimsync
    aimsync.install()
    before = set(o.Name for o in doc.Objects)
    try:
        ifc_import.insert(path, doc.Name, strategy=1, shapemode=shapemode, switchwb=False,
                          silent=True, singledoc=singledoc)
    except Exception as exc:
        raise SceneError(f"NativeIFC could not open it: {exc}", path)
    projs = [o for o in doc.Objects if o.Name not in before and hasattr(o, "IfcFilePath")]
    if singledoc and hasattr(doc, "IfcFilePath"):
        projs = [doc]
    if not projs:
        raise SceneError("NativeIFC made no project object", path)
    proj = projs[0]
    backend.forget(doc)                    # the document is a NativeIFC one now
    spaces = native_spaces(doc)
    if not spaces:
        raise SceneError("the file has no rooms (IfcSpace)", path)
    if requirements:
        with transaction(doc, "Lighting requirements from IFC"):
            for sp in spaces:
                lux = read_requirement(entity(sp))
                if lux is not None:
                    set_work_plane(sp, lux)
    return doc, proj
