"""One place for paths and tunables shared by the core, the CLI and the workbench.

All physical quantities are SI: metres, lux, lumens, candela.
"""
import os

#: The package folder and the checkout / workbench folder above it.
PACKAGE_DIR = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(PACKAGE_DIR)


def _data_dir(name):
    """``kernels/``, ``tables/`` or ``resources/``: inside the package when installed
    (``pip install .`` maps them to ``invrad_wb/<name>``), else at the checkout's top level
    (the FreeCAD workbench layout, and editable installs)."""
    inside = os.path.join(PACKAGE_DIR, name)
    return inside if os.path.isdir(inside) else os.path.join(ROOT, name)


KERNELS_DIR = _data_dir("kernels")
TABLES_DIR = _data_dir("tables")
RESOURCES_DIR = _data_dir("resources")

#: Geometric tolerance in metres: points closer than this are the same point,
#: planes whose offsets differ by less are the same plane.
EPS_M = 1e-6
#: Offset in metres of ray origins/ends off a surface for occlusion tests.
RAY_EPS_M = 1e-4
#: Two unit normals are parallel when their dot product exceeds this.
COPLANAR_COS = 1.0 - 1e-6
#: Coplanarity tolerance for grouping faces into planes (metres).
PLANE_OFFSET_TOL_M = 1e-4
#: A scene whose bounding box is larger than this (metres) is probably in millimetres.
MAX_PLAUSIBLE_EXTENT_M = 2000.0
#: A scene smaller than this (metres) cannot hold a luminaire: a metres file read as
#: millimetres (--unit mm) or a model in kilometres.
MIN_PLAUSIBLE_EXTENT_M = 0.3
#: Faces smaller than this (m^2) are degenerate.
MIN_FACE_AREA_M2 = 1e-10

#: Disk luminaires are integrated with this many rings (Gauss-Legendre in r^2) x angles.
DISK_RINGS = 3
DISK_ANGLES = 8

#: Radiosity: target number of patches per room and smallest patch edge (metres).
RADIOSITY_TARGET_PATCHES = 1200
RADIOSITY_MIN_PATCH_M = 0.1
#: Near-field: emitter patches closer than this many patch radii are integrated exactly.
RADIOSITY_NEAR_FACTOR = 3.0
RADIOSITY_MAX_ITER = 500
RADIOSITY_TOL = 1e-5
#: Rooms of at most this many patches are solved directly (LU factors made once per room,
#: about 0.06 CPU s at 1200 patches, growing as P^3), larger ones by Jacobi iteration.
RADIOSITY_DIRECT_MAX_PATCHES = 2000

#: Default reflectance of faces without one.
DEFAULT_REFLECTANCE = 0.5

#: Radiosity patch matrix: each patch's form factors are the area-weighted mean over
#: q x q sub-cell sample points of it (1 = its representative point only).
RADIOSITY_RECEIVER_SUBDIV = 2
#: Receiver x patch gather matrices (float32) larger than this are not stored but
#: recomputed at each application (MiB).
RADIOSITY_GATHER_MAX_MB = 1024
#: Work units per numpy chunk (receiver-patch or receiver-triangle pairs, segments).
RADIOSITY_NUMPY_CHUNK = 400_000
#: Device output buffer per OpenCL form-factor launch (MiB).
RADIOSITY_CL_CHUNK_MB = 64
#: Width (patch radii) of the zone beyond the near field where exact and far-field form
#: factors are blended (continuous form factors).
RADIOSITY_NEAR_BLEND = 0.5

#: Work-items per OpenCL launch (launches are chunked so any scene size fits and no launch
#: runs long enough to trip a GPU driver's watchdog).
CL_CHUNK_RECEIVERS = 1 << 18
CL_CHUNK_SEGMENTS = 1 << 20
#: Photometric direct light: (point, luminaire) pairs per launch (kernels/photometric.cl)
CL_CHUNK_PHOTOMETRIC_PAIRS = 1 << 24
#: Exact votes: (16-pixel blocks x voting points) per launch.
CL_CHUNK_VOTE_PAIRS = 1 << 27
CL_CHUNK_ELLIPSES = 1 << 16

#: Lighting design: a spot (an accent target) is met when its maintained mean lux is within
#: this fraction of its target mean (invrad_wb.core.design.accent; the design report says it).
SPOT_TOLERANCE = 0.10
#: general lighting dimmed below this fraction of its rated output is flagged (a smaller
#: type would do with less installed power): each luminaire's own output counts
DEEP_DIMMING = 0.5
#: where the EN 12464-1 minimums of walls and ceilings come from (the design report says
#: so); the design's table of room types re-exports it
SURFACE_REFERENCE = "EN 12464-1:2021 5.2.3"

#: locate: a room whose luminaires still explain its targets poorly after this many CPU
#: seconds of refinement gets no further searches (overlap votes, residual votes, regular
#: arrangements, the count search); the run says so in one line. The issue's rooms of
#: narrow-beam photometry the method cannot explain took 150-195 s each
LOCATE_UNEXPLAINED_LIMIT_S = 60.0
