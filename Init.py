# invrad workbench: start-up of FreeCAD, with or without GUI.
# Tiny and headless-safe: nothing is imported here. The workbench's package, invrad_wb,
# is loaded only when it is used (InitGui.py loads it inside Initialize()).
import FreeCAD

# Open/insert the rooms of an IFC file with ifcopenshell (FreeCAD 0.20's own IFC importer
# does not work with ifcopenshell >= 0.8); see invrad_wb/app/ifcrooms.py.
FreeCAD.addImportType("IFC rooms for lighting design - invrad (*.ifc)",
                      "invrad_wb.app.ifcimport")
