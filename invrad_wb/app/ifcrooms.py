"""IFC -> FreeCAD document with ifcopenshell: IfcSpaces become Arch Spaces.

Why our own importer and not FreeCAD's ``importIFC``: FreeCAD 0.20's importer calls
``ifcopenshell.geom.settings().USE_BREP_DATA``, which ifcopenshell 0.8+ removed, so with
the ifcopenshell 0.9 this project needs it fails before reading a single entity
(AttributeError). Invrad also needs much less than a full import: the spatial structure
(building, storeys), each IfcSpace's closed solid, its name, GlobalId and lighting
requirement. ifcopenshell gives each space's geometry in world coordinates as an
OpenCASCADE BREP string that FreeCAD's Part reads directly (``importBrepFromString``);
faces are sewn into a closed shell, made a solid and cleaned of coplanar splits
(``removeSplitter``), so each wall of a room is one face ``FaceN``.

What is created (one undoable transaction):

* an Arch BuildingPart per IfcBuilding (IfcType "Building") and per IfcBuildingStorey
  (IfcType "Building Storey"), with the IFC GlobalId in ``IfcData['IfcUID']``;
* per IfcSpace: a hidden Part::Feature with its solid and an Arch Space based on it,
  labelled with the space's LongName (else Name), inside its storey, GlobalId kept;
* ``Pset_SpaceLightingRequirements.Illuminance`` (``Pset_SpaceLightingDesign`` in IFC4.3)
  -> a WorkPlane target (0.75 m);
* light fixtures that a previous invrad run wrote (property set ``InvRad_Luminaire``)
  -> Equipment "Light Fixture" in their Space again, so a round trip keeps them;
* optionally (``elements=True``) walls, slabs, windows... as Arch Components for context.

Units: the IFC file's length unit is converted to metres by ifcopenshell's geometry
(and :func:`ifcopenshell.util.unit.calculate_unit_scale` for placements), then to mm.
"""
from dataclasses import dataclass, field
import os
import time

from invrad_wb.errors import Cancelled, SceneError
from invrad_wb.app.document import activate, transaction
from invrad_wb.app.ifcdata import (  # noqa: F401 - ifcrooms.geometry_settings etc. as before
    brep_to_shape, closed_solid, geometry_settings, invrad_fixture_data, read_requirement)


@dataclass
class IfcImport:
    """What :func:`import_ifc` made."""
    doc: object
    path: str
    spaces: list
    storeys: dict
    buildings: list
    fixtures: list = field(default_factory=list)
    elements: list = field(default_factory=list)
    warnings: list = field(default_factory=list)
    seconds: float = 0.0


def _open(path):
    try:
        import ifcopenshell
    except ImportError as exc:
        raise SceneError(f"cannot read IFC: ifcopenshell is not installed ({exc})", path)
    if not os.path.isfile(path):
        raise SceneError("file does not exist", path)
    try:
        return ifcopenshell.open(path)
    except Exception as exc:
        raise SceneError(f"not a readable IFC file: {exc}", path)


def _ifc_type_name(entity):
    """'IfcWallStandardCase' -> 'Wall' (an Arch IfcType), else 'Building Element Proxy'."""
    import re
    import ArchIFC
    name = entity.is_a()[3:].replace("StandardCase", "").replace("ElementedCase", "")
    words = " ".join(re.findall(r"[A-Z][a-z0-9]*", name))
    return words if words in ArchIFC.IfcTypes else "Building Element Proxy"


def _set_uid(obj, guid):
    data = dict(obj.IfcData) if hasattr(obj, "IfcData") else None
    if data is not None:
        data["IfcUID"] = guid
        obj.IfcData = data


def _storey_of(entity):
    """The IfcBuildingStorey (or None) an element/space belongs to, through spaces too."""
    import ifcopenshell.util.element as E
    seen = 0
    cur = entity
    while cur is not None and seen < 16:
        if cur.is_a("IfcBuildingStorey"):
            return cur
        parent = E.get_container(cur) or E.get_aggregate(cur)
        cur = parent
        seen += 1
    return None


def required_illuminance(entity):
    """Required illuminance (lux) of an IfcSpace, or None: ``Illuminance`` of
    ``Pset_SpaceLightingRequirements`` (IFC2X3/IFC4) or ``Pset_SpaceLightingDesign``
    (its IFC4.3 name)."""
    return read_requirement(entity)


def import_ifc(path, doc=None, elements=False, progress=None):
    """Read an IFC file into a FreeCAD document (new, or ``doc``) as one transaction.

    Parameters
    ----------
    path : str
    doc : FreeCAD document, optional (a new one named after the file by default)
    elements : bool
        Also import building elements (walls, slabs, windows...) as Arch Components.
    progress : callable(fraction, message) -> bool, optional
        Return False to cancel (raises :class:`~invrad_wb.errors.Cancelled`; the document
        is left as it was).

    Returns
    -------
    IfcImport

    Raises
    ------
    SceneError
        Unreadable file, or a file without IfcSpace.
    """
    import FreeCAD
    t0 = time.perf_counter()
    path = os.path.abspath(path)
    ifc = _open(path)
    spaces_ifc = ifc.by_type("IfcSpace")
    if not spaces_ifc:
        raise SceneError("the file has no rooms (IfcSpace)", path)
    if doc is None:
        name = "".join(c if c.isalnum() else "_" for c in os.path.splitext(
            os.path.basename(path))[0]) or "Imported"
        doc = FreeCAD.newDocument(name)
        doc.Label = os.path.splitext(os.path.basename(path))[0]
    activate(doc)

    def report(frac, msg):
        if progress is not None and progress(frac, msg) is False:
            raise Cancelled(f"IFC import of {path} cancelled")

    settings = geometry_settings()
    result = IfcImport(doc=doc, path=path, spaces=[], storeys={}, buildings=[])
    with transaction(doc, f"Import {os.path.basename(path)}"):
        report(0.0, "spatial structure")
        _import_structure(ifc, path, result)
        by_guid = {}
        for k, sp in enumerate(spaces_ifc):
            report(0.05 + 0.75 * k / len(spaces_ifc), f"room {sp.LongName or sp.Name}")
            by_guid[sp.GlobalId] = _import_space(sp, doc, settings, result)
        doc.recompute()
        report(0.8, "lighting requirements")
        _import_lighting(ifc, spaces_ifc, by_guid, result)
        if elements:
            result.elements = _import_elements(ifc, doc, settings, result, report)
        report(1.0, "done")
    result.seconds = time.perf_counter() - t0
    for w in result.warnings:
        FreeCAD.Console.PrintWarning(f"invrad: {w}\n")
    return result


def _import_structure(ifc, path, result):
    """IfcBuilding / IfcBuildingStorey -> Arch BuildingParts in ``result`` (storeys nested
    in their building; the first building remembers the source file)."""
    import Arch
    import ifcopenshell.util.element as E
    buildings = {}
    for b in ifc.by_type("IfcBuilding"):
        bp = Arch.makeBuildingPart()
        bp.IfcType = "Building"
        bp.Label = b.Name or "Building"
        _set_uid(bp, b.GlobalId)
        buildings[b.id()] = bp
        result.buildings.append(bp)
    for st in sorted(ifc.by_type("IfcBuildingStorey"), key=lambda s: s.Elevation or 0.0):
        bp = Arch.makeBuildingPart()
        bp.IfcType = "Building Storey"
        bp.Label = st.Name or "Storey"
        _set_uid(bp, st.GlobalId)
        result.storeys[st.GlobalId] = bp
        parent = E.get_aggregate(st)
        if parent is not None and parent.id() in buildings:
            buildings[parent.id()].addObject(bp)
    if result.buildings:
        b0 = result.buildings[0]
        b0.addProperty("App::PropertyFile", "SourceIfc", "InvRad",
                       "IFC file this document was imported from")
        b0.SourceIfc = path


def _import_space(sp, doc, settings, result):
    """One IfcSpace -> an Arch Space on a closed solid (warnings in ``result`` when it has
    no geometry or an open one), placed in its storey. Returns the Space."""
    import Arch
    import FreeCAD
    import ifcopenshell.geom
    label = sp.LongName or sp.Name or f"Space {sp.id()}"
    solid, free = None, 0
    try:
        shp = ifcopenshell.geom.create_shape(settings, sp)
        solid, free = closed_solid(brep_to_shape(shp.geometry.brep_data))
    except Exception as exc:
        result.warnings.append(f"IfcSpace {label!r} (#{sp.id()}): no geometry ({exc})")
        shape_for_base = None
    else:
        shape_for_base = solid
        if solid is None:
            result.warnings.append(f"IfcSpace {label!r} (#{sp.id()}): open surface"
                                   f" ({free} free edges), not a closed solid")
            shape_for_base = brep_to_shape(shp.geometry.brep_data)
    base = None
    if shape_for_base is not None:
        base = doc.addObject("Part::Feature", "SpaceSolid")
        base.Label = f"{label} solid"
        base.Shape = shape_for_base
        if FreeCAD.GuiUp:
            base.ViewObject.hide()
    space = Arch.makeSpace(baseobj=base) if base is not None else Arch.makeSpace()
    space.Label = label
    if sp.Name and sp.LongName:
        space.Description = f"IFC space {sp.Name}"
    _set_uid(space, sp.GlobalId)
    storey = _storey_of(sp)
    if storey is not None and storey.GlobalId in result.storeys:
        result.storeys[storey.GlobalId].addObject(space)
    result.spaces.append(space)
    return space


def _import_lighting(ifc, spaces_ifc, by_guid, result):
    """Required illuminance of the spaces -> work-plane targets; invrad's own light
    fixtures (written by an earlier export) -> fixtures in their Space."""
    import ifcopenshell.util.element as E
    import ifcopenshell.util.unit as U
    from invrad_wb.app import fixtures as FX
    from invrad_wb.app import targets as TG
    unit_scale = U.calculate_unit_scale(ifc)
    for sp in spaces_ifc:
        lux = required_illuminance(sp)
        if lux is not None:
            TG.set_work_plane(by_guid[sp.GlobalId], lux)
    for lf in ifc.by_type("IfcLightFixture"):
        lum = invrad_fixture_data(lf, unit_scale, ifc)
        if lum is None:
            continue
        container = E.get_container(lf)
        space = by_guid.get(container.GlobalId) if container is not None else None
        if space is None:
            result.warnings.append(f"invrad light fixture {lf.Name!r} is not in a room;"
                                   " left out")
            continue
        fx = FX.make_fixture(space, lum, lf.Name or f"Luminaire {space.Label}")
        _set_uid(fx, lf.GlobalId)
        result.fixtures.append(fx)

def _import_elements(ifc, doc, settings, result, report):
    """Walls, slabs, windows... as Arch Components (for context; not used for lighting)."""
    import Arch
    import ifcopenshell.geom
    skip = ("IfcOpeningElement", "IfcVirtualElement", "IfcSpace", "IfcLightFixture")
    todo = [e for e in ifc.by_type("IfcElement") if not any(e.is_a(s) for s in skip)]
    out = []
    for k, e in enumerate(todo):
        if k % 10 == 0:
            report(0.85 + 0.15 * k / max(1, len(todo)), f"element {k + 1}/{len(todo)}")
        try:
            shp = ifcopenshell.geom.create_shape(settings, e)
            shape = brep_to_shape(shp.geometry.brep_data)
        except Exception as exc:
            result.warnings.append(f"{e.is_a()} {e.Name!r}: no geometry ({exc})")
            continue
        base = doc.addObject("Part::Feature", "ElementShape")
        base.Shape = shape
        comp = Arch.makeComponent(base)
        comp.IfcType = _ifc_type_name(e)
        comp.Label = e.Name or e.is_a()
        _set_uid(comp, e.GlobalId)
        storey = _storey_of(e)
        if storey is not None and storey.GlobalId in result.storeys:
            result.storeys[storey.GlobalId].addObject(comp)
        out.append(comp)
    return out
