"""The beam axes of aimed fixtures, drawn again where FreeCAD forgets them.

An aimed fixture's beam axis (:func:`invrad_wb.app.fixturebody.draw_beam_axis`) is a Coin
node under its view object's root: FreeCAD neither saves it nor keeps it when it makes
the view object again. So a document observer, installed by ``InitGui.py`` when FreeCAD
starts (a document may be opened before the workbench is ever activated), draws the axes
of every aimed fixture (its ``Tilt``, ``Pan`` and ``AimPoint`` properties, classic or
NativeIFC) that lacks one (``InitGui.py``'s observer calls :func:`redraw_later`):

* once a document has been opened (FreeCAD 0.20 tells its observers that a document is
  created, not that it has been read: the drawing waits for the event loop, when the
  document and its view objects are complete);
* after undo and redo (an undone removal makes the fixture's view object anew).

On the first document it also installs :mod:`invrad_wb.app.aimsync`'s observer: NativeIFC
makes a fixture's object only when its space is expanded (a document opened from an
``.ifc``), and that observer gives it its aim properties and beam axis then; and a
moved fixture's aim point follows it.

This module imports nothing at its top (the observer imports it for every document); the
drawing code is imported when a document holds aimed fixtures.
"""
#: Properties every aimed fixture has (``fixturebody.AIM_PROPERTIES``, repeated here so
#: that looking for them imports nothing).
AIM_PROPERTIES = ("Tilt", "Pan", "AimPoint")


def aimed_fixtures(doc):
    """The document's objects with an aimed fixture's properties."""
    out = []
    for obj in getattr(doc, "Objects", ()):
        try:
            props = obj.PropertiesList
        except Exception:          # an object being deleted
            continue
        if all(p in props for p in AIM_PROPERTIES):
            out.append(obj)
    return out


def redraw(doc):
    """Draw the beam axis of each aimed fixture of ``doc`` (again: it may show none, or one
    to an aim point that undo changed back); the number drawn (0 without the GUI)."""
    import FreeCAD
    objs = aimed_fixtures(doc)
    if not objs or not FreeCAD.GuiUp:
        return 0
    from invrad_wb.app import dependencies
    dependencies.add_site_packages()       # numpy where the workbench was not loaded yet
    from invrad_wb.app import fixturebody
    n = 0
    for obj in objs:
        # every one, not only those without: an undone move changed its aim point back
        if fixturebody.draw_beam_axis(obj):
            n += 1
    return n


def redraw_later(doc):
    """:func:`redraw` once FreeCAD's event loop runs again (the document by name: it may
    be closed by then)."""
    import FreeCAD
    if not FreeCAD.GuiUp:
        return
    # the observer that completes NativeIFC fixtures made lazily (a file opened from its
    # .ifc) and keeps a moved fixture's aim (imports nothing at its top either)
    from invrad_wb.app import aimsync
    aimsync.install()
    name = doc.Name
    from PySide import QtCore

    def run():
        d = FreeCAD.listDocuments().get(name)
        if d is not None:
            try:
                redraw(d)
            except Exception as exc:       # never break opening a document
                FreeCAD.Console.PrintWarning(f"invrad: beam axes not drawn: {exc}\n")

    QtCore.QTimer.singleShot(0, run)
