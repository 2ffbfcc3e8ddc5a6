"""Defaults and tunables of the FreeCAD document side (SI units: metres, lux, lumens).

The core's tunables live in :mod:`invrad_wb.constants`; these only concern how a BIM
document is turned into a scene and how luminaires are put back into it.
"""

#: Default diffuse reflectance per surface type when nothing else is set (EN 12464-1
#: recommends 0.2-0.4 for floors, 0.5-0.8 for walls and 0.7-0.9 for ceilings).
REFLECTANCE = {"floor": 0.25, "wall": 0.5, "ceiling": 0.7}

#: A surface whose inward normal has a z component above this is a floor, below minus
#: this a ceiling, otherwise a wall (0.5 = tilted by less than 60 degrees from horizontal).
FLOOR_CEILING_NZ = 0.5

#: Default sampling resolution: the longest triangle edge of a room mesh (metres).
RESOLUTION_M = 0.3
#: Finest resolution accepted (metres); finer meshes only cost time.
MIN_RESOLUTION_M = 0.01

#: Default work-plane height above the floor (metres) and border zone left out (metres).
WORK_PLANE_HEIGHT_M = 0.75
WORK_PLANE_MARGIN_M = 0.0

#: Tolerance in mm of FreeCAD's tessellation of curved room surfaces.
TESSELLATION_TOL_MM = 1.0

#: Body of an inserted light fixture: a disk of the luminaire's radius (this radius if the
#: luminaire is a point emitter without a luminous area) and this thickness, hanging from
#: the mounting surface; a downward luminaire at least PENDANT_MIN_DROP_M below the ceiling
#: above it hangs from it on a rod (app/fixtures.py).
FIXTURE_RADIUS_M = 0.15
FIXTURE_THICKNESS_M = 0.04
PENDANT_MIN_DROP_M = 0.1

#: IFC property set (custom, hence no "Pset_" prefix) holding the photometric data of
#: inserted fixtures, and the tag that marks fixtures made by invrad.
IFC_LUMINAIRE_PSET = "InvRad_Luminaire"
GENERATOR_TAG = "invrad"

#: Label of the document group that holds the lighting targets.
TARGETS_GROUP_LABEL = "Lighting targets"

#: Name of invrad's metrics spreadsheet in a document (app/results.py writes it; the IFC
#: export leaves it out).
SHEET_NAME = "InvRadReport"
