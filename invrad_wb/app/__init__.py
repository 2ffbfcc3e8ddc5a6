"""The FreeCAD document side of invrad: rooms and targets in, luminaires out.

This package is headless-safe: it imports FreeCAD (never FreeCADGui) and only inside the
modules that need it, so ``import invrad_wb.app`` works without FreeCAD. The GUI commands
(``invrad_wb.gui``) are thin calls into it. Its modules are in layers, each importing only
those below it (``tests/test_architecture.py``), lowest first:

* :mod:`.settings`, :mod:`.units` (mm <-> m at the FreeCAD boundary), :mod:`.document`
  (undoable transactions, active document)
* :mod:`.fixturebody` a light fixture's body and frame (both backends and the export)
* :mod:`.ifcdata`   invrad's data in IFC files through ifcopenshell: requirement sets,
  fixture entities' psets, placement and body, IfcSpace shapes
* the two document backends: :mod:`.classic` (Arch Spaces, Arch Equipment fixtures,
  requirements in IfcProperties, a FreeCAD transaction per edit) and :mod:`.nativeifc`
  (FreeCAD 1.x: IfcSpace rooms, IfcLightFixture entities, requirements, one undo step per
  run holding one ifcopenshell transaction)
* :mod:`.backend`   one interface over them, chosen once per document (``backend.of``):
  rooms, their solids and requirements, fixtures in and out; nothing above branches on
  an object's kind; :mod:`.aimsync` an observer that keeps aimed fixtures whole (their
  aim read from the IFC when NativeIFC makes their objects lazily, their aim point and
  tilt following a move, their placement a tilt or pan edit)
* :mod:`.rooms`     Arch Spaces (or IfcSpaces) -> room solids -> sampling meshes (metres,
  inward normals); :mod:`.dependencies` the venv on sys.path (appended) and what is
  missing, with the command that installs it (called by the workbench's Initialize)
* :mod:`.targets`   lighting targets stored in the document (FeaturePython objects);
  :mod:`.fixtures`  found luminaires -> light fixtures in their Space (Arch Equipment, or
  IfcLightFixture entities in a NativeIFC document)
* :mod:`.ifcrooms`  IFC import with ifcopenshell (IfcSpace -> Arch Space);
  :mod:`.ifcexport` IFC export (FreeCAD's exporter or merged into the source IFC);
  :mod:`.design`    design specs from a targets file or the rooms' requirements
* :mod:`.ifcimport` FreeCAD open/insert hooks (registered by Init.py) and ``open_ifc``
  (a NativeIFC document); :mod:`.pipeline` a whole building, room by room: targets ->
  locate -> fixtures -> report
* :mod:`.results`   Verify, re-insert, the metrics sheet
* :mod:`.dependencies` also installs what is missing into FreeCAD's add-on package folder
  (``dependencies.install()``: the first-activation dialog and ``freecadcmd -c``), with
  :mod:`.pip_runner` (pip with FreeCAD's Python version, as the Addon Manager runs it)

(mesh refinement lives in the core: :mod:`invrad_wb.core.geometry.meshing`)
"""
