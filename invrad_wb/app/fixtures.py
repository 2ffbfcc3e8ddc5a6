"""Found luminaires -> real BIM light fixtures in the document (and back).

Each luminaire becomes an Arch Equipment with ``IfcType = "Light Fixture"``:

* **Placement**: its origin is the luminaire's position (the point found by locate on
  the mounting surface); its **local -Z axis is the light direction**, i.e. the found
  normal pointing into the room (a ceiling luminaire has the identity rotation; a wall
  washer's -Z is horizontal). ``LightDirection`` repeats it as a global unit vector.
* **Body** (:func:`fixture_size`, :func:`fixture_shape`): sized from the luminaire's
  luminous area: a downlight disc of its emitter radius, or of its photometry file's
  luminous opening (a panel when that opening is 0.09 m2 or more: the file's length and
  width along the luminaire's C0 and C90 axes, a square of its area when it gives none);
  a point emitter
  without photometry gets a ``settings.FIXTURE_RADIUS_M`` disc. It is
  ``settings.FIXTURE_THICKNESS_M`` thick, from local z = -thickness to 0, i.e. just below
  the mounting surface, in the room. A **pendant** (facing down, more than
  ``settings.PENDANT_MIN_DROP_M`` below the ceiling above it, or ``extra['mount'] ==
  'pendant'``) hangs from the ceiling on a rod with a canopy (:func:`ceiling_drop_m`). The
  shape is the Equipment's own (no base object), so a document stays light with hundreds
  of fixtures; it is one solid (the IFC exporter writes it as the fixture's body).
* **View** (:func:`style_fixture`, in the GUI): a warm light colour that glows (emissive),
  so fixtures stand out from the building and the false colours; selectable as usual.
* **Label**: ``Luminaire <room> <n>``, with the catalogue type a design chose in
  parentheses (the fixtures are listed under their Space in the tree).
* **Photometry**: ``LuminousFlux`` (lm), ``EmitterRadius`` (0 = point emitter) and the
  locate ``Score`` as properties, mirrored in ``IfcProperties`` so that FreeCAD's IFC
  exporter writes them as the custom property set ``InvRad_Luminaire`` (IFC has no
  standard fixture flux; Pset_LightFixtureTypeCommon gets NumberOfSources = 1).
* **Room**: fixtures are put inside their Space (``Space.Group``: Arch's "objects that
  are included inside this space, such as furniture"), and ``Room`` links back to it. The
  link is an ``App::PropertyLinkHidden``: a plain link would close a dependency cycle with
  the Space's Group ("The graph must be a DAG").

:func:`insert_fixtures` makes all of it ONE undoable transaction and, by default, first
removes the fixtures a previous invrad run put into the same rooms (``Generator`` tag).
"""
import numpy as np

from invrad_wb.core.model.luminaires import Luminaire
from invrad_wb.errors import LuminaireError, SceneError
from invrad_wb.app import settings as S
from invrad_wb.app.document import describe, object_type, transaction
from invrad_wb.app.units import direction, m_to_mm, mm_to_m, vector_mm

LIGHT_FIXTURE = "Light Fixture"
#: A luminous opening this large (m2) or larger is drawn as a panel, not a disc.
PANEL_MIN_AREA_M2 = 0.09
#: Smallest disc radius drawn (metres), so that a small spot stays visible.
MIN_RADIUS_M = 0.05
#: A pendant's rod and the canopy where it meets the ceiling (metres).
ROD_RADIUS_M = 0.006
CANOPY_RADIUS_M = 0.04
CANOPY_THICKNESS_M = 0.015
#: Colours in the 3D view (RGB in [0, 1]): a warm white body that glows, dark outlines.
FIXTURE_RGB = (1.0, 0.93, 0.55)
FIXTURE_EMISSIVE_RGB = (0.75, 0.62, 0.15)
FIXTURE_LINE_RGB = (0.25, 0.2, 0.05)


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


def ceiling_drop_m(space, lum):
    """How far a downward-facing luminaire hangs below the room's ceiling (metres).

    The vertical line up from the luminaire meets the Space's shape; 0 when the luminaire
    does not face down, sits on the ceiling (less than ``settings.PENDANT_MIN_DROP_M``
    below it, unless ``extra['mount'] == 'pendant'``) or nothing is found above it.
    """
    if lum.normal[2] > -0.99:
        return 0.0
    try:
        import FreeCAD
        import Part
        shape = space.Shape
        p = vector_mm(lum.position)
        seg = Part.LineSegment(p, p + FreeCAD.Vector(0, 0, 1e5)).toShape()
        dist = [v.Point.z - p.z for v in seg.section(shape).Vertexes if v.Point.z > p.z + 1.0]
    except Exception:          # no shape, a broken solid: no rod (the body still shows)
        return 0.0
    if not dist:
        return 0.0
    drop = mm_to_m(min(dist))
    pendant = lum.extra.get("mount") == "pendant" or drop >= S.PENDANT_MIN_DROP_M
    return float(drop) if pendant else 0.0


def fixture_label(space, i, lum):
    """``Luminaire <room> <i + 1>``, with the catalogue type in parentheses if known (the
    room by :func:`~invrad_wb.app.rooms.room_name`: a NativeIFC space's LongName)."""
    from invrad_wb.app.rooms import room_name
    kind = lum.extra.get("type")
    return f"Luminaire {room_name(space)} {i + 1}" + (f" ({kind})" if kind else "")


def style_fixture(obj):
    """The fixture's look in the 3D view: a light colour that glows (emissive), dark
    outlines; no-op without the GUI."""
    import FreeCAD
    if not FreeCAD.GuiUp:
        return
    vo = getattr(obj, "ViewObject", None)
    if vo is None or not hasattr(vo, "ShapeColor"):
        return
    vo.ShapeColor = FIXTURE_RGB
    vo.LineColor = FIXTURE_LINE_RGB
    try:
        mat = vo.ShapeMaterial
        mat.DiffuseColor = FIXTURE_RGB
        mat.EmissiveColor = FIXTURE_EMISSIVE_RGB
        vo.ShapeMaterial = mat
    except Exception:          # a FreeCAD without ShapeMaterial: the colour alone
        pass


def is_fixture(obj, generated_only=False):
    if _native(obj):
        from invrad_wb.app import nativeifc
        return nativeifc.is_native_fixture(obj, generated_only)
    if object_type(obj) != "Equipment" or getattr(obj, "IfcType", "") != LIGHT_FIXTURE:
        return False
    return not generated_only or getattr(obj, "Generator", "") == S.GENERATOR_TAG


def _native(obj):
    """A NativeIFC object (FreeCAD 1.x): its fixtures are IFC entities (.nativeifc)."""
    try:
        return "StepId" in obj.PropertiesList and "IfcClass" in obj.PropertiesList
    except Exception:
        return False


def room_fixtures(space, generated_only=True):
    """Light fixtures inside a Space (those made by invrad only, by default)."""
    if _native(space):
        from invrad_wb.app import nativeifc
        return nativeifc.room_fixtures(space, generated_only)
    return [o for o in space.Group if is_fixture(o, generated_only)]


def all_fixtures(doc, generated_only=True):
    return [o for o in doc.Objects if is_fixture(o, generated_only)]


def fixture_room(obj):
    """The Space of a fixture: its Room link, else the Space whose Group holds it."""
    if _native(obj):
        from invrad_wb.app import nativeifc
        return nativeifc.fixture_room(obj)
    room = getattr(obj, "Room", None)
    if room is not None:
        return room
    for parent in obj.InList:
        if object_type(parent) == "Space" and obj in parent.Group:
            return parent
    return None


def _add_properties(obj):
    props = [
        ("App::PropertyFloat", "LuminousFlux", "Light", "Luminous flux of the luminaire (lm)"),
        ("App::PropertyLength", "EmitterRadius", "Light", "Radius of the emitting disk"
                                                          " (0 = point emitter)"),
        ("App::PropertyVector", "LightDirection", "Light", "Light direction (global unit"
                                                           " vector, the local -Z axis)"),
        ("App::PropertyFloat", "Score", "Light", "How much this luminaire lowered the"
                                                 " locate cost"),
        ("App::PropertyLinkHidden", "Room", "Light", "The room (Space) this fixture lights"),
        ("App::PropertyString", "Generator", "Light", "Tool that placed this fixture"),
    ]
    for ptype, name, group, doc in props:
        if name not in obj.PropertiesList:
            obj.addProperty(ptype, name, group, doc)


def _ifc_properties(lum):
    p = {"LuminousFlux;;" + S.IFC_LUMINAIRE_PSET: f"IfcLuminousFluxMeasure;;{float(lum.flux_lm)!r}",
         "Generator;;" + S.IFC_LUMINAIRE_PSET: f"IfcLabel;;{S.GENERATOR_TAG}",
         "NumberOfSources;;Pset_LightFixtureTypeCommon": "IfcInteger;;1"}
    if lum.radius_m > 0:
        p["EmitterRadius;;" + S.IFC_LUMINAIRE_PSET] = f"IfcLengthMeasure;;{float(lum.radius_m)!r}"
    if lum.score is not None and np.isfinite(lum.score) and lum.score > 0:
        p["Score;;" + S.IFC_LUMINAIRE_PSET] = f"IfcReal;;{float(lum.score)!r}"
    if lum.extra.get("type"):      # the catalogue entry a design chose
        p["LuminaireType;;" + S.IFC_LUMINAIRE_PSET] = f"IfcLabel;;{lum.extra['type']}"
    return p


def check_luminaire(lum, where):
    if not isinstance(lum, Luminaire):
        raise LuminaireError(f"{where}: not a Luminaire: {lum!r}")
    if not (np.all(np.isfinite(lum.position)) and np.all(np.isfinite(lum.normal))):
        raise LuminaireError(f"{where}: position/normal are not finite")
    if not (np.isfinite(lum.flux_lm) and lum.flux_lm > 0):
        raise LuminaireError(f"{where}: flux {lum.flux_lm!r} lm must be > 0")


def make_fixture(space, lum, label):
    """Create one fixture (no transaction of its own: use :func:`insert_fixtures`).

    The body is sized from the luminaire (:func:`fixture_size`) and hangs on a rod when
    it is a pendant in ``space`` (:func:`ceiling_drop_m`)."""
    import Arch
    obj = Arch.makeEquipment(name=label)
    obj.Label = label
    obj.IfcType = LIGHT_FIXTURE
    _add_properties(obj)
    obj.Shape = fixture_shape(fixture_size(lum), ceiling_drop_m(space, lum))
    obj.Placement = _placement(lum)
    obj.LuminousFlux = float(lum.flux_lm)
    obj.EmitterRadius = m_to_mm(lum.radius_m)
    obj.LightDirection = direction(lum.normal)
    obj.Score = float(lum.score) if lum.score is not None and np.isfinite(lum.score) else 0.0
    obj.Generator = S.GENERATOR_TAG
    kind = lum.extra.get("type")
    obj.Description = (f"invrad luminaire, {kind}, {lum.flux_lm:.0f} lm" if kind
                       else f"invrad luminaire, {lum.flux_lm:.0f} lm")
    if kind and "Model" in obj.PropertiesList:
        obj.Model = str(kind)
    props = dict(obj.IfcProperties)
    props.update(_ifc_properties(lum))
    obj.IfcProperties = props
    uid = new_guid()
    if uid:
        data = dict(obj.IfcData)
        data["IfcUID"] = uid
        obj.IfcData = data
    obj.Room = space
    space.Proxy.addObject(space, obj)
    style_fixture(obj)
    return obj


def _placement(lum):
    import FreeCAD
    return FreeCAD.Placement(vector_mm(lum.position),
                             fixture_rotation(lum.normal, getattr(lum, "c0", None)))


def _ensure_space_uid(space):
    data = dict(getattr(space, "IfcData", {}) or {})
    if not data.get("IfcUID"):
        uid = new_guid()
        if uid:
            data["IfcUID"] = uid
            space.IfcData = data


def insert_fixtures(doc, per_room, replace=True, name="Insert luminaires"):
    """Insert luminaires as light fixtures, room by room, as ONE undoable transaction.

    Parameters
    ----------
    doc : FreeCAD document
    per_room : list of (Space, list of Luminaire)
    replace : bool
        First remove the fixtures that invrad put into these rooms before.

    Returns
    -------
    list of the new fixture objects, in the order given.

    Raises
    ------
    LuminaireError, SceneError
        Bad luminaire or room; the document is left unchanged.
    """
    if per_room and all(_native(sp) for sp, _ in per_room):
        from invrad_wb.app import nativeifc      # IfcLightFixture entities, one undo step
        return nativeifc.insert_fixtures(doc, per_room, replace=replace, name=name)
    for space, lums in per_room:
        if object_type(space) != "Space":
            raise SceneError(f"{describe(space)} is not a room (Arch Space)", doc.Label)
        for i, lum in enumerate(lums):
            check_luminaire(lum, f"luminaire {i + 1} of room {describe(space)}")
    out = []
    with transaction(doc, name):
        for space, lums in per_room:
            if replace:
                for old in room_fixtures(space):
                    doc.removeObject(old.Name)
            _ensure_space_uid(space)
            for i, lum in enumerate(lums):
                out.append(make_fixture(space, lum, fixture_label(space, i, lum)))
    return out


def fixture_luminaire(obj):
    """The Luminaire a fixture stands for (position, direction, flux, radius, score)."""
    if _native(obj):
        from invrad_wb.app import nativeifc
        return nativeifc.fixture_luminaire(obj)
    pl = obj.getGlobalPlacement() if hasattr(obj, "getGlobalPlacement") else obj.Placement
    import FreeCAD
    d = pl.Rotation.multVec(FreeCAD.Vector(0, 0, -1))
    x = pl.Rotation.multVec(FreeCAD.Vector(1, 0, 0))
    flux = float(getattr(obj, "LuminousFlux", 0.0))
    n = np.array([d.x, d.y, d.z])
    # an aimed luminaire's C0 axis (local X) differs from its normal's own frame
    c0 = np.array([x.x, x.y, x.z])
    if np.allclose(c0, fixture_axes(n)[0], atol=1e-6):
        c0 = None
    return Luminaire(mm_to_m(pl.Base), n, flux,
                     mm_to_m(getattr(obj, "EmitterRadius", 0.0)),
                     score=float(getattr(obj, "Score", 0.0)) or None, c0=c0)
