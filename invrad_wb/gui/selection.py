"""What the user selected, in invrad's terms: faces of rooms, rooms, a picked point.

Targets live on the faces of a room's Space (``FaceN`` of the Space's solid). In the 3D
view the Space's faces coincide with the inner faces of the walls and slabs around it, and
a click often lands on the wall: :func:`room_faces` maps a selected face of any object to
the coplanar, overlapping face(s) of the Spaces, so that both work.

The functions take a selection as ``FreeCADGui.Selection.getSelectionEx()`` returns it
(objects with ``Object``, ``SubElementNames``, ``PickedPoints``) or, headless, a list of
``(object, [sub-element names], [picked points])``; only :func:`current` needs the GUI.
"""
from invrad_wb.app.document import describe, object_type
from invrad_wb.app.rooms import find_spaces, is_space, room_shape
from invrad_wb.errors import SceneError

#: Coplanarity tolerances: mm, and |cos| of the angle between the normals.
DIST_TOL_MM = 1.0
PARALLEL_COS = 0.999


class Sel:
    """One selected object (the subset of Gui.SelectionObject invrad uses)."""

    def __init__(self, obj, subs=(), points=()):
        self.Object = obj
        self.SubElementNames = list(subs)
        self.PickedPoints = list(points)


def current():
    """The GUI selection (list of SelectionObject); [] without a GUI."""
    import FreeCAD
    if not FreeCAD.GuiUp:
        return []
    import FreeCADGui
    return FreeCADGui.Selection.getSelectionEx()


def _items(sel):
    out = []
    for s in (current() if sel is None else sel):
        if isinstance(s, tuple):
            s = Sel(*s)
        out.append(s)
    return out


def _face_normal(face):
    u0, u1, v0, v1 = face.ParameterRange
    return face.normalAt(0.5 * (u0 + u1), 0.5 * (v0 + v1))


def _is_planar(face):
    return "Plane" in type(face.Surface).__name__


def matching_space_faces(face, spaces):
    """``[(space, 'FaceN'), ...]``: Space faces coplanar with ``face`` that overlap it."""
    out = []
    if not _is_planar(face):
        return out
    n = _face_normal(face)
    p = face.CenterOfMass
    for space in spaces:
        try:
            shape = room_shape(space)
        except SceneError:
            continue
        for i, f in enumerate(shape.Faces):
            if not _is_planar(f):
                continue
            m = _face_normal(f)
            if abs(n.dot(m)) < PARALLEL_COS:
                continue
            if abs((f.CenterOfMass - p).dot(n)) > DIST_TOL_MM:
                continue
            if f.distToShape(face)[0] > DIST_TOL_MM:
                continue
            try:
                common = f.common(face).Area
            except Exception:
                common = 0.0
            if common > 1e-4 * min(f.Area, face.Area):
                out.append((space, f"Face{i + 1}"))
    return out


def global_element(obj, sub):
    """The sub-element ``sub`` of ``obj`` in global coordinates (containers' placements
    applied, e.g. an IFC storey), or None."""
    try:
        import Part
        shape = Part.getShape(obj, sub, needSubElement=True)
        if shape is not None and not shape.isNull():
            return shape
    except Exception:
        pass
    try:
        shape = obj.Shape.getElement(sub).copy()
        if hasattr(obj, "getGlobalPlacement"):
            shape.Placement = obj.getGlobalPlacement().multiply(
                obj.Placement.inverse()).multiply(shape.Placement)
        return shape
    except Exception:
        return None


def room_faces(sel=None):
    """Faces of rooms in the selection, grouped by room.

    Returns
    -------
    list of (Space, ['FaceN', ...]) in selection order, and the first picked point (a
    FreeCAD Vector in mm, or None) as ``(groups, point)``.

    Raises
    ------
    SceneError
        Nothing selected, or a selected face that belongs to no room.
    """
    items = _items(sel)
    groups, order, point = {}, [], None
    unmatched = []
    spaces = None
    for s in items:
        obj = s.Object
        faces = [n for n in s.SubElementNames if n.startswith("Face")]
        for k, sub in enumerate(faces):
            if point is None and k < len(s.PickedPoints):
                point = s.PickedPoints[k]
            if is_space(obj):
                hits = [(obj, sub)]
            else:
                if spaces is None:
                    spaces = find_spaces(obj.Document)
                face = global_element(obj, sub)
                hits = matching_space_faces(face, spaces) if face is not None else []
            if not hits:
                unmatched.append(f"{sub} of {describe(obj)}")
            for space, name in hits:
                if space.Name not in groups:
                    groups[space.Name] = (space, [])
                    order.append(space.Name)
                if name not in groups[space.Name][1]:
                    groups[space.Name][1].append(name)
    if unmatched:
        raise SceneError(f"{', '.join(unmatched)} {'is' if len(unmatched) == 1 else 'are'}"
                         " not on the boundary of any room (Arch Space); select faces of a"
                         " Space, or the inner faces of its walls, floor and ceiling")
    if not order:
        raise SceneError("select one or more faces of a room (an Arch Space, or the inner"
                         " faces of its walls, floor and ceiling) in the 3D view")
    return [groups[n] for n in order], point


def rooms(sel=None):
    """The rooms the selection is about (Spaces; the rooms of selected faces, targets,
    fixtures), in order, without duplicates; [] when the selection names none."""
    from invrad_wb.app.fixtures import fixture_room, is_fixture
    from invrad_wb.app.targets import is_target
    out = []
    for s in _items(sel):
        obj = s.Object
        found = []
        if is_space(obj):
            found = [obj]
        elif is_target(obj) and obj.Room is not None:
            found = [obj.Room]
        elif is_fixture(obj):
            r = fixture_room(obj)
            found = [r] if r is not None else []
        elif s.SubElementNames:
            try:
                found = [g[0] for g in room_faces([s])[0]]
            except SceneError:
                found = []
        elif object_type(obj) == "Space":
            found = [obj]
        for sp in found:
            if sp not in out:
                out.append(sp)
    return out
