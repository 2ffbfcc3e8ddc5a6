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


# --------------------------------------------------------------------------- aimed fixtures
#: Tilts below this (degrees from the mounting surface's normal) are not drawn as aimed.
AIMED_MIN_TILT_DEG = 0.5
#: The beam axis of an aimed fixture in the 3D view: a dashed line in this colour from the
#: fixture to its aim point, and a small cross there.
BEAM_AXIS_RGB = (0.85, 0.25, 0.0)
BEAM_AXIS_NODE = "InvradBeamAxis"
#: The properties an aimed fixture carries in the document (both backends).
AIM_PROPERTIES = ("Tilt", "Pan", "AimPoint")


def aimed_tilt(lum):
    """The tilt in degrees of an aimed luminaire (locate --aim free, a design accent: its
    ``extra['tilt_deg']``), or None for one that faces along its mounting normal."""
    t = lum.extra.get("tilt_deg")
    if isinstance(t, bool) or not isinstance(t, (int, float)) or not np.isfinite(t):
        return None
    return float(t) if t >= AIMED_MIN_TILT_DEG else None


def aimed_pan(lum):
    """The pan in degrees of an aimed luminaire (``extra['pan_deg']``), 0 when none."""
    p = lum.extra.get("pan_deg")
    if isinstance(p, bool) or not isinstance(p, (int, float)) or not np.isfinite(p):
        return 0.0
    return float(p)


def aim_point_mm(shape, lum):
    """Where an aimed luminaire's beam axis first meets its room (FreeCAD Vector, mm): the
    ray from the luminaire along its light direction against the room's ``shape`` (a Part
    shape, mm); 2 m along the axis when it meets nothing (an open or broken shape)."""
    import Part
    from invrad_wb.app.units import direction, vector_mm
    p = vector_mm(lum.position)
    d = direction(lum.normal)
    try:
        seg = Part.LineSegment(p, p + d * 1e5).toShape()
        hits = [(v.Point - p).Length for v in seg.section(shape).Vertexes]
        hits = [h for h in hits if h > 5.0]
    except Exception:          # no shape, a broken solid
        hits = []
    return p + d * (min(hits) if hits else 2000.0)


def mount_normal_of(aim, c0, tilt_deg, pan_deg):
    """(3,) unit mounting normal of a fixture aimed along ``aim`` with C0 axis ``c0``,
    tilted ``tilt_deg`` towards pan ``pan_deg``: the gimbal tilt undone. The tilt is the
    smallest rotation R taking the mount normal m onto the aim and the mounted C0 axis u
    onto ``c0`` (:func:`~invrad_wb.core.model.aiming.aimed_c0`); the tilt direction d =
    cos(pan) u + sin(pan) v is turned to R d = cos(pan) c0 + sin(pan) R v, and m = cos(t)
    aim - sin(t) R d. None when the result does not give back the tilt and pan (a placement
    turned about its own axis by hand)."""
    from invrad_wb.core.model.aiming import tilt_pan
    from invrad_wb.core.model.scene import plane_basis
    a = np.asarray(aim, dtype=np.float64)
    t, p = np.radians(tilt_deg), np.radians(pan_deg)
    for sign in (1.0, -1.0):          # plane_basis' handedness, checked below
        rv = sign * np.cross(a, c0)
        rd = np.cos(p) * np.asarray(c0) + np.sin(p) * rv
        m = np.cos(t) * a - np.sin(t) * rd
        m = m / np.linalg.norm(m)
        u, v = plane_basis(m)
        if abs(abs(np.cross(m, u) @ v) - 1.0) > 1e-6 or np.sign(np.cross(m, u) @ v) != sign:
            continue
        tt, pp = tilt_pan(a, m)
        if abs(tt - tilt_deg) < 1e-3 and (tilt_deg < 1e-3 or
                                          abs((pp - pan_deg + 180.0) % 360.0 - 180.0) < 1e-3):
            return m
    return None


def add_aim_properties(obj, lum, tilt, aim_point, group="Light", readonly=False):
    """An aimed fixture's tilt and pan (degrees from its mounting normal) and the point its
    beam axis meets the room (drawn in the 3D view, :func:`draw_beam_axis`), as document
    properties of ``obj`` in ``group``; ``readonly`` where they only show what is stored
    elsewhere (a NativeIFC fixture's IFC placement and property set)."""
    for ptype, name, doc in (
            ("App::PropertyFloat", "Tilt", "Tilt of the beam from the mounting surface's"
                                           " normal (degrees)"),
            ("App::PropertyFloat", "Pan", "Pan of the beam around the mounting surface's"
                                          " normal (degrees)"),
            ("App::PropertyVector", "AimPoint", "Where the beam axis meets the room")):
        if name not in obj.PropertiesList:
            obj.addProperty(ptype, name, group, doc)
    key = (obj.Document.Name, obj.Name)
    WRITING_AIM.add(key)
    try:
        _write_aim_properties(obj, lum, tilt, aim_point, group, readonly)
    finally:
        WRITING_AIM.discard(key)


#: (document, object) names whose aim properties are being written
#: (:func:`add_aim_properties`): :mod:`.aimsync` leaves their changes be (not the user's).
WRITING_AIM = set()


def _write_aim_properties(obj, lum, tilt, aim_point, group, readonly):
    m = lum_mount_normal(lum, tilt)
    if m is not None and "MountNormal" not in obj.PropertiesList:
        obj.addProperty("App::PropertyVector", "MountNormal", group,
                        "Normal of the surface the fixture is mounted on (Tilt and Pan are"
                        " measured from it)")
        obj.setPropertyStatus("MountNormal", "Hidden")
    if m is not None:
        import FreeCAD
        obj.MountNormal = FreeCAD.Vector(*(float(x) for x in m))
    obj.Tilt = tilt
    obj.Pan = aimed_pan(lum)
    obj.AimPoint = aim_point
    if readonly:
        for name in AIM_PROPERTIES:
            obj.setPropertyStatus(name, "ReadOnly")


def lum_mount_normal(lum, tilt=None):
    """(3,) unit mounting normal of an aimed luminaire: its ``extra['mount_normal']``
    (locate, design), else worked out from its aim, C0 axis, tilt and pan
    (:func:`mount_normal_of`); None when neither gives one."""
    m = lum.extra.get("mount_normal")
    try:
        m = np.asarray(m, dtype=np.float64).reshape(3)
        if np.isfinite(m).all() and np.linalg.norm(m) > 0.5:
            return m / np.linalg.norm(m)
    except (TypeError, ValueError):
        pass
    tilt = aimed_tilt(lum) if tilt is None else tilt
    if tilt is None:
        return None
    c0 = getattr(lum, "c0", None)
    if c0 is None:
        c0 = fixture_axes(lum.normal)[0]
    return mount_normal_of(lum.normal, c0, tilt, aimed_pan(lum))


def is_aimed_fixture(obj):
    """A document object with an aimed fixture's properties (either backend)."""
    try:
        props = obj.PropertiesList
    except Exception:          # a deleted object
        return False
    return all(p in props for p in AIM_PROPERTIES)


def aim_extra(obj):
    """``{"tilt_deg", "pan_deg"}`` of an aimed fixture's document properties, or {}."""
    if not is_aimed_fixture(obj):
        return {}
    return {"tilt_deg": float(obj.Tilt), "pan_deg": float(obj.Pan)}


def has_beam_axis(obj):
    """Whether the 3D view shows ``obj``'s beam axis (False without the GUI)."""
    root = getattr(getattr(obj, "ViewObject", None), "RootNode", None)
    if root is None:
        return False
    return any(root.getChild(i).getName() == BEAM_AXIS_NODE
               for i in range(root.getNumChildren()))


def draw_beam_axis(obj):
    """Show an aimed fixture's beam axis in the 3D view (GUI only): a dashed line along its
    light direction (local -Z) from the fixture to its ``AimPoint``, and a cross there.
    The line is a child of the view's root, after the placement's transform, so it moves
    with the fixture; drawn once per view object (an earlier one is replaced). The 3D
    view's nodes are not saved: :mod:`invrad_wb.gui.beamaxis` draws them again when a
    document is opened and after undo or redo. True when drawn."""
    import FreeCAD
    if not FreeCAD.GuiUp or "AimPoint" not in getattr(obj, "PropertiesList", ()):
        return False
    vo = getattr(obj, "ViewObject", None)
    root = getattr(vo, "RootNode", None)
    if root is None:
        return False
    try:
        from pivy import coin
    except ImportError:
        return False
    for i in range(root.getNumChildren() - 1, -1, -1):
        if root.getChild(i).getName() == BEAM_AXIS_NODE:
            root.removeChild(i)
    pl = obj.Placement
    end = pl.inverse().multVec(obj.AimPoint)
    length = max(end.Length, 1.0)
    c = 0.04 * length
    sep = coin.SoSeparator()
    sep.setName(BEAM_AXIS_NODE)
    col = coin.SoBaseColor()
    col.rgb = BEAM_AXIS_RGB
    style = coin.SoDrawStyle()
    style.lineWidth = 2
    style.linePattern = 0xFF00
    pts = [(0, 0, 0), (0, 0, -length),
           (-c, 0, -length), (c, 0, -length), (0, -c, -length), (0, c, -length)]
    coords = coin.SoCoordinate3()
    coords.point.setValues(0, len(pts), pts)
    lines = coin.SoLineSet()
    lines.numVertices.setValues(0, 3, [2, 2, 2])
    light = coin.SoLightModel()
    light.model = coin.SoLightModel.BASE_COLOR
    for node in (light, col, style, coords, lines):
        sep.addChild(node)
    root.addChild(sep)
    return True
