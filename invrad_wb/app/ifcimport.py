"""FreeCAD import hooks (``open``/``insert``) for IFC rooms, registered by ``Init.py``.

They only wrap :func:`invrad_wb.app.ifcrooms.import_ifc` (with building elements, since a
user opening a file wants to see the building).
"""


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
