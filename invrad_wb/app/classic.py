"""The classic document backend (Arch/BIM objects, FreeCAD 0.20 and 1.x): rooms are Arch
Spaces, light fixtures Arch Equipment, requirements the Spaces' ``IfcProperties``, and an
undo step one FreeCAD transaction. :mod:`.backend` puts it and :mod:`.nativeifc` behind
one interface; rooms, fixtures and the IFC export call that, not this module.

**Fixtures.** Each luminaire becomes an Arch Equipment with ``IfcType = "Light Fixture"``
(:func:`make_fixture`; what its placement, body, label and properties are:
:mod:`.fixtures`), put inside its Space's Group with a hidden ``Room`` link back.
**Requirements** (:func:`write_requirements`): ``Pset_SpaceLightingRequirements``
(Illuminance, ArtificialLighting) and ``InvRad_LightingResult`` (AchievedEm, AchievedEmin,
AchievedU0, InstalledPower) in ``IfcProperties``, which FreeCAD's IFC exporter writes as
property sets.
"""
import math

import numpy as np

from invrad_wb.core.model.luminaires import Luminaire
from invrad_wb.errors import SceneError
from invrad_wb.app import settings as S
from invrad_wb.app.document import describe, global_shape, object_type, transaction
from invrad_wb.app.fixturebody import (add_aim_properties, aim_extra, aim_point_mm, aimed_tilt,
                                       check_luminaire, draw_beam_axis, fixture_axes,
                                       fixture_rotation, fixture_shape, fixture_size,
                                       new_guid)
from invrad_wb.app.ifcdata import PSET_REQ_IFC4, PSET_RESULT, RESULT_PROPERTIES
from invrad_wb.app.units import direction, m_to_mm, mm_to_m, vector_mm

LIGHT_FIXTURE = "Light Fixture"
#: Colours in the 3D view (RGB in [0, 1]): a warm white body that glows, dark outlines.
FIXTURE_RGB = (1.0, 0.93, 0.55)
FIXTURE_EMISSIVE_RGB = (0.75, 0.62, 0.15)
FIXTURE_LINE_RGB = (0.25, 0.2, 0.05)


# --------------------------------------------------------------------------- rooms
def is_space(obj):
    """An Arch/BIM Space."""
    return object_type(obj) == "Space"


def room_name(space):
    return space.Label


def space_uid(space):
    """The IFC GlobalId stored on a Space (``IfcData['IfcUID']``) or ''."""
    data = getattr(space, "IfcData", None) or {}
    return str(data.get("IfcUID", "")) if hasattr(data, "get") else ""


def face_count(space):
    """Number of faces of a Space's shape (0 without geometry)."""
    shape = getattr(space, "Shape", None)
    if shape is None or shape.isNull():
        return 0
    return len(shape.Faces)


def _free_edges(shape):
    import Part
    n = 0
    for e in shape.Edges:
        if len(shape.ancestorsOfType(e, Part.Face)) < 2:
            n += 1
    return n


def space_solid(space):
    """The Space's closed solid, in global coordinates (mm), checked.

    Raises
    ------
    SceneError
        Naming the Space when it has no geometry, its boundaries enclose no volume or its
        surface is not closed.
    """
    who = f"room {describe(space)}"
    base = getattr(space, "Base", None)
    if base is not None and hasattr(base, "Shape") and not base.Shape.isNull():
        # Arch keeps a Space's previous shape when its base stops being a solid: check it
        bs = base.Shape
        if not bs.Solids or not all(sh.isClosed() for so in bs.Solids for sh in so.Shells):
            raise SceneError(f"{who} is not closed: its base {describe(base)} is an open"
                             f" surface ({len(bs.Faces)} faces, {_free_edges(bs)} free"
                             " edges), not a closed solid; close it (e.g. Part > Shape"
                             " builder > solid from shell)", space.Label)
    shape = getattr(space, "Shape", None)
    if shape is None or shape.isNull() or not shape.Faces:
        if getattr(space, "Boundaries", None):
            raise SceneError(f"{who} has no geometry: its {len(space.Boundaries)} boundary"
                             " objects do not enclose a volume (check that the walls, floor"
                             " and ceiling faces close the room)", space.Label)
        raise SceneError(f"{who} has no geometry (no base solid and no boundaries)",
                         space.Label)
    if not shape.Solids:
        raise SceneError(f"{who} is not closed: its shape has no solid ({len(shape.Faces)}"
                         f" faces, {_free_edges(shape)} free edges)", space.Label)
    for solid in shape.Solids:
        for shell in solid.Shells:
            if not shell.isClosed():
                raise SceneError(f"{who} is not closed: its solid has"
                                 f" {_free_edges(shell)} free edges", space.Label)
    return global_shape(space, shape)


# --------------------------------------------------------------------------- fixtures
def is_fixture(obj, generated_only=False):
    if object_type(obj) != "Equipment" or getattr(obj, "IfcType", "") != LIGHT_FIXTURE:
        return False
    return not generated_only or getattr(obj, "Generator", "") == S.GENERATOR_TAG


def room_fixtures(space, generated_only=True):
    return [o for o in space.Group if is_fixture(o, generated_only)]


def fixture_room(obj):
    """The Space of a fixture: its Room link, else the Space whose Group holds it."""
    room = getattr(obj, "Room", None)
    if room is not None:
        return room
    for parent in obj.InList:
        if object_type(parent) == "Space" and obj in parent.Group:
            return parent
    return None


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
    draw_beam_axis(obj)


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
    if lum.extra.get("dimming_group"):       # its letter in the report's dimming plan
        p["DimmingGroup;;" + S.IFC_LUMINAIRE_PSET] = \
            f"IfcLabel;;{lum.extra['dimming_group']}"
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
    group = lum.extra.get("dimming_group")
    if group:                  # a design dimmed apart: the report's group letter
        obj.addProperty("App::PropertyString", "DimmingGroup", "Light",
                        "Dimming group of a design dimmed apart (the letter on the"
                        " report's plans and commissioning plan)")
        obj.DimmingGroup = str(group)
    props = dict(obj.IfcProperties)
    props.update(_ifc_properties(lum))
    obj.IfcProperties = props
    uid = new_guid()
    if uid:
        data = dict(obj.IfcData)
        data["IfcUID"] = uid
        obj.IfcData = data
    tilt = aimed_tilt(lum)
    if tilt is not None:
        add_aim_properties(obj, lum, tilt, aim_point_mm(space.Shape, lum))
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


def insert_fixtures(doc, per_room, label, replace=True, name="Insert luminaires",
                    requirements=None):
    """Luminaires -> Arch Equipment in their Space, as ONE undoable transaction (first
    removing invrad's earlier fixtures of these rooms with ``replace``); ``label(space, i,
    luminaire)`` names each; ``requirements`` (:func:`write_requirements`) are written in
    the same step. The new objects, in the order given; LuminaireError or SceneError with
    the document unchanged."""
    for space, lums in per_room:
        if not is_space(space):
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
                out.append(make_fixture(space, lum, label(space, i, lum)))
        if requirements:
            write_requirements(doc, requirements)
    return out


def fixture_luminaire(obj):
    """The Luminaire a fixture stands for (position, direction, flux, radius, score)."""
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
    extra = aim_extra(obj)
    if getattr(obj, "DimmingGroup", ""):      # a design's group letter, for the IFC
        extra["dimming_group"] = str(obj.DimmingGroup)
    return Luminaire(mm_to_m(pl.Base), n, flux,
                     mm_to_m(getattr(obj, "EmitterRadius", 0.0)),
                     score=float(getattr(obj, "Score", 0.0)) or None, c0=c0,
                     extra=extra)


# --------------------------------------------------------------------------- requirements
def write_requirements(doc, requirements, name="Lighting requirements"):
    """Write ``{space Name: (lux, achieved or None)}`` into each Arch Space's
    ``IfcProperties``, as one undo step (joins the caller's transaction); the rooms written."""
    n = 0
    with transaction(doc, name):
        for key, (lux, achieved) in requirements.items():
            space = doc.getObject(key)
            if space is None or not hasattr(space, "IfcProperties"):
                continue
            _set_space_properties(space, lux, achieved)
            n += 1
    return n


def _set_space_properties(space, lux, achieved):
    props = dict(space.IfcProperties)
    props[f"Illuminance;;{PSET_REQ_IFC4}"] = f"IfcIlluminanceMeasure;;{float(lux)!r}"
    props[f"ArtificialLighting;;{PSET_REQ_IFC4}"] = "IfcBoolean;;True"
    for key, value in (achieved or {}).items():
        if key in RESULT_PROPERTIES and value is not None and math.isfinite(float(value)):
            name, kind = RESULT_PROPERTIES[key]
            props[f"{name};;{PSET_RESULT}"] = f"{kind};;{float(value)!r}"
    space.IfcProperties = props
