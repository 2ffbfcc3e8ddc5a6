"""What the building says about a room's ceiling: where no luminaire may be mounted.

A room's scene is built from its IfcSpace (or Arch Space) solid alone, a box whose top is
the ceiling everywhere. The building knows better:

* a **slab opening** above the room (an ``IfcOpeningElement`` voiding the slab over it: a
  double-height void, a stairwell) means there is no ceiling there; only a pendant hung
  from the structure above may be there (FZK-Haus: the Wohnen's east half is open to the
  Galerie's roof);
* a **stair** (or ramp) standing in the room: nothing may be mounted over it (FZK-Haus's
  spiral stair in the Wohnen).

:func:`no_mount_zones` reads them, through ifcopenshell, from the IFC file the rooms come
from (the classic import's ``SourceIfc``, or the NativeIFC project's file) and from the
document's own stairs and ramps (Arch objects, e.g. an import with ``elements=True`` or a
model drawn in FreeCAD), and gives per room plain plan polygons (metres) that the core's
layouts honour (:class:`invrad_wb.core.model.scene.NoMountZone`). The core never sees
FreeCAD or IFC.
"""
import numpy as np

from invrad_wb.app.units import MM_PER_M

#: an opening in a slab counts for a room when its underside is this close above (or
#: below) the room's ceiling (metres): slabs sit on the ceiling, a finish may lie between
OPENING_ABOVE_M = (0.05, 0.6)
#: a stair counts for a room when it rises through at least this much of the room's
#: height (metres) and its plan outline reaches into the room
STAIR_OVERLAP_M = 0.3
#: IFC classes that stand in a room and carry nothing (their parts' geometry is read too)
STAIR_CLASSES = ("IfcStair", "IfcStairFlight", "IfcRamp", "IfcRampFlight")
#: Arch IfcType words of the same (document objects)
STAIR_KINDS = ("Stair", "Stair Flight", "Ramp", "Ramp Flight")
#: slab-like IFC classes whose openings leave no ceiling under them
SLAB_CLASSES = ("IfcSlab", "IfcRoof", "IfcCovering")

_CACHE = {}      # (id of the IFC file, its path or None) -> (file, elements)


def convex_hull(xy):
    """The convex hull of plan points (k, 2), counter-clockwise, (h, 2) (monotone chain)."""
    p = np.unique(np.round(np.asarray(xy, dtype=np.float64).reshape(-1, 2), 6), axis=0)
    if len(p) < 3:
        return p

    def half(points):
        out = []
        for q in points:
            while len(out) >= 2 and np.cross(out[-1] - out[-2], q - out[-2]) <= 0:
                out.pop()
            out.append(q)
        return out[:-1]
    return np.array(half(p) + half(p[::-1]))


def world_settings():
    """ifcopenshell geometry settings in world coordinates."""
    import ifcopenshell.geom
    settings = ifcopenshell.geom.settings()
    settings.set(settings.USE_WORLD_COORDS, True)
    return settings


def body_vertices(el, settings):
    """(k, 3) world vertices (metres) of an IFC element's body, or None without one."""
    import ifcopenshell.geom
    try:
        shape = ifcopenshell.geom.create_shape(settings, el)
    except Exception:              # no body representation (e.g. a stair of flights)
        return None
    # a copy while the shape lives: ifcopenshell 0.8's verts is a buffer into the shape,
    # freed with it (a view read the FZK opening as 1.7e-315..6.4e300 m in the FreeCAD
    # 1.0 root, and its zone landed over the Kueche)
    v = np.array(shape.geometry.verts, dtype=np.float64).reshape(-1, 3)
    return v if len(v) else None


def element_vertices(ifc, classes):
    """``[(class, element, (k, 3) world vertices in metres)]`` of an ifcopenshell file's
    elements of exactly ``classes`` (not their subtypes; a class the schema lacks is left
    out); elements without a body are left out."""
    settings = world_settings()
    out = []
    for cls in classes:
        try:
            elements = ifc.by_type(cls, include_subtypes=False)
        except Exception:          # a class this schema lacks
            continue
        for el in elements:
            v = body_vertices(el, settings)
            if v is not None:
                out.append((cls, el, v))
    return out


def ifc_elements(ifc):
    """``[(kind, words, (k, 3) vertices in metres)]`` of an ifcopenshell file:
    ``'opening'`` for each opening that voids a slab, roof or covering, ``'stair'`` for
    each stair, ramp or their flights (world coordinates; cached per file)."""
    key = id(ifc)
    got = _CACHE.get(key)
    if got is not None and got[0] is ifc:
        return got[1]
    settings = world_settings()
    out = []
    for rel in ifc.by_type("IfcRelVoidsElement"):
        host, opening = rel.RelatingBuildingElement, rel.RelatedOpeningElement
        if not any(host.is_a(c) for c in SLAB_CLASSES):
            continue
        v = body_vertices(opening, settings)
        if v is not None:
            out.append(("opening", f"opening in {host.is_a()[3:].lower()}"
                        f" {host.Name or '#%d' % host.id()}", v))
    out += [("stair", f"{cls[3:].lower()} {el.Name or '#%d' % el.id()}", v)
            for cls, el, v in element_vertices(ifc, STAIR_CLASSES)]
    _CACHE[key] = (ifc, out)
    return out


def _ifc_of(spaces, doc):
    """The ifcopenshell file the rooms come from (NativeIFC project or the classic
    import's SourceIfc), or None."""
    from invrad_wb.app.rooms import is_native
    for sp in spaces:
        if is_native(sp):
            try:
                from invrad_wb.app import nativeifc
                return nativeifc.ifcfile(sp)
            except Exception:
                return None
    if doc is None:
        return None
    try:
        import os
        path = next((p for p in (getattr(o, "SourceIfc", "") for o in doc.Objects)
                     if p and os.path.isfile(p)), None)     # ifcrooms' import remembers it
        if path is None:
            return None
        import ifcopenshell
        got = _CACHE.get(("path", path))
        if got is None:
            got = _CACHE[("path", path)] = ifcopenshell.open(path)
        return got
    except Exception:             # no ifcopenshell, an unreadable file: no zones from it
        return None


def _document_stairs(doc, spaces):
    """Stairs and ramps of the document (Arch objects) as ``('stair', words, (k, 3) m)``."""
    from invrad_wb.app.document import global_shape
    from invrad_wb.app.rooms import _ifc_kind, is_space
    out = []
    for obj in getattr(doc, "Objects", ()):
        if is_space(obj) or _ifc_kind(obj) not in STAIR_KINDS:
            continue
        shape = getattr(obj, "Shape", None)
        if shape is None or shape.isNull():
            continue
        try:
            shape = global_shape(obj)
            pts = [[v.Point.x, v.Point.y, v.Point.z] for v in shape.Vertexes]
            for e in shape.Edges:      # a curved stair's outline, not only its vertices
                pts += [[p.x, p.y, p.z] for p in e.discretize(Number=9)]
        except Exception:              # unreadable geometry: no zone
            continue
        if pts:
            out.append(("stair", f"stair {obj.Label}", np.asarray(pts) / MM_PER_M))
    return out


def _reaches_into(shape, hull, z):
    """Whether a plan polygon (metres) reaches into a room solid (mm) at height ``z`` (m):
    its centroid or a corner (pulled 5 cm towards the centroid) inside."""
    import FreeCAD
    c = hull.mean(axis=0)
    d = c - hull
    n = np.linalg.norm(d, axis=1, keepdims=True)
    pts = np.vstack([c[None], hull + 0.05 * d / np.maximum(n, 1e-9)])
    return any(shape.isInside(FreeCAD.Vector(x * MM_PER_M, y * MM_PER_M, z * MM_PER_M),
                              1.0, True) for x, y in pts)


def no_mount_zones(spaces, shapes, doc=None):
    """Per room (in the order of ``spaces``) a list of ``(polygon (k, 2) metres, words,
    pendants)``: the plan outlines of the slab openings over its ceiling (``pendants``
    True: no ceiling, a pendant may hang there) and of the stairs standing in it
    (``pendants`` False). ``shapes``: the rooms' solids (mm, :func:`rooms.room_shape`)."""
    elements = []
    ifc = _ifc_of(spaces, doc)
    if ifc is not None:
        try:
            elements += ifc_elements(ifc)
        except Exception:          # an IFC file whose geometry cannot be read: no zones
            pass
    if doc is not None:
        elements += _document_stairs(doc, spaces)
    out = [[] for _ in spaces]
    if not elements:
        return out
    hulls = [(kind, words, convex_hull(v[:, :2]), float(v[:, 2].min()),
              float(v[:, 2].max())) for kind, words, v in elements]
    for k, shape in enumerate(shapes):
        bb = shape.BoundBox
        lo, hi = bb.ZMin / MM_PER_M, bb.ZMax / MM_PER_M
        box = np.array([[bb.XMin, bb.YMin], [bb.XMax, bb.YMax]]) / MM_PER_M
        for kind, words, hull, z0, z1 in hulls:
            if len(hull) < 3 or np.any(hull.max(0) <= box[0]) or np.any(hull.min(0) >= box[1]):
                continue
            if kind == "opening":
                if not hi - OPENING_ABOVE_M[0] <= z0 <= hi + OPENING_ABOVE_M[1]:
                    continue
            elif min(z1, hi) - max(z0, lo) < STAIR_OVERLAP_M:
                continue
            z = 0.5 * (max(z0, lo) + min(z1, hi)) if kind == "stair" else 0.5 * (lo + hi)
            if _reaches_into(shape, hull, z):
                out[k].append((hull, words, kind == "opening"))
    return out
