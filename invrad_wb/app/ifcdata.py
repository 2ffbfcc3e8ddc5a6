"""invrad's data in IFC files, through ifcopenshell (no FreeCAD document logic): what both
document backends, the classic IFC import and the IFC export share.

* **Requirements**: the lighting requirement property set of an IfcSpace
  (``Pset_SpaceLightingRequirements`` in IFC2X3/IFC4, ``Pset_SpaceLightingDesign`` in
  IFC4.3: ``Illuminance``, ``ArtificialLighting``) and invrad's achieved values
  (``InvRad_LightingResult``, :data:`RESULT_PROPERTIES`).
* **Fixtures**: an IfcLightFixture's property sets, placement and ``Body``; the Luminaire
  of a fixture invrad wrote.
* **Shapes**: IfcSpace geometry as a closed Part solid (world coordinates, mm).
"""
import math
import os

import numpy as np

from invrad_wb.app import settings as S
from invrad_wb.app.fixturebody import aimed_pan, aimed_tilt, fixture_axes, fixture_size
from invrad_wb.app.units import MM_PER_M

#: the lighting requirement property set: IFC4 name, IFC4.3 name (same properties:
#: ArtificialLighting IfcBoolean, Illuminance IfcIlluminanceMeasure; buildingSMART's
#: templates as shipped with ifcopenshell.util.pset)
PSET_REQ_IFC4 = "Pset_SpaceLightingRequirements"
PSET_REQ_IFC4X3 = "Pset_SpaceLightingDesign"
#: invrad's own results on an IfcSpace (the standard sets have no achieved values)
PSET_RESULT = "InvRad_LightingResult"
#: achieved values -> (property of :data:`PSET_RESULT`, its IFC measure type)
RESULT_PROPERTIES = {"Em": ("AchievedEm", "IfcIlluminanceMeasure"),
                     "Emin": ("AchievedEmin", "IfcIlluminanceMeasure"),
                     "U0": ("AchievedU0", "IfcRatioMeasure"),
                     "Watts": ("InstalledPower", "IfcPowerMeasure")}


def requirement_pset_name(ifc):
    """The schema's lighting requirement set: Pset_SpaceLightingDesign in IFC4.3,
    Pset_SpaceLightingRequirements before."""
    schema = str(getattr(ifc, "schema", "") or "").upper()
    return PSET_REQ_IFC4X3 if schema.startswith("IFC4X3") else PSET_REQ_IFC4


def read_requirement(ent):
    """Required illuminance (lux) of an IfcSpace from either lighting set, or None."""
    if ent is None:
        return None
    import ifcopenshell.util.element as E
    psets = E.get_psets(ent)
    for name in (PSET_REQ_IFC4X3, PSET_REQ_IFC4):
        value = (psets.get(name) or {}).get("Illuminance")
        try:
            value = float(value)
        except (TypeError, ValueError):
            continue
        if math.isfinite(value) and value >= 0:
            return value
    return None


def write_requirement(ifc, ent, lux, achieved=None):
    """Write a space's required illuminance (and, in invrad's own set, what was achieved).

    Parameters
    ----------
    ifc : ifcopenshell file
    ent : IfcSpace
    lux : float, required work-plane illuminance (lx)
    achieved : dict, optional
        ``{"Em": lx, "Emin": lx, "U0": ratio, "Watts": W}`` (any subset) ->
        ``InvRad_LightingResult`` (the standard sets have no achieved values).
    """
    import ifcopenshell.api.pset as PS
    import ifcopenshell.util.element as E
    name = requirement_pset_name(ifc)
    psets = E.get_psets(ent, psets_only=True)
    if name in psets:
        pset = ifc.by_id(psets[name]["id"])
    else:
        pset = PS.add_pset(ifc, product=ent, name=name)
    PS.edit_pset(ifc, pset=pset, properties={
        "Illuminance": ifc.create_entity("IfcIlluminanceMeasure", float(lux)),
        "ArtificialLighting": True})
    if achieved:
        props = {RESULT_PROPERTIES[k][0]: ifc.create_entity(RESULT_PROPERTIES[k][1], float(v))
                 for k, v in achieved.items() if k in RESULT_PROPERTIES and v is not None
                 and math.isfinite(float(v))}
        if props:
            psets = E.get_psets(ent, psets_only=True)
            if PSET_RESULT in psets:
                rp = ifc.by_id(psets[PSET_RESULT]["id"])
            else:
                rp = PS.add_pset(ifc, product=ent, name=PSET_RESULT)
            PS.edit_pset(ifc, pset=rp, properties=props)


def geometry_settings():
    """ifcopenshell geometry settings: world coordinates, BREP output (0.7 and 0.8+ APIs)."""
    import ifcopenshell.geom
    s = ifcopenshell.geom.settings()
    try:
        import ifcopenshell.ifcopenshell_wrapper as W
        s.set("use-world-coords", True)
        s.set("iterator-output", W.SERIALIZED)
    except Exception:                       # ifcopenshell 0.7
        s.set(s.USE_WORLD_COORDS, True)
        s.set(s.USE_BREP_DATA, True)
    return s


def brep_to_shape(brep, scale=MM_PER_M):
    """A BREP string (metres) -> Part shape in mm."""
    import Part
    shape = Part.Shape()
    shape.importBrepFromString(brep)
    if scale != 1.0:
        shape.scale(scale)
    return shape


def closed_solid(shape):
    """Faces -> one closed solid (sewn, outward, coplanar splits removed), or None.

    Returns ``(solid or None, free_edge_count)``.
    """
    import Part
    if shape.isNull() or not shape.Faces:
        return None, 0
    if shape.Solids and all(sh.isClosed() for so in shape.Solids for sh in so.Shells):
        solid = shape.Solids[0] if len(shape.Solids) == 1 else shape
    else:
        shell = Part.Shell(shape.Faces)
        if not shell.isClosed():
            shell.sewShape()
        if not shell.isClosed():
            free = sum(1 for e in shell.Edges
                       if len(shell.ancestorsOfType(e, Part.Face)) < 2)
            return None, free
        solid = Part.Solid(shell)
        if solid.Volume < 0:
            solid.reverse()
    try:
        cleaned = solid.removeSplitter()
        if cleaned.isValid() and abs(cleaned.Volume - solid.Volume) <= 1e-6 * abs(solid.Volume):
            solid = cleaned
    except Exception:
        pass
    return solid, 0


def invrad_fixture_data(entity, unit_scale, ifc=None):
    """A Luminaire from an IfcLightFixture written by invrad, or None if it is not one:
    position and light direction (local -Z) from its placement, an aimed one's C0 axis
    (local X) and its tilt and pan (``extra``, :func:`read_aim`; ``ifc``, the entity's
    file, gives their angle unit)."""
    import ifcopenshell.util.element as E
    import ifcopenshell.util.placement as P
    from invrad_wb.core.model.luminaires import Luminaire
    pset = E.get_psets(entity).get(S.IFC_LUMINAIRE_PSET)
    if not pset or entity.ObjectPlacement is None:
        return None
    try:
        flux = float(pset.get("LuminousFlux"))
    except (TypeError, ValueError):
        return None
    if not (math.isfinite(flux) and flux > 0):
        return None
    m = np.asarray(P.get_local_placement(entity.ObjectPlacement), dtype=np.float64)
    pos = m[:3, 3] * unit_scale
    normal = -m[:3, 2] / np.linalg.norm(m[:3, 2])
    # an aimed luminaire's C0 axis (local X) differs from its normal's own frame
    c0 = m[:3, 0] / np.linalg.norm(m[:3, 0])
    if np.allclose(c0, fixture_axes(normal)[0], atol=1e-6):
        c0 = None
    radius = float(pset.get("EmitterRadius") or 0.0)
    score = pset.get("Score")
    return Luminaire(pos, normal, flux, radius, score=float(score) if score else None,
                     c0=c0, extra=read_aim(ifc, pset))


def _degrees_per_angle_unit(ifc):
    """Degrees per unit of the file's plane angle unit (its ``PLANEANGLEUNIT``; radians,
    IFC's default, where it names none)."""
    import ifcopenshell.util.unit as U
    try:
        scale = float(U.calculate_unit_scale(ifc, "PLANEANGLEUNIT"))
    except Exception:          # no unit assignment, an ifcopenshell without angle units
        scale = 1.0
    k = math.degrees(scale if math.isfinite(scale) and scale > 0 else 1.0)
    return 1.0 if abs(k - 1.0) < 1e-9 else k      # a DEGREE unit's pi/180 round-off


def aim_properties(ifc, lum, always=False):
    """An aimed luminaire's ``Tilt`` and ``Pan`` (``IfcPlaneAngleMeasure`` in the file's
    plane angle unit) for invrad's property set, or {} for one facing along its mounting
    normal (unless ``always``: then its own figures, however small, 0 when it has none).
    Its placement carries the aim itself (local -Z along the light)."""
    tilt = aimed_tilt(lum)
    if tilt is None:
        if not always:
            return {}
        t = lum.extra.get("tilt_deg")
        tilt = float(t) if isinstance(t, (int, float)) and math.isfinite(t) else 0.0
    k = _degrees_per_angle_unit(ifc)
    return {"Tilt": ifc.create_entity("IfcPlaneAngleMeasure", tilt / k),
            "Pan": ifc.create_entity("IfcPlaneAngleMeasure", aimed_pan(lum) / k)}


def write_aim(ifc, ent, lum):
    """Add an aimed luminaire's tilt and pan (:func:`aim_properties`) to the invrad
    property set of the IfcLightFixture ``ent`` (made when missing); False when it is not
    aimed and its set holds no aim. A fixture that was aimed and is now turned back to its
    mounting normal (tilt below the aimed threshold) gets its own small tilt written, so
    that the set never keeps the old one."""
    import ifcopenshell.api.pset as PS
    import ifcopenshell.util.element as E
    pset = E.get_psets(ent).get(S.IFC_LUMINAIRE_PSET) or {}
    props = aim_properties(ifc, lum, always=pset.get("Tilt") is not None)
    if not props:
        return False
    pid = pset.get("id")
    p = ifc.by_id(pid) if pid else PS.add_pset(ifc, product=ent, name=S.IFC_LUMINAIRE_PSET)
    PS.edit_pset(ifc, pset=p, properties=props)
    return True


def read_aim(ifc, pset):
    """``{"tilt_deg", "pan_deg"}`` from invrad's property set (as ``get_psets`` gives it)
    of an aimed fixture, or {}."""
    try:
        tilt = float(pset.get("Tilt"))
        pan = float(pset.get("Pan") or 0.0)
    except (TypeError, ValueError):
        return {}
    k = _degrees_per_angle_unit(ifc) if ifc is not None else math.degrees(1.0)
    tilt, pan = tilt * k, (pan * k) % 360.0
    if not (math.isfinite(tilt) and math.isfinite(pan)):
        return {}
    return {"tilt_deg": tilt, "pan_deg": pan}


def luminaire_psets(ifc, ent, lum, kind=None):
    """invrad's property set (flux, emitter radius, vote score, catalogue type, photometry
    file) and ``Pset_LightFixtureTypeCommon`` on the IfcLightFixture ``ent``, through
    ``ifcopenshell.api`` (classic export and NativeIFC documents alike). ``kind``: the
    catalogue type (default: the luminaire's ``extra['type']``)."""
    import ifcopenshell.api.pset as PS
    props = {"LuminousFlux": ifc.create_entity("IfcLuminousFluxMeasure", float(lum.flux_lm)),
             "Generator": ifc.create_entity("IfcLabel", S.GENERATOR_TAG)}
    if lum.radius_m > 0:
        props["EmitterRadius"] = ifc.create_entity("IfcLengthMeasure", float(lum.radius_m))
    if lum.score is not None and math.isfinite(lum.score) and lum.score > 0:
        props["Score"] = ifc.create_entity("IfcReal", float(lum.score))
    kind = kind or lum.extra.get("type")
    if kind:       # the catalogue entry a design chose
        props["LuminaireType"] = ifc.create_entity("IfcLabel", str(kind))
    if lum.extra.get("dimming_group"):       # its letter in the report's dimming plan
        props["DimmingGroup"] = ifc.create_entity("IfcLabel", str(lum.extra["dimming_group"]))
    path = getattr(lum.photometry, "path", None)
    if path:
        props["PhotometryFile"] = ifc.create_entity("IfcText", os.fspath(path))
    props.update(aim_properties(ifc, lum))
    p = PS.add_pset(ifc, product=ent, name=S.IFC_LUMINAIRE_PSET)
    PS.edit_pset(ifc, pset=p, properties=props)
    common = {"NumberOfSources": 1}
    if kind:
        common["Reference"] = str(kind)
    p = PS.add_pset(ifc, product=ent, name="Pset_LightFixtureTypeCommon")
    PS.edit_pset(ifc, pset=p, properties=common)


def body_context(ifc):
    import ifcopenshell.api.context as CX
    import ifcopenshell.util.representation as R
    ctx = R.get_context(ifc, "Model", "Body", "MODEL_VIEW")
    if ctx is None:
        model = R.get_context(ifc, "Model") or CX.add_context(ifc, context_type="Model")
        ctx = CX.add_context(ifc, context_type="Model", context_identifier="Body",
                             target_view="MODEL_VIEW", parent=model)
    return ctx


def fixture_matrix(lum):
    """4x4 placement (metres): origin at the luminaire, local -Z along its normal, local X
    its C0 axis (:func:`invrad_wb.app.fixtures.fixture_axes`, as the FreeCAD fixture)."""
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2] = fixture_axes(lum.normal, getattr(lum, "c0", None))
    m[:3, 3] = lum.position
    return m


def add_body(ifc, ent, lum, ctx, unit_scale):
    """The fixture's ``Body``: its disc or panel (:func:`invrad_wb.app.fixtures.
    fixture_size`, the FreeCAD fixture's plan) extruded along local -Z."""
    size = fixture_size(lum)
    t = S.FIXTURE_THICKNESS_M / unit_scale
    if size[0] == "panel":
        prof = ifc.create_entity("IfcRectangleProfileDef", ProfileType="AREA",
                                 XDim=size[1] / unit_scale, YDim=size[2] / unit_scale)
    else:
        prof = ifc.create_entity("IfcCircleProfileDef", ProfileType="AREA",
                                 Radius=size[1] / unit_scale)
    pos = ifc.create_entity("IfcAxis2Placement3D",
                            Location=ifc.create_entity("IfcCartesianPoint", (0.0, 0.0, 0.0)))
    solid = ifc.create_entity("IfcExtrudedAreaSolid", SweptArea=prof, Position=pos,
                              ExtrudedDirection=ifc.create_entity("IfcDirection",
                                                                  (0.0, 0.0, -1.0)),
                              Depth=t)
    rep = ifc.create_entity("IfcShapeRepresentation", ContextOfItems=ctx,
                            RepresentationIdentifier="Body", RepresentationType="SweptSolid",
                            Items=[solid])
    ent.Representation = ifc.create_entity("IfcProductDefinitionShape", Representations=[rep])


def is_invrad_fixture(entity):
    import ifcopenshell.util.element as E
    return S.IFC_LUMINAIRE_PSET in E.get_psets(entity)


def _is_invrad_entity(ent):
    import ifcopenshell.util.element as E
    pset = E.get_psets(ent).get(S.IFC_LUMINAIRE_PSET) or {}
    return pset.get("Generator") == S.GENERATOR_TAG
