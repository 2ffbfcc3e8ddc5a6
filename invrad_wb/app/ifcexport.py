"""IFC export of a lit document: fixtures as IfcLightFixture inside their IfcSpace.

Two ways, chosen by :func:`export_ifc`:

**Merge** (``base_ifc`` given, e.g. the file the document was imported from): the
architect's own IFC file is copied unchanged except that the light fixtures invrad wrote
before are removed, the document's fixtures are added as ``IfcLightFixture`` (a disk body,
placement with local -Z along the light direction, contained in their ``IfcSpace`` by
``IfcRelContainedInSpatialStructure``, property sets ``InvRad_Luminaire`` and
``Pset_LightFixtureTypeCommon``) and each room's work-plane illuminance is written to
``Pset_SpaceLightingRequirements.Illuminance``. Nothing else of the model is touched, which
is what a BIM round trip needs (walls, openings, properties stay as the author made them).

**FreeCAD** (no base file, e.g. a document modelled in FreeCAD): FreeCAD 0.20's own
exporter (``exportIFC.export``) writes the document. How it writes containment (read in
src/Mod/Arch/exportIFC.py, 0.20.2): every product found under a storey (BuildingPart
with IfcType "Building Storey", through ``Draft.get_group_contents``, which also walks a
Space's Group) is put into ONE ``IfcRelContainedInSpatialStructure`` of that storey
('StoreyLink'); spaces are aggregated to the storey (``IfcRelAggregates``); products
under no storey go to a default storey ('UnassignedObjectsLink'). It never relates an
element to an IfcSpace. So after FreeCAD has written the file, :func:`_fix_containment`
moves each fixture from its storey relation into its IfcSpace (found by the GlobalIds the
document keeps in ``IfcData['IfcUID']``, else by name). FreeCAD also writes a fixture (a
shape without base object) as a faceted BREP in world coordinates with an identity
placement, losing the light direction: the fixture gets the same placement and disk body
as in a merge. The flux is already there: FreeCAD exports ``IfcProperties`` as property
sets. Invrad's target objects are left out of the export.
"""
from dataclasses import dataclass, field
import math
import os
import tempfile

from invrad_wb.errors import SceneError
from invrad_wb.app import settings as S
from invrad_wb.app.document import activate, describe
from invrad_wb.app.fixtures import all_fixtures, fixture_luminaire, fixture_room
from invrad_wb.app.ifcdata import (  # noqa: F401 - ifcexport.add_body etc. as before
    PSET_REQ_IFC4, PSET_RESULT, RESULT_PROPERTIES, add_body, body_context, fixture_matrix,
    is_invrad_fixture, luminaire_psets, write_aim, write_requirement)
from invrad_wb.app.rooms import find_spaces, space_uid


@dataclass
class ExportInfo:
    path: str
    mode: str                  # 'merge' or 'freecad'
    fixtures: int = 0
    spaces_with_requirement: int = 0
    warnings: list = field(default_factory=list)


def _uid(obj):
    data = getattr(obj, "IfcData", None) or {}
    return str(data.get("IfcUID", "")) if hasattr(data, "get") else ""


def _is_internal(obj):
    """invrad's own bookkeeping objects, never exported: targets, their group and the
    metrics spreadsheet of Verify and report (FreeCAD's exporter would write a sheet
    as an IfcBuildingElementProxy)."""
    from invrad_wb.app.targets import is_target
    return is_target(obj) or (obj.TypeId == "App::DocumentObjectGroup"
                              and obj.Name.startswith("InvRadTargets")) \
        or (obj.TypeId == "Spreadsheet::Sheet" and obj.Name.startswith(S.SHEET_NAME))


def export_ifc(doc, path, base_ifc=None):
    """Write ``doc`` (its rooms and light fixtures) to an IFC file.

    Parameters
    ----------
    doc : FreeCAD document
    path : str
        Output .ifc file (written atomically: a failed export leaves no partial file).
    base_ifc : str, optional
        Merge into a copy of this IFC file instead of exporting the whole document with
        FreeCAD's exporter (see the module docstring). Defaults to the file the document
        was imported from (``SourceIfc`` of its building) if it still exists.

    Returns
    -------
    ExportInfo
    """
    if base_ifc is None:
        base_ifc = source_ifc(doc)
    folder = os.path.dirname(os.path.abspath(path)) or "."
    fd, tmp = tempfile.mkstemp(suffix=".ifc", dir=folder)
    os.close(fd)
    try:
        if base_ifc:
            info = _merge(doc, base_ifc, tmp)
        else:
            info = _freecad_export(doc, tmp)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)
    info.path = path
    return info


def source_ifc(doc):
    """The IFC file a document was imported from by :mod:`.ifcrooms`, if it exists."""
    for o in doc.Objects:
        p = getattr(o, "SourceIfc", "")
        if p and os.path.isfile(p):
            return p
    return None


# --------------------------------------------------------------------------- helpers
def _find_space(ifc, space):
    """The IfcSpace of a document Space: by GlobalId, else by unique Name/LongName."""
    uid = space_uid(space)
    if uid:
        try:
            return ifc.by_guid(uid)
        except RuntimeError:
            pass
    hits = [s for s in ifc.by_type("IfcSpace") if space.Label in (s.Name, s.LongName)]
    return hits[0] if len(hits) == 1 else None


def _set_requirements(ifc, doc, info):
    """Each room's WorkPlane lux -> the schema's lighting set (``Illuminance``,
    ``ArtificialLighting``: Pset_SpaceLightingRequirements in IFC2X3/IFC4,
    Pset_SpaceLightingDesign in IFC4.3) and the achieved values a run stored on the Space
    (``InvRad_LightingResult`` in its IfcProperties) -> the same set on the IfcSpace."""
    from invrad_wb.app.targets import work_plane_target
    for space in find_spaces(doc):
        wp = work_plane_target(space)
        if wp is None or not (math.isfinite(wp.Lux) and wp.Lux >= 0):
            continue
        ent = _find_space(ifc, space)
        if ent is None:
            info.warnings.append(f"room {describe(space)} has no IfcSpace in the file; its"
                                 " work-plane illuminance is not written")
            continue
        write_requirement(ifc, ent, float(wp.Lux), _stored_results(space))
        info.spaces_with_requirement += 1


def _stored_results(space):
    """The achieved values a run wrote into a Space's IfcProperties, as
    :func:`.nativeifc.write_requirement` takes them (None if there are none)."""
    props = getattr(space, "IfcProperties", None) or {}
    out = {}
    for key, (name, _) in RESULT_PROPERTIES.items():
        raw = props.get(f"{name};;{PSET_RESULT}") if hasattr(props, "get") else None
        try:
            out[key] = float(str(raw).split(";;")[-1])
        except (TypeError, ValueError):
            continue
    return out or None


# --------------------------------------------------------------------------- merge
def _merge(doc, base_ifc, out_path):
    import ifcopenshell
    import ifcopenshell.api.geometry as G
    import ifcopenshell.api.root as RT
    import ifcopenshell.api.spatial as SP
    import ifcopenshell.util.unit as U
    try:
        ifc = ifcopenshell.open(base_ifc)
    except Exception as exc:
        raise SceneError(f"cannot read the IFC file to merge into: {exc}", base_ifc)
    info = ExportInfo(out_path, "merge")
    for lf in list(ifc.by_type("IfcLightFixture")):
        if is_invrad_fixture(lf):
            RT.remove_product(ifc, product=lf)
    unit_scale = U.calculate_unit_scale(ifc)
    ctx = body_context(ifc)
    used = set()
    for fx in all_fixtures(doc, generated_only=False):
        space = fixture_room(fx)
        sp = _find_space(ifc, space) if space is not None else None
        if sp is None:
            info.warnings.append(f"fixture {describe(fx)}: its room"
                                 f" {describe(space)} is not an IfcSpace of {base_ifc};"
                                 " left out")
            continue
        lum = fixture_luminaire(fx)
        ent = RT.create_entity(ifc, ifc_class="IfcLightFixture", name=fx.Label,
                               predefined_type="POINTSOURCE")
        uid = _uid(fx)
        if uid and uid not in used:
            try:
                ifc.by_guid(uid)
            except RuntimeError:
                ent.GlobalId = uid
        used.add(ent.GlobalId)
        ent.Description = getattr(fx, "Description", None) or None
        SP.assign_container(ifc, products=[ent], relating_structure=sp)
        G.edit_object_placement(ifc, product=ent, matrix=fixture_matrix(lum), is_si=True)
        add_body(ifc, ent, lum, ctx, unit_scale)
        luminaire_psets(ifc, ent, lum, kind=getattr(fx, "Model", "") or None)
        info.fixtures += 1
    _set_requirements(ifc, doc, info)
    ifc.write(out_path)
    return info


# --------------------------------------------------------------------------- FreeCAD
def _exporter():
    """FreeCAD's IFC exporter module: ``exportIFC`` (Arch, 0.20) or
    ``importers.exportIFC`` (the BIM workbench, 1.x)."""
    try:
        import exportIFC
    except ImportError:
        from importers import exportIFC
    return exportIFC


def _freecad_export(doc, out_path):
    exportIFC = _exporter()
    import ifcopenshell
    from invrad_wb.app.document import transaction
    objs = [o for o in doc.Objects if not _is_internal(o)]
    if not objs:
        raise SceneError("nothing to export", doc.Label)
    activate(doc)
    # FreeCAD 0.20 quirk: getPreferences() reads the module global 'ifcopenshell' that only
    # export() itself imports; calling it first raises NameError
    exportIFC.ifcopenshell = ifcopenshell
    prefs = exportIFC.getPreferences()
    # FreeCAD may store new GlobalIds in the objects (preference ifcStoreUid): one undo step
    with transaction(doc, "Export IFC"):
        exportIFC.export(objs, out_path, preferences=prefs)
    if not os.path.isfile(out_path) or os.path.getsize(out_path) == 0:
        raise SceneError("FreeCAD's IFC exporter wrote nothing (see the report view)",
                         doc.Label)
    info = ExportInfo(out_path, "freecad")
    ifc = ifcopenshell.open(out_path)
    _fix_containment(ifc, doc, info)
    _set_requirements(ifc, doc, info)
    ifc.write(out_path)
    return info


def _fix_containment(ifc, doc, info):
    """Move each exported light fixture from its storey into its IfcSpace."""
    import ifcopenshell.api.spatial as SP
    import ifcopenshell.util.unit as U
    unit_scale = U.calculate_unit_scale(ifc)
    by_name = {}
    for e in ifc.by_type("IfcLightFixture"):
        by_name.setdefault(e.Name, []).append(e)
    for fx in all_fixtures(doc, generated_only=False):
        ent = None
        uid = _uid(fx)
        if uid:
            try:
                ent = ifc.by_guid(uid)
            except RuntimeError:
                ent = None
        if ent is None and len(by_name.get(fx.Label, [])) == 1:
            ent = by_name[fx.Label][0]
        if ent is None:
            info.warnings.append(f"fixture {describe(fx)} is not in the exported file")
            continue
        space = fixture_room(fx)
        sp = _find_space(ifc, space) if space is not None else None
        if sp is None:
            info.warnings.append(f"fixture {describe(fx)}: room {describe(space)} is not in"
                                 " the exported file; left in its storey")
            continue
        SP.assign_container(ifc, products=[ent], relating_structure=sp)
        _restore_orientation(ifc, ent, fixture_luminaire(fx), unit_scale)
        info.fixtures += 1


def _restore_orientation(ifc, ent, lum, unit_scale):
    """FreeCAD 0.20 writes a fixture (a shape without base object) as a faceted BREP in
    world coordinates with an identity placement, which loses the light direction; give it
    the luminaire's placement (local -Z = light direction) and a swept-disk body instead."""
    import ifcopenshell.api.geometry as G
    if ent.Representation is not None:
        for rep in list(ent.Representation.Representations):
            G.unassign_representation(ifc, product=ent, representation=rep)
            G.remove_representation(ifc, representation=rep)
    G.edit_object_placement(ifc, product=ent, matrix=fixture_matrix(lum), is_si=True)
    add_body(ifc, ent, lum, body_context(ifc), unit_scale)
    write_aim(ifc, ent, lum)            # an aimed spot's tilt and pan in invrad's set


# --------------------------------------------------------------------------- requirements
def requirements_of_run(building, summary):
    """Each room's work-plane requirement and what a run achieved, for the IFC lighting
    set: ``{space Name: (required lux, {"Em", "Emin", "U0", "Watts"})}`` (rooms with a
    work plane only). A design's own figures (exact EN 12464 metrics) are used where
    there are some (with task areas given: the area furthest below its own requirement,
    and that requirement), else the verification's work-plane mean and minimum."""
    design = {r.get("room"): r for r in (summary.get("design") or {}).get("rooms", [])}
    stats = {r["space"]: r for r in summary.get("rooms", [])}
    out = {}
    for p in building.rooms:
        if p.work_plane is None:
            continue
        d = design.get(p.room_id)
        required = float(p.work_plane.lux)
        if d is not None and d.get("task_areas"):
            # task areas given: each is judged on its own; the space carries the one
            # furthest below its own requirement (its Em against its lux, U0 likewise)
            worst = min(d["task_areas"], key=lambda a: min(
                a["em_lux"] / max(a["required"]["lux"], 1e-9),
                a["u0"] / max(a["required"]["u0"], 1e-9)))
            required = float(worst["required"]["lux"])
            achieved = {"Em": worst["em_lux"], "Emin": worst.get("emin_lux"),
                        "U0": worst.get("u0"), "Watts": d.get("watts")}
        elif d is not None and "em_lux" in d:
            achieved = {"Em": d["em_lux"], "Emin": d.get("emin_lux"), "U0": d.get("u0"),
                        "Watts": d.get("watts")}
        else:
            wp = (stats.get(p.space.Name) or {}).get("work_plane") or {}
            em, emin = wp.get("mean_achieved_lux"), wp.get("min_achieved_lux")
            achieved = {"Em": em, "Emin": emin,
                        "U0": (emin / em) if em and emin is not None else None}
        out[p.space.Name] = (required, achieved)
    return out
