"""A light fixture's body and frame, shared by both document backends (Arch Equipment in a
classic document, IfcLightFixture entities in a NativeIFC one) and the IFC export:

* :func:`fixture_axes` / :func:`fixture_rotation`: local -Z along the light, local X the
  luminaire's C0 axis;
* :func:`fixture_size` / :func:`fixture_shape`: a disc or panel from the luminous area,
  with a rod and canopy for a pendant;
* :func:`check_luminaire`: a luminaire fit to become a fixture (one line naming it).
"""
import numpy as np

from invrad_wb.core.model.luminaires import Luminaire
from invrad_wb.errors import LuminaireError
from invrad_wb.app import settings as S
from invrad_wb.app.units import m_to_mm

#: A luminous opening this large (m2) or larger is drawn as a panel, not a disc.
PANEL_MIN_AREA_M2 = 0.09
#: Smallest disc radius drawn (metres), so that a small spot stays visible.
MIN_RADIUS_M = 0.05
#: A pendant's rod and the canopy where it meets the ceiling (metres).
ROD_RADIUS_M = 0.006
CANOPY_RADIUS_M = 0.04
CANOPY_THICKNESS_M = 0.015


def new_guid():
    """A new IFC GlobalId (22 characters), or '' without ifcopenshell."""
    try:
        import ifcopenshell.guid
    except ImportError:
        return ""
    return ifcopenshell.guid.new()


def fixture_axes(normal, c0=None):
    """The fixture's local x, y, z axes in the building (unit vectors): z = -``normal`` (the
    light leaves along local -Z) and x the luminaire's C0 direction, the photometry frame
    of :func:`invrad_wb.core.model.scene.plane_basis` (+X for a downlight, horizontal on a
    wall), so that a rectangular body lies the way its intensity table does; an aimed
    luminaire's own ``c0`` (its mounted C0 carried by the tilt) where it has one."""
    from invrad_wb.core.model.aiming import photometric_frame
    n = np.asarray(normal, dtype=np.float64)
    n = n / np.linalg.norm(n)
    u, v = photometric_frame(n, c0)
    return u, -v, -n


def fixture_rotation(normal, c0=None):
    """FreeCAD Rotation taking local -Z to the unit ``normal`` (the light direction) and
    local X to the luminaire's C0 axis (:func:`fixture_axes`)."""
    import FreeCAD
    x, y, z = fixture_axes(normal, c0)
    m = FreeCAD.Matrix()
    m.A11, m.A12, m.A13 = float(x[0]), float(y[0]), float(z[0])
    m.A21, m.A22, m.A23 = float(x[1]), float(y[1]), float(z[1])
    m.A31, m.A32, m.A33 = float(x[2]), float(y[2]), float(z[2])
    return FreeCAD.Rotation(m)


def fixture_size(lum):
    """The body's plan size from the luminaire's luminous area.

    Returns
    -------
    ("disc", radius_m) or ("panel", along local x (C0) m, along local y (C90) m)
    """
    if lum.radius_m > 0:
        return ("disc", float(lum.radius_m))
    phot = getattr(lum, "photometry", None)
    area = getattr(phot, "luminous_area_m2", None)
    if area and area > 0:
        if area >= PANEL_MIN_AREA_M2:
            ext = getattr(phot, "luminous_extent_m", None)
            if ext:
                return ("panel", float(ext[0]), float(ext[1]))
            side = float(np.sqrt(area))
            return ("panel", side, side)
        return ("disc", max(float(np.sqrt(area / np.pi)), MIN_RADIUS_M))
    return ("disc", S.FIXTURE_RADIUS_M)


def fixture_shape(size, drop_m=0.0, thickness_m=S.FIXTURE_THICKNESS_M):
    """The fixture body in local coordinates (mm); the light leaves along local -Z.

    Parameters
    ----------
    size : tuple from :func:`fixture_size`, or a radius in metres (a disc)
    drop_m : float, metres between the luminaire and the ceiling above it; > 0 adds a rod
        from the body up to the ceiling and a canopy there (a pendant)
    thickness_m : float, metres

    Returns
    -------
    Part.Solid: the body from local z = -thickness to 0 (a disc or a panel), fused
    with the rod and canopy of a pendant (local z = 0 .. drop).
    """
    import FreeCAD
    import Part
    if not isinstance(size, tuple):
        size = ("disc", float(size) if size > 0 else S.FIXTURE_RADIUS_M)
    t = m_to_mm(thickness_m)
    V = FreeCAD.Vector
    if size[0] == "panel":
        a, b = m_to_mm(size[1]), m_to_mm(size[2])
        body = Part.makeBox(a, b, t, V(-a / 2, -b / 2, -t))
    else:
        body = Part.makeCylinder(m_to_mm(size[1]), t, V(0, 0, -t), V(0, 0, 1))
    if drop_m <= 0:
        return body
    d = m_to_mm(drop_m)
    ct = min(m_to_mm(CANOPY_THICKNESS_M), 0.5 * d)
    rod = Part.makeCylinder(m_to_mm(ROD_RADIUS_M), d, V(0, 0, 0), V(0, 0, 1))
    canopy = Part.makeCylinder(m_to_mm(CANOPY_RADIUS_M), ct, V(0, 0, d - ct), V(0, 0, 1))
    solid = body.fuse([rod, canopy]).removeSplitter()
    return solid.Solids[0] if len(solid.Solids) == 1 else solid


def check_luminaire(lum, where):
    if not isinstance(lum, Luminaire):
        raise LuminaireError(f"{where}: not a Luminaire: {lum!r}")
    if not (np.all(np.isfinite(lum.position)) and np.all(np.isfinite(lum.normal))):
        raise LuminaireError(f"{where}: position/normal are not finite")
    if not (np.isfinite(lum.flux_lm) and lum.flux_lm > 0):
        raise LuminaireError(f"{where}: flux {lum.flux_lm!r} lm must be > 0")
