"""Lighting targets stored in a FreeCAD document.

Storage: one ``App::FeaturePython`` object per target ("InvRadTarget"), with a proxy class
:class:`TargetProxy` that lives here and imports nothing of the GUI, so a saved document
re-opens with its targets in ``freecadcmd`` as well as in the GUI. Why objects and not
properties on the Space:

* a room has any number of targets of different kinds (a desk, a spot, a dark wall...):
  one object each, with typed ``App::Property*`` values, is editable in the property view,
  selectable, deletable and undoable one by one; a Space would need parallel lists;
* faces are ``App::PropertyLinkSubList`` references ``(Space, ['Face3', ...])``, which is
  exactly what a GUI selection gives, and FreeCAD keeps the dependency on the Space;
* the Space (a BIM object exported to IFC) stays untouched: targets are design intent,
  not building data. All targets sit in one document group ("Lighting targets") outside
  the building hierarchy, so FreeCAD's IFC exporter never sees them.

The exception is the room's required work-plane illuminance, which IFC does have
(``Pset_SpaceLightingRequirements.Illuminance``): the IFC importer turns it into a
"WorkPlane" target and the IFC export writes the WorkPlane target's lux back there.

Kinds and the properties they use (lengths are FreeCAD lengths, i.e. mm in the document;
positions are global):

==========  ===================================================================
Uniform     Faces, Lux
Spot        Faces (the face the centre is on), Centre, Radius, Lux (peak), Falloff
Texture     Faces (one face), Image (path), LuxScale
Shade       Faces; optionally Centre + Radius (a dark disk on them)
WorkPlane   Lux, Height (default 750 mm), Margin (border zone left out); for a design,
            TaskAreas (outlines drawn on the plan: the desks, a counter; they replace
            Margin) and TaskAreaLux (each area's own Em, 0: the work plane's Lux)
Reflectance Reflectance for Faces, or for all faces of a SurfaceType
==========  ===================================================================

All functions here are headless; GUI commands call them (inside ``Gui.doCommand``).
"""
import os

import numpy as np

from invrad_wb.core.model import targets as CT
from invrad_wb.errors import SceneError
from invrad_wb.app import settings as S
from invrad_wb.app.document import describe, object_type, transaction
from invrad_wb.app.units import mm_to_m, m_to_mm, vector_mm

TYPE = "InvRadTarget"
KINDS = ["Uniform", "Spot", "Texture", "Shade", "WorkPlane", "Reflectance"]
FALLOFFS = ["Cosine", "Gaussian", "Flat"]
SURFACE_TYPES = ["Faces", "Floor", "Walls", "Ceiling", "All"]

_PROPS = [
    # (type, name, doc)
    ("App::PropertyEnumeration", "Kind", "What this target asks for"),
    ("App::PropertyLink", "Room", "The room (Arch Space) this target belongs to"),
    ("App::PropertyLinkSubList", "Faces", "Faces of the room the target is on (FaceN)"),
    ("App::PropertyFloat", "Lux", "Illuminance in lux (uniform, spot peak, work plane)"),
    ("App::PropertyVector", "Centre", "Spot / shaded disk centre on the face (global, mm)"),
    ("App::PropertyLength", "Radius", "Spot / shaded disk radius"),
    ("App::PropertyEnumeration", "Falloff", "Spot falloff: Cosine (smooth), Gaussian"
                                            " (sigma = radius/3), Flat (a disk)"),
    ("App::PropertyFile", "Image", "Illuminance image (EXR, TIFF, PNG...) for a texture"),
    ("App::PropertyFloat", "LuxScale", "Lux per image unit (8-bit images read as 0..1)"),
    ("App::PropertyLength", "Height", "Work-plane height above the floor"),
    ("App::PropertyLength", "Margin", "Border zone along the walls left out of the work"
                                      " plane"),
    ("App::PropertyLinkSubList", "TaskAreas", "Work plane: the outlines of its task areas"
                                              " (closed wires or horizontal faces on the"
                                              " plan: desks, tables, a counter); empty: the"
                                              " room less Margin"),
    ("App::PropertyFloatList", "TaskAreaLux", "Work plane: each task area's own Em in lux,"
                                              " in the order of TaskAreas (0 or none: the"
                                              " work plane's Lux)"),
    ("App::PropertyFloat", "Reflectance", "Diffuse reflectance in [0, 1)"),
    ("App::PropertyEnumeration", "SurfaceType", "Reflectance: for the listed Faces or for"
                                                " all faces of a type"),
    ("App::PropertyBool", "Enabled", "Use this target"),
]


class TargetProxy:
    """Proxy of an InvRadTarget object (no GUI, importable in freecadcmd)."""

    Type = TYPE

    def __init__(self, obj):
        obj.Proxy = self
        self.set_properties(obj)

    def set_properties(self, obj):
        have = obj.PropertiesList
        for ptype, name, doc in _PROPS:
            if name not in have:
                obj.addProperty(ptype, name, "Lighting target", doc)
                if name == "Kind":
                    obj.Kind = KINDS
                elif name == "Falloff":
                    obj.Falloff = FALLOFFS
                elif name == "SurfaceType":
                    obj.SurfaceType = SURFACE_TYPES
                elif name == "Height":
                    obj.Height = m_to_mm(S.WORK_PLANE_HEIGHT_M)
                elif name == "LuxScale":
                    obj.LuxScale = 1.0
                elif name == "Enabled":
                    obj.Enabled = True
                elif name == "Reflectance":
                    obj.Reflectance = 0.5

    def onDocumentRestored(self, obj):
        self.set_properties(obj)

    def execute(self, obj):
        pass

    # FreeCAD 0.20 pickles proxies with __getstate__/__setstate__, 0.21+ with dumps/loads
    def __getstate__(self):
        return None

    def __setstate__(self, state):
        return None

    def dumps(self):
        return None

    def loads(self, state):
        return None


def is_target(obj):
    return object_type(obj) == TYPE


def targets_group(doc, create=True):
    """The document group holding all targets (created on demand)."""
    for o in doc.Objects:
        if o.TypeId == "App::DocumentObjectGroup" and o.Name.startswith("InvRadTargets"):
            return o
    if not create:
        return None
    g = doc.addObject("App::DocumentObjectGroup", "InvRadTargets")
    g.Label = S.TARGETS_GROUP_LABEL
    return g


def room_targets(space, enabled_only=True):
    """The target objects of a room, in document order."""
    doc = space.Document
    out = [o for o in doc.Objects if is_target(o) and o.Room == space]
    if enabled_only:
        out = [o for o in out if o.Enabled]
    return out


# --------------------------------------------------------------------------- creation
def _faces_arg(space, faces):
    """'floor'/'walls'/'ceiling'/'all', 'Face3', 3 (1-based), or a list -> ['FaceN', ...]."""
    from invrad_wb.app.rooms import faces_by_kind
    if faces is None:
        return []
    if isinstance(faces, (str, int)):
        faces = [faces]
    out = []
    for f in faces:
        if isinstance(f, str) and f.lower() in ("floor", "floors", "wall", "walls", "ceiling",
                                               "ceilings", "all"):
            out.extend(faces_by_kind(space, f.lower()))
        elif isinstance(f, str) and f.startswith("Face"):
            out.append(f)
        elif isinstance(f, (int, np.integer)) and not isinstance(f, bool):
            out.append(f"Face{int(f)}")
        else:
            raise SceneError(f"face {f!r}: give 'FaceN', a 1-based face number or one of"
                             " floor, walls, ceiling, all", space.Label)
    from invrad_wb.app.rooms import face_count
    n = face_count(space)
    for sub in out:
        if not sub[4:].isdigit() or not 1 <= int(sub[4:]) <= max(n, 1) or n == 0:
            raise SceneError(f"{sub} is not a face of room {describe(space)}"
                             + (f" (it has Face1..Face{n})" if n else " (it has no geometry)"),
                             space.Label)
    return out


def add_target(space, kind, faces=None, label=None, **values):
    """Add a target object to ``space``'s document (one undoable step) and return it.

    ``values`` are property values in SI units where the property is a length or position:
    ``lux``, ``centre_m``, ``radius_m``, ``falloff``, ``image``, ``lux_scale``,
    ``height_m``, ``margin_m``, ``reflectance``, ``surface_type``, ``enabled``.
    """
    if kind not in KINDS:
        raise SceneError(f"unknown target kind {kind!r}; use one of {', '.join(KINDS)}",
                         space.Label)
    doc = space.Document
    with transaction(doc, f"Add {kind.lower()} lighting target"):
        subs = _faces_arg(space, faces)
        obj = doc.addObject("App::FeaturePython", "InvRadTarget")
        TargetProxy(obj)
        obj.Kind = kind
        obj.Room = space
        if subs:
            obj.Faces = [(space, subs)]
        _set_values(obj, values)
        obj.Label = label or f"{kind} target {space.Label}"
        targets_group(doc).addObject(obj)
    return obj


def _set_values(obj, values):
    names = {"lux": "Lux", "lux_scale": "LuxScale", "reflectance": "Reflectance",
             "enabled": "Enabled", "image": "Image"}
    for key, val in values.items():
        if val is None:
            continue
        if key in names:
            setattr(obj, names[key], val if key in ("enabled", "image") else float(val))
        elif key == "centre_m":
            obj.Centre = vector_mm(val)
        elif key == "radius_m":
            obj.Radius = m_to_mm(val)
        elif key == "height_m":
            obj.Height = m_to_mm(val)
        elif key == "margin_m":
            obj.Margin = m_to_mm(val)
        elif key == "falloff":
            obj.Falloff = str(val).capitalize()
        elif key == "surface_type":
            obj.SurfaceType = str(val).capitalize()
        else:
            raise SceneError(f"unknown target value {key!r}", obj.Label)


def add_uniform_target(space, faces, lux, label=None):
    return add_target(space, "Uniform", faces, label, lux=lux)


def add_spot_target(space, face, centre_m, radius_m, peak_lux, falloff="cosine", label=None):
    return add_target(space, "Spot", face, label, centre_m=centre_m, radius_m=radius_m,
                      lux=peak_lux, falloff=falloff)


def add_texture_target(space, face, image, lux_scale=1.0, label=None):
    return add_target(space, "Texture", face, label, image=os.fspath(image),
                      lux_scale=lux_scale)


def add_shade_target(space, faces, centre_m=None, radius_m=None, label=None):
    return add_target(space, "Shade", faces, label, centre_m=centre_m, radius_m=radius_m)


def set_work_plane(space, lux, height_m=S.WORK_PLANE_HEIGHT_M, margin_m=S.WORK_PLANE_MARGIN_M):
    """Set (create or update) the room's work-plane requirement; returns the target."""
    existing = [o for o in room_targets(space, enabled_only=False) if o.Kind == "WorkPlane"]
    if not existing:
        return add_target(space, "WorkPlane", None, f"Work plane {space.Label}", lux=lux,
                          height_m=height_m, margin_m=margin_m)
    obj = existing[0]
    with transaction(space.Document, "Set work-plane illuminance"):
        _set_values(obj, dict(lux=lux, height_m=height_m, margin_m=margin_m, enabled=True))
    return obj


def work_plane_target(space):
    """The room's enabled WorkPlane target object, or None."""
    wp = [o for o in room_targets(space) if o.Kind == "WorkPlane"]
    return wp[0] if wp else None


# --------------------------------------------------------------------------- task areas
#: an outline whose corners differ more than this in height is not on the plan, mm
FLAT_TOL_MM = 1.0
#: curved edges (a round table) are followed to within this, mm
CURVE_DEFLECTION_MM = 5.0


def _outline_pairs(selection):
    """[(object, 'FaceN' or None)] of a selection: objects, (object, [subs]) pairs
    (LinkSubList values, GUI selection's SubElementNames)."""
    out = []
    for item in selection:
        obj, subs = item if isinstance(item, (tuple, list)) else (item, ())
        subs = [s for s in (subs or ()) if s]
        if not subs:
            out.append((obj, None))
        out.extend((obj, s) for s in subs)
    return out


def _area_name(obj, sub):
    return obj.Label if sub is None else f"{obj.Label} {sub}"


def outline_polygon(obj, sub=None):
    """A task area's plan polygon, ((k, 2) metres, global x/y) from a closed wire or face
    (a Draft rectangle or wire drawn on the plan, or ``sub`` = 'FaceN' of any object, e.g.
    a desk's top). Raises SceneError naming the object when it is not one closed
    horizontal outline."""
    import Part
    from invrad_wb.app.document import global_shape
    from invrad_wb.app.units import points_mm_to_m
    what = describe(obj) + (f" {sub}" if sub else "")
    hint = ("select a closed wire or a horizontal face drawn on the plan (a Draft rectangle)"
            " as a task area")
    shape = getattr(obj, "Shape", None)
    if shape is None or shape.isNull():
        raise SceneError(f"{what} has no shape: {hint}", obj.Label)
    shape = global_shape(obj)
    if sub is not None:
        if not (sub.startswith("Face") and sub[4:].isdigit()
                and 1 <= int(sub[4:]) <= len(shape.Faces)):
            raise SceneError(f"{what} is not a face of {describe(obj)}: {hint}", obj.Label)
        faces = [shape.Faces[int(sub[4:]) - 1]]
    else:
        faces = shape.Faces
    if len(faces) == 1:
        wire = faces[0].OuterWire
    elif not faces and len(shape.Wires) == 1 and shape.Wires[0].isClosed():
        wire = shape.Wires[0]
    else:
        raise SceneError(f"{what} is not one closed outline ({len(faces)} faces,"
                         f" {len(shape.Wires)} wires): {hint}", obj.Label)
    if all(isinstance(e.Curve, (Part.Line, Part.LineSegment)) for e in wire.Edges):
        pts = [v.Point for v in wire.OrderedVertexes]
    else:
        pts = wire.discretize(Deflection=CURVE_DEFLECTION_MM)
    xyz = points_mm_to_m(pts)
    if len(xyz) > 1 and np.allclose(xyz[0], xyz[-1]):
        xyz = xyz[:-1]
    if len(xyz) < 3:
        raise SceneError(f"{what} has {len(xyz)} corners, not an outline: {hint}", obj.Label)
    lo, hi = float(xyz[:, 2].min()), float(xyz[:, 2].max())
    if hi - lo > FLAT_TOL_MM / 1000.0:
        raise SceneError(f"{what} is not horizontal (its outline spans z {lo:.3f} to"
                         f" {hi:.3f} m): {hint}", obj.Label)
    return xyz[:, :2]


def set_task_areas(space, outlines, lux=None):
    """The task areas of ``space``'s work plane (one undoable step): ``outlines`` are the
    objects (or ``(object, ['FaceN'])`` pairs) whose closed outline is a task area;
    ``lux`` None or a list (one per outline, None: the work plane's). Each outline is
    checked first (:func:`outline_polygon`); the room needs a work-plane target. Returns
    the work-plane target."""
    wp = work_plane_target(space)
    if wp is None:
        raise SceneError(f"room {describe(space)} has no work plane: set its illuminance"
                         " first (Set lighting target on the room, or Design)", space.Label)
    pairs = _outline_pairs(outlines)
    if not pairs:
        raise SceneError(f"no task area given for room {describe(space)}: select closed"
                         " wires or faces drawn on the plan", space.Label)
    for obj, sub in pairs:
        if obj == space or is_target(obj):
            raise SceneError(f"{describe(obj)} cannot be a task area of room"
                             f" {describe(space)}: select outlines drawn on the plan",
                             obj.Label)
        outline_polygon(obj, sub)
    lux = [None] * len(pairs) if lux is None else list(lux)
    if len(lux) != len(pairs):
        raise SceneError(f"{len(lux)} lux values for {len(pairs)} task areas", space.Label)
    values = []
    for v in lux:
        values.append(0.0 if v is None else
                      CT.check_lux(float(v), f"{_who(wp)}: task area lux", None))
    with transaction(space.Document, "Set task areas"):
        wp.TaskAreas = [(o, s) if s else o for o, s in pairs]
        wp.TaskAreaLux = values
    return wp


def task_area_selection(doc, items):
    """``(space, [(object, 'FaceN' or None), ...])`` of a selection for
    :func:`set_task_areas`: ``items`` are ``(object, [subs])`` pairs; the room is the
    selected Space (or the document's only one), the rest are the outlines. Raises
    SceneError naming what is missing or ambiguous."""
    from invrad_wb.app.rooms import find_spaces, is_space
    pairs = _outline_pairs(items)
    spaces = []
    for o, _ in pairs:
        if is_space(o) and o not in spaces:
            spaces.append(o)
    outlines = [(o, s) for o, s in pairs if not is_space(o)]
    if not spaces:
        spaces = find_spaces(doc)
        if len(spaces) != 1:
            raise SceneError("select the room (its Space) together with the task-area"
                             f" outlines: the document has {len(spaces)} rooms", doc.Label)
    if len(spaces) > 1:
        raise SceneError("select one room (Space) with its task-area outlines, not"
                         f" {len(spaces)} ({', '.join(describe(o) for o in spaces)})",
                         doc.Label)
    if not outlines:
        raise SceneError(f"select the task-area outlines of room {describe(spaces[0])}"
                         " (closed wires or faces drawn on the plan) with it",
                         spaces[0].Label)
    return spaces[0], outlines


def _task_area_pairs(wp):
    out = []
    for obj, subs in wp.TaskAreas:
        out.extend(_outline_pairs([(obj, subs)]))
    return out


def task_areas_m(wp):
    """A WorkPlane target's task areas as the design spec's ``"task_areas"``: [{"name",
    "polygon": [[x, y], ...] metres, "lux" where given}], [] without. Raises SceneError
    naming the target and the outline at fault."""
    pairs = _task_area_pairs(wp)
    lux = list(wp.TaskAreaLux)
    if len(lux) > len(pairs):
        raise SceneError(f"{_who(wp)}: TaskAreaLux has {len(lux)} values for"
                         f" {len(pairs)} task areas (an outline was deleted?): give one"
                         " per task area, or Set task areas again", wp.Label)
    out, names = [], set()
    for i, (obj, sub) in enumerate(pairs):
        try:
            poly = outline_polygon(obj, sub)
        except SceneError as exc:
            raise SceneError(f"{_who(wp)}: task area {exc}", wp.Label)
        name, k = _area_name(obj, sub), 2
        while name in names:
            name, k = f"{_area_name(obj, sub)} ({k})", k + 1
        names.add(name)
        d = {"name": name, "polygon": [[round(float(x), 6), round(float(y), 6)]
                                       for x, y in poly]}
        v = lux[i] if i < len(lux) else 0.0
        if v:
            d["lux"] = CT.check_lux(float(v), f"{_who(wp)}: TaskAreaLux[{i}]", None)
        out.append(d)
    return out


def add_task_area_outlines(space, areas, height_m):
    """Outline objects (a flat face each, labelled with the area's name, in the targets
    group) for task areas given in metres (the targets file's ``"task_areas"``), at the
    work plane's height above the room's floor; returns them. Call inside a
    transaction."""
    import FreeCAD
    import Part
    from invrad_wb.app.document import global_shape
    doc = space.Document
    z = global_shape(space).BoundBox.ZMin + m_to_mm(height_m)
    out = []
    for a in areas:
        pts = [FreeCAD.Vector(m_to_mm(x), m_to_mm(y), z) for x, y in a.polygon]
        obj = doc.addObject("Part::Feature", "TaskArea")
        obj.Shape = Part.Face(Part.makePolygon(pts + pts[:1]))
        obj.Label = a.name
        targets_group(doc).addObject(obj)
        out.append(obj)
    return out


def set_reflectance(space, reflectance, faces=None, surface_type=None):
    """Reflectance for some faces of a room, or for all its floor/walls/ceiling."""
    st = "Faces" if faces is not None else (surface_type or "All")
    return add_target(space, "Reflectance", faces, f"Reflectance {space.Label}",
                      reflectance=reflectance, surface_type=st)


# --------------------------------------------------------------------------- evaluation
def _who(obj):
    return f"target {describe(obj)}"


def target_faces(obj, space, n_faces):
    """0-based face indices of a target, checked against its room."""
    out = []
    for linked, subs in obj.Faces:
        if linked != space:
            raise SceneError(f"{_who(obj)} of room {describe(space)} refers to faces of"
                             f" {describe(linked)}, not of its room", obj.Label)
        for sub in subs:
            if not sub.startswith("Face") or not sub[4:].isdigit():
                raise SceneError(f"{_who(obj)} refers to {sub!r}, which is not a face"
                                 " (FaceN)", obj.Label)
            k = int(sub[4:])
            if not 1 <= k <= n_faces:
                raise SceneError(f"{_who(obj)} refers to {sub} of room {describe(space)},"
                                 f" which does not exist: the room has {n_faces} faces"
                                 f" (Face1..Face{n_faces})", obj.Label)
            out.append(k - 1)
    return out


def _finite_lux(obj, prop):
    return CT.check_lux(getattr(obj, prop), f"{_who(obj)}: {prop}", None)


def _need_faces(obj, faces, count=None):
    if not faces:
        raise SceneError(f"{_who(obj)} ({obj.Kind}) has no faces: select faces of its room",
                         obj.Label)
    if count == 1 and len(set(faces)) != 1:
        raise SceneError(f"{_who(obj)} ({obj.Kind}) must be on exactly one face, has"
                         f" {len(set(faces))}", obj.Label)


def room_specs(space, n_faces, face_kinds=None, base_dir=None):
    """Core target specs and reflectance overrides of a room, checked.

    Returns
    -------
    specs : list of core target specs (face ids are 0-based face indices)
    reflectance : dict for :func:`invrad_wb.app.rooms.mesh_room`
    work_plane : core WorkPlaneTarget or None

    Raises
    ------
    SceneError
        Naming the target object: missing faces, NaN/negative lux, bad radius, missing
        image, faces of another object.
    """
    specs, reflectance, work_plane = [], {}, None
    for obj in room_targets(space):
        kind = obj.Kind
        faces = target_faces(obj, space, n_faces)
        name = f"{_who(obj)}"
        if kind == "Uniform":
            _need_faces(obj, faces)
            specs.append(CT.UniformTarget(faces, _finite_lux(obj, "Lux"), name=name))
        elif kind == "Spot":
            _need_faces(obj, faces)
            radius = mm_to_m(obj.Radius)
            if not radius > 0:
                raise SceneError(f"{name}: Radius must be > 0", obj.Label)
            specs.append(CT.SpotTarget(faces[0], mm_to_m(obj.Centre), radius,
                                       _finite_lux(obj, "Lux"), obj.Falloff.lower(),
                                       surfaces=sorted(set(faces)), name=name))
        elif kind == "Texture":
            _need_faces(obj, faces, count=1)
            scale = _finite_lux(obj, "LuxScale")
            path = obj.Image
            if not path:
                raise SceneError(f"{name}: no Image file set", obj.Label)
            if base_dir and not os.path.isabs(path):
                path = os.path.join(base_dir, path)
            if not os.path.isfile(path):
                raise SceneError(f"{name}: image {path} does not exist", obj.Label)
            specs.append(CT.TextureTarget(faces[0], path, scale, name=name))
        elif kind == "Shade":
            _need_faces(obj, faces)
            radius = mm_to_m(obj.Radius)
            if radius > 0:
                specs.append(CT.ShadeTarget(faces, mm_to_m(obj.Centre), radius, name=name))
            else:
                specs.append(CT.ShadeTarget(faces, name=name))
        elif kind == "WorkPlane":
            if work_plane is not None:
                raise SceneError(f"room {describe(space)} has more than one enabled work"
                                 f" plane ({work_plane.name} and {name})", space.Label)
            work_plane = CT.WorkPlaneTarget(_finite_lux(obj, "Lux"), mm_to_m(obj.Height),
                                            mm_to_m(obj.Margin), name=name)
        elif kind == "Reflectance":
            r = obj.Reflectance
            if not (np.isfinite(r) and 0 <= r < 1):
                raise SceneError(f"{name}: Reflectance {r} must be in [0, 1) (a fraction,"
                                 " not a percentage)", obj.Label)
            st = obj.SurfaceType
            if st == "Faces":
                _need_faces(obj, faces)
                for f in faces:
                    reflectance[f] = r
            elif st == "All":
                for k in ("floor", "wall", "ceiling"):
                    reflectance[k] = r
            else:
                reflectance[{"Floor": "floor", "Walls": "wall", "Ceiling": "ceiling"}[st]] = r
    return specs, reflectance, work_plane


def has_targets(space):
    return any(o.Kind != "Reflectance" for o in room_targets(space))


# --------------------------------------------------------------------------- JSON
TARGETS_JSON_DOC = """Targets file (``--targets T.json``), all keys optional except ``rooms``::

    {"flux_lm": 3000, "resolution_m": 0.3,
     "rooms": {
       "Wohnen": {                               # a room's label, name or IFC GlobalId
         "replace": true,                        # drop the room's existing targets first
         "work_plane": {"lux": 300, "height_m": 0.75, "margin_m": 0.5},   # or just 300
         # or task areas instead of margin_m (metres, plan x/y; they become outlines in
         # the document, linked from the work plane's TaskAreas):
         # "work_plane": {"lux": 500, "task_areas": [{"name": "desks", "rect": [x0, y0,
         #   x1, y1]}, {"name": "counter", "polygon": [[x, y], ...], "lux": 300}]},
         "reflectance": {"floor": 0.2, "walls": 0.5, "ceiling": 0.7, "Face3": 0.8},
         "targets": [
           {"kind": "uniform", "faces": "floor", "lux": 200},   # faces: floor, walls,
           {"kind": "spot", "face": "Face2", "centre_m": [1, 2, 0], # ceiling, all, FaceN,
            "radius_m": 0.5, "peak_lux": 500, "falloff": "cosine"}, # 1-based numbers
           {"kind": "texture", "face": "Face1", "image": "lux.exr", "lux_scale": 1.0},
           {"kind": "shade", "faces": ["Face3"]},
           {"kind": "shade", "faces": "floor", "centre_m": [1, 1, 0], "radius_m": 0.4}]}}}

Relative image paths are relative to the targets file."""


def apply_targets_file(doc, path):
    """Add the targets of a JSON file (see ``TARGETS_JSON_DOC``) as one undoable step.

    Returns the file's top-level options (``flux_lm``, ``resolution_m``) as a dict.
    """
    import json
    from invrad_wb.app.rooms import get_space
    try:
        with open(path, "r", encoding="utf-8") as fh:
            data = json.load(fh)
    except OSError as exc:
        raise SceneError(f"cannot read targets: {exc.strerror}", path)
    except json.JSONDecodeError as exc:
        raise SceneError(f"not valid JSON: {exc}", path)
    except UnicodeDecodeError as exc:
        raise SceneError(f"not UTF-8 text (byte {exc.start}): not a JSON file", path)
    if not isinstance(data, dict) or not isinstance(data.get("rooms"), dict):
        raise SceneError('expected {"rooms": {"<room>": {...}}}', path)
    base = os.path.dirname(os.path.abspath(path))
    known_top = {"rooms", "flux_lm", "resolution_m"} | DESIGN_TOP_KEYS
    unknown = set(data) - known_top
    if unknown:
        raise SceneError(f"unknown key(s) {', '.join(sorted(unknown))}; expected"
                         f" {', '.join(sorted(known_top))}", path)
    rooms = _expand_rooms(doc, data)
    with transaction(doc, f"Lighting targets from {os.path.basename(path)}"):
        for key, spec in rooms.items():
            where = f"rooms.{key}"
            try:
                space = get_space(doc, key)
            except SceneError as exc:
                raise SceneError(f"{where}: {exc}", path)
            if not isinstance(spec, dict):
                raise SceneError(f"{where} must be an object", path)
            try:
                _apply_room(space, spec, base, where)
            except SceneError as exc:
                raise SceneError(f"{where}: {exc}", path)
    return {k: data[k] for k in ("flux_lm", "resolution_m") if k in data}


#: keys of a design spec (``invrad_wb.core.design.spec``) that a targets file may carry:
#: with a ``catalogue`` the run designs from requirements instead of locating
DESIGN_TOP_KEYS = {"maintenance_factor", "catalogue", "project", "description"}
DESIGN_ROOM_KEYS = {"room_type", "mounting", "catalogue", "shade_limit_lux", "ugr_max",
                    "name"}


def _expand_rooms(doc, data):
    """The file's rooms, with design requirements turned into work-plane targets: a room
    key "*" (every other room) and a ``room_type`` without a ``work_plane`` (its EN 12464-1
    illuminance) in a design file."""
    from invrad_wb.app.rooms import find_spaces
    rooms = {k: v for k, v in data["rooms"].items() if k != "*"}
    if "catalogue" not in data:
        return data["rooms"]
    from invrad_wb.core.design import en12464
    if "*" in data["rooms"]:
        named = set(rooms)
        for sp in find_spaces(doc):
            if not named & {sp.Label, sp.Name}:
                rooms[sp.Label] = data["rooms"]["*"]
    from invrad_wb.core.design.spec import DEFAULT_MARGIN_M
    out = {}
    for key, spec in rooms.items():
        if isinstance(spec, dict) and "work_plane" not in spec and spec.get("room_type"):
            req = en12464.lookup(spec["room_type"])
            if req is not None:
                spec = dict(spec, work_plane={"lux": req.em_lux, "u0": req.u0})
        if isinstance(spec, dict) and spec.get("work_plane") is not None:
            # the same work plane as the design's: EN 12464-1 border zone by default
            # (none where task areas are given); a room type's Em where no lux is given
            wp = spec["work_plane"]
            wp = dict(wp) if isinstance(wp, dict) else {"lux": wp}
            if "lux" not in wp and spec.get("room_type"):
                req = en12464.lookup(spec["room_type"])
                if req is not None:
                    wp["lux"] = req.em_lux
            if wp.get("task_areas") is None:
                wp.setdefault("margin_m", DEFAULT_MARGIN_M)
            spec = dict(spec, work_plane=wp)
        out[key] = spec
    return out


def _apply_room(space, spec, base, where):
    known = {"replace", "work_plane", "reflectance", "targets"} | DESIGN_ROOM_KEYS
    unknown = set(spec) - known
    if unknown:
        raise SceneError(f"unknown key(s) {', '.join(sorted(unknown))}; expected"
                         f" {', '.join(sorted(known))}")
    doc = space.Document
    if spec.get("replace"):
        group = targets_group(doc, create=False)
        for o in room_targets(space, enabled_only=False):
            # the task-area outlines a targets file made go with their work plane
            made = [a for a, _ in o.TaskAreas
                    if group is not None and a in group.Group and a.Name.startswith("TaskArea")]
            doc.removeObject(o.Name)
            for a in made:
                doc.removeObject(a.Name)
    wp = spec.get("work_plane")
    if wp is not None:
        if not isinstance(wp, dict):
            wp = {"lux": wp}
        _check_keys(wp, {"lux", "height_m", "margin_m", "u0", "task_areas"}, "work_plane")
        if "lux" not in wp:
            raise SceneError("work_plane needs 'lux'")
        areas = _file_task_areas(wp)
        height = _num(wp.get("height_m", S.WORK_PLANE_HEIGHT_M), "work_plane.height_m")
        set_work_plane(space, _num(wp["lux"], "work_plane.lux"), height,
                       _num(wp.get("margin_m", S.WORK_PLANE_MARGIN_M), "work_plane.margin_m"))
        if areas:
            set_task_areas(space, add_task_area_outlines(space, areas, height),
                           [a.lux for a in areas])
    for k, v in (spec.get("reflectance") or {}).items():
        kl = k.lower()
        if kl in ("floor", "walls", "wall", "ceiling", "all"):
            st = {"wall": "Walls", "walls": "Walls"}.get(kl, kl.capitalize())
            set_reflectance(space, _num(v, f"reflectance.{k}"), surface_type=st)
        else:
            set_reflectance(space, _num(v, f"reflectance.{k}"), faces=[k])
    for i, t in enumerate(spec.get("targets") or []):
        w = f"targets[{i}]"
        if not isinstance(t, dict) or "kind" not in t:
            raise SceneError(f"{w} must be an object with a 'kind'")
        kind = str(t["kind"]).lower()
        if kind == "uniform":
            _check_keys(t, {"kind", "faces", "lux", "label"}, w)
            add_uniform_target(space, t.get("faces"), _num(t.get("lux"), f"{w}.lux"),
                               t.get("label"))
        elif kind == "spot":
            _check_keys(t, {"kind", "face", "faces", "centre_m", "radius_m", "peak_lux",
                            "falloff", "label"}, w)
            faces = t.get("faces", t.get("face"))
            add_target(space, "Spot", faces, t.get("label"), centre_m=t.get("centre_m"),
                       radius_m=_num(t.get("radius_m"), f"{w}.radius_m"),
                       lux=_num(t.get("peak_lux"), f"{w}.peak_lux"),
                       falloff=t.get("falloff", "cosine"))
        elif kind == "texture":
            _check_keys(t, {"kind", "face", "image", "lux_scale", "label"}, w)
            img = t.get("image")
            if not img:
                raise SceneError(f"{w} needs an 'image'")
            if not os.path.isabs(img):
                img = os.path.join(base, img)
            add_texture_target(space, t.get("face"), img,
                               _num(t.get("lux_scale", 1.0), f"{w}.lux_scale"), t.get("label"))
        elif kind == "shade":
            _check_keys(t, {"kind", "faces", "face", "centre_m", "radius_m", "label"}, w)
            add_shade_target(space, t.get("faces", t.get("face")), t.get("centre_m"),
                             t.get("radius_m"), t.get("label"))
        else:
            raise SceneError(f"{w}: unknown kind {t['kind']!r}; use uniform, spot, texture"
                             " or shade")


def _file_task_areas(wp):
    """The work plane's ``"task_areas"`` checked as the design spec checks them (core
    TaskArea objects, metres), () without."""
    if wp.get("task_areas") is None:
        return ()
    if "margin_m" in wp:
        raise SceneError("work_plane: give either margin_m (the task area is the room less"
                         " a border zone) or task_areas, not both")
    from invrad_wb.core.design.spec import task_areas_from
    from invrad_wb.errors import SettingsError
    try:
        return task_areas_from(wp["task_areas"], "work_plane", ("task_areas",))
    except SettingsError as exc:
        raise SceneError(str(exc))


def _check_keys(d, known, where):
    unknown = set(d) - known
    if unknown:
        raise SceneError(f"{where}: unknown key(s) {', '.join(sorted(unknown))}; expected"
                         f" {', '.join(sorted(known))}")


def _num(v, where):
    try:
        x = float(v)
    except (TypeError, ValueError):
        raise SceneError(f"{where} is {v!r}: expected a number")
    return x
