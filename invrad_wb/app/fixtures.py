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
from invrad_wb.errors import SceneError
from invrad_wb.app import nativeifc
from invrad_wb.app import settings as S
from invrad_wb.app.document import describe, object_type, transaction
from invrad_wb.app.units import direction, m_to_mm, mm_to_m, vector_mm
# the body and frame (both backends and the IFC export use them): fixtures.fixture_size etc.
from invrad_wb.app.fixturebody import (  # noqa: F401
    CANOPY_RADIUS_M, CANOPY_THICKNESS_M, MIN_RADIUS_M, PANEL_MIN_AREA_M2, ROD_RADIUS_M,
    check_luminaire, fixture_axes, fixture_rotation, fixture_shape, fixture_size, new_guid)

LIGHT_FIXTURE = "Light Fixture"
#: Colours in the 3D view (RGB in [0, 1]): a warm white body that glows, dark outlines.
FIXTURE_RGB = (1.0, 0.93, 0.55)
FIXTURE_EMISSIVE_RGB = (0.75, 0.62, 0.15)
FIXTURE_LINE_RGB = (0.25, 0.2, 0.05)


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
    if nativeifc.is_native(obj):
        return nativeifc.is_native_fixture(obj, generated_only)
    if object_type(obj) != "Equipment" or getattr(obj, "IfcType", "") != LIGHT_FIXTURE:
        return False
    return not generated_only or getattr(obj, "Generator", "") == S.GENERATOR_TAG


def room_fixtures(space, generated_only=True):
    """Light fixtures inside a Space (those made by invrad only, by default)."""
    if nativeifc.is_native(space):
        return nativeifc.room_fixtures(space, generated_only)
    return [o for o in space.Group if is_fixture(o, generated_only)]


def all_fixtures(doc, generated_only=True):
    return [o for o in doc.Objects if is_fixture(o, generated_only)]


def fixture_room(obj):
    """The Space of a fixture: its Room link, else the Space whose Group holds it."""
    if nativeifc.is_native(obj):
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
    if per_room and all(nativeifc.is_native(sp) for sp, _ in per_room):
        # IfcLightFixture entities, one undo step
        return nativeifc.insert_fixtures(doc, per_room, fixture_label, replace=replace,
                                         name=name)
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
    if nativeifc.is_native(obj):
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
