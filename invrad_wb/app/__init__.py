"""The FreeCAD document side of invrad: rooms and targets in, luminaires out.

This package is headless-safe: it imports FreeCAD (never FreeCADGui) and only inside the
modules that need it, so ``import invrad_wb.app`` works without FreeCAD. The GUI commands
(``invrad_wb.gui``) are thin calls into it:

* :mod:`.rooms`     Arch Spaces -> room solids -> sampling meshes (metres, inward normals)
* :mod:`.targets`   lighting targets stored in the document (FeaturePython objects)
* :mod:`.ifcrooms`  IFC import with ifcopenshell (IfcSpace -> Arch Space)
* :mod:`.ifcimport` FreeCAD open/insert hooks for it (registered by Init.py)
* :mod:`.fixtures`  found luminaires -> Arch Equipment "Light Fixture" in their Space
* :mod:`.ifcexport` IFC export (FreeCAD's exporter or merged into the source IFC)
* :mod:`.pipeline`  a whole building, room by room: targets -> locate -> fixtures -> report
* :mod:`.document`  undoable transactions, active document
* :mod:`.units`     mm <-> m at the FreeCAD boundary
* (mesh refinement lives in the core: :mod:`invrad_wb.core.geometry.meshing`)
* :mod:`.settings`  defaults of the document side (reflectance per surface, sizes)
* :mod:`.dependencies` the venv on sys.path (appended), what is missing, and the
  installer into FreeCAD's add-on package folder (``dependencies.install()``: the
  first-activation dialog and ``freecadcmd -c``)
* :mod:`.pip_runner` pip with FreeCAD's Python version, as the Addon Manager runs it
"""
