"""Unit conversion at the FreeCAD boundary: FreeCAD works in millimetres, invrad in metres.

Every value that crosses between a FreeCAD document and the core goes through these
functions, so that no other module multiplies by 1000.
"""
import numpy as np

MM_PER_M = 1000.0


def m_to_mm(value):
    """Metres (scalar or array) -> millimetres."""
    if np.ndim(value):
        return np.asarray(value, dtype=np.float64) * MM_PER_M
    return float(value) * MM_PER_M


def mm_to_m(value):
    """Millimetres (scalar, array, FreeCAD Quantity or Vector) -> metres."""
    if hasattr(value, "getValueAs"):            # FreeCAD Quantity
        return float(value.getValueAs("m"))
    if hasattr(value, "x") and hasattr(value, "z"):  # FreeCAD Vector
        return np.array([value.x, value.y, value.z], dtype=np.float64) / MM_PER_M
    if np.ndim(value):
        return np.asarray(value, dtype=np.float64) / MM_PER_M
    return float(value) / MM_PER_M


def points_mm_to_m(points):
    """A sequence of FreeCAD Vectors (or (k, 3) mm) -> (k, 3) float64 metres."""
    if len(points) == 0:
        return np.zeros((0, 3))
    if hasattr(points[0], "x"):
        return np.array([(p.x, p.y, p.z) for p in points], dtype=np.float64) / MM_PER_M
    return np.asarray(points, dtype=np.float64).reshape(-1, 3) / MM_PER_M


def vector_mm(point_m):
    """A point in metres -> FreeCAD Vector in millimetres."""
    import FreeCAD
    p = np.asarray(point_m, dtype=np.float64).reshape(3) * MM_PER_M
    return FreeCAD.Vector(float(p[0]), float(p[1]), float(p[2]))


def direction(vec):
    """A unit direction (no scaling) -> FreeCAD Vector."""
    import FreeCAD
    d = np.asarray(vec, dtype=np.float64).reshape(3)
    d = d / np.linalg.norm(d)
    return FreeCAD.Vector(float(d[0]), float(d[1]), float(d[2]))
