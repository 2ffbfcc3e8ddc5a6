"""False-colour display of illuminance on the room surfaces, with a legend.

The display is a coin3d overlay added to the 3D views' scene graphs, not a document
object: nothing of it is saved in the .FCStd file or written to an IFC export, and showing
or hiding it is no document change (no undo step).

What it shows (per vertex of the rooms' sampling meshes, colours interpolated):

* **targets**: the lighting targets of every room with targets, as the pipeline evaluates
  them (:func:`invrad_wb.app.pipeline.prepare`) in viridis like the report's images;
  "no target" is grey and a shade target (0 lx, "must stay dark") near black, so neither
  is mistaken for a low target; the work plane is a translucent layer at its height;
  along the targets' edges (a painted spot's rim) the mesh is refined and the targets
  evaluated again (:func:`target_mesh`), so that a round spot looks round, not stair-stepped;
* **achieved** illuminance after *Verify and report* or *Design*, on the same meshes;
* its **deviation** from the targets (*Show/hide deviation*), -50 % .. +50 % in the
  report's blue-white-red.

Both views of a document share ONE lux scale, chosen once from its targets
(:func:`document_scale`: the largest target and half as much again, rounded up), so
that the same colour means the same illuminance in both and a met target looks alike.

The overlay sits ``offset_m`` inside the room (no z-fighting with the Space and the wall
faces), is not pickable (clicks select the faces behind it) and culls back faces, so that
from outside a room one looks into it like into a doll's house: the near walls and the
ceiling vanish while the floor and the far walls stay. The legend (colour bar, ticks in
lux, swatches) is drawn in screen space at the left of the view; each room's name is
written over its floor, clear of its walls, fixtures and the objects standing in it; a
name cut away by a clipping plane, or under a storey above that hides its room, is not
drawn (:func:`label_visibility`), so that one storey's names never print over another's.

The numpy part (colour map, ticks, overlay geometry) needs no GUI and is tested
headless; the coin part runs only with FreeCAD's GUI.
"""
import numpy as np

from invrad_wb.gui.coinnodes import (LEGEND_NAME, OVERLAY_NAME, build_labels,  # noqa: F401
                                     build_legend, build_overlay, clip_planes)
from invrad_wb.gui.falsecolour import (DEVIATION_LIMIT, NO_TARGET_RGB,  # noqa: F401
                                       SCALE_HEADROOM, SHADE_RGB, VIRIDIS, boundary_edges,
                                       colour_map, colours, deviation, deviation_colours,
                                       edge_triangles, face_groups, legend_layout, lux_scale,
                                       mean_target, nice_max, open_faces, overlay_geometry,
                                       percent, subdivide, target_mesh, ticks)
from invrad_wb.gui.roomlabels import label_visibility, room_labels  # noqa: F401
from invrad_wb.core.output import images as _images


class DocumentDisplay:
    """What the display keeps for one document: the overlay shown now (``overlay``: its
    coin nodes, views, mode, building, labels; None when hidden), the lux scale its views
    share (``scale``) and the last achieved result (``achieved``: (building, lux), for
    the deviation view)."""

    __slots__ = ("overlay", "scale", "achieved")

    def __init__(self):
        self.overlay = None
        self.scale = None
        self.achieved = None


_DOCS = {}          # doc name -> DocumentDisplay


def _doc_state(doc, create=False):
    name = doc if isinstance(doc, str) else doc.Name
    st = _DOCS.get(name)
    if st is None and create:
        st = _DOCS[name] = DocumentDisplay()
    return st


def _overlay(doc):
    st = _doc_state(doc)
    return st.overlay if st is not None else None


def _graphs(doc):
    """Scene graphs of the document's 3D views."""
    import FreeCADGui
    gdoc = FreeCADGui.getDocument(doc.Name)
    out = []
    for view in gdoc.mdiViewsOfType("Gui::View3DInventor"):
        try:
            out.append(view.getSceneGraph())
        except Exception:
            pass
    return out


def is_shown(doc, mode=None):
    ov = _overlay(doc)
    return ov is not None and (mode is None or ov["mode"] == mode)


def mode(doc):
    ov = _overlay(doc)
    return ov["mode"] if ov else None


def hide(doc):
    """Remove the overlay of ``doc`` from its views (no-op if none)."""
    ov = _overlay(doc)
    if ov is None:
        return False
    _doc_state(doc).overlay = None
    _detach(ov)
    for sg in ov["graphs"]:
        for node in (ov["node"], ov["legend"]):
            try:
                if sg.findChild(node) >= 0:
                    sg.removeChild(node)
            except Exception:
                pass
    return True


def target_scale(building):
    """Top of the scale for a building's targets (lux): :func:`lux_scale` of them."""
    return lux_scale(building.scene.vertex_lux)


def document_scale(doc, target_lux):
    """The lux scale of ``doc``'s target and achieved views, chosen once: by
    :func:`lux_scale` on the first view, then kept while the largest target still fits
    under it with its headroom (5 % slack: meshes of other resolutions sample a spot's
    peak a little differently, one step of the rounding); new when the targets changed
    more (a brighter target, or one a step lower as after an undo)."""
    t = np.asarray(target_lux, dtype=np.float64) if target_lux is not None else np.zeros(0)
    t = t[np.isfinite(t)]
    need = SCALE_HEADROOM * (t.max() if t.size else 0.0)
    st = _doc_state(doc, create=True)
    old = st.scale
    new = lux_scale(t)
    if old is not None and need <= old * 1.05 and new >= 0.75 * old:
        return old
    st.scale = new
    return new


def show(doc, building, values, title, mode_name, targets=True, vmax=None, mesh=None,
         deviation=False):
    """Show per-vertex ``values`` (lux) of ``building`` (or of the display ``mesh``, see
    :func:`target_mesh`) in false colour; replaces any overlay of ``doc``. ``vmax``: top
    of the scale (default: the largest value, rounded up); larger values take the top
    colour and the top tick reads "<vmax>+". With ``deviation`` the values are relative
    deviations from the target, drawn -vmax..+vmax in the report's blue-white-red.
    Returns the top of the scale (lux, or the deviation fraction)."""
    import FreeCAD
    from invrad_wb.gui import params
    if not FreeCAD.GuiUp:
        return None
    opts = params.load_display()
    hide(doc)
    rgb = deviation_colours(values, vmax) if deviation else None
    geom = overlay_geometry(building, values, offset_m=opts["offset_m"], targets=targets,
                            vmax=vmax, mesh=mesh, rgb=rgb)
    from pivy import coin
    node = coin.SoSeparator()
    node.setName(OVERLAY_NAME + "Root")
    node.addChild(build_overlay(geom, opts["work_plane_transparency"]))
    v = np.asarray(values, dtype=np.float64)
    over = not deviation and bool(np.any(v[np.isfinite(v)] > geom["vmax"] * (1 + 1e-9)))
    swatches = []
    scale = {}
    if deviation:
        scale = {"vmin": -geom["vmax"], "fmt": percent,
                 "cmap": lambda x: deviation_colours(x, geom["vmax"])}
        if np.any(~np.isfinite(v)):
            swatches.append((tuple(np.asarray(_images.NAN_GREY) / 255.0), "no target"))
    elif targets:
        if np.any(np.isfinite(v) & (v == 0)):
            swatches.append((SHADE_RGB, "0 (shade)"))
        if np.any(~np.isfinite(v)):
            swatches.append((NO_TARGET_RGB, "no target"))
    legend = coin.SoSeparator()
    legend.setName(LEGEND_NAME + "Root")
    legend.addChild(build_legend(title, geom["vmax"], swatches, over=over, **scale))
    label_node = coin.SoSeparator()
    legend.addChild(label_node)
    graphs = _graphs(doc)
    for sg in graphs:
        # the surfaces go last, where clipping planes (Std_ToggleClipPlane, inserted
        # after the 'EditingRoot' child) cut them like the building; the legend and the
        # room names go first, where no clipping plane reaches them (clipped annotations
        # vanish altogether in FreeCAD 0.20)
        sg.addChild(node)
        sg.insertChild(legend, 0)
    ov = _doc_state(doc, create=True).overlay = {"node": node, "legend": legend, "graphs": graphs,
                        "mode": mode_name,
                        "building": building, "vmax": geom["vmax"],
                        "triangles": len(geom["surfaces"]) + len(geom["work_plane"]),
                        "labels": room_labels(building), "label_node": label_node,
                        "label_vis": None, "sensors": [],
                        "rooms": {p.space.Name: room_signature(p.space)
                                  for p in building.rooms}}
    update_labels(doc)
    # a clipping plane toggled or moved later shows and hides the names again
    for sg in graphs:
        try:
            sensor = coin.SoNodeSensor(_graph_changed, doc.Name)
            sensor.attach(sg)
            ov["sensors"].append(sensor)
        except Exception:          # without the sensor the names follow at the next show
            pass
    return geom["vmax"]


def room_signature(space):
    """A room's solid in a few numbers (volume, area, bounding box, mm), or None."""
    try:
        sh = space.Shape
        bb = sh.BoundBox
        return (round(sh.Volume, 3), round(sh.Area, 3),
                tuple(round(v, 3) for v in (bb.XMin, bb.YMin, bb.ZMin, bb.XMax, bb.YMax,
                                            bb.ZMax)))
    except Exception:
        return None


def room_geometry_changed(doc, space):
    """Whether a room's solid differs from the one the shown overlay was built on (True
    when nothing is shown or the room is not in it)."""
    st = _overlay(doc)
    rooms = (st or {}).get("rooms") or {}
    if space.Name not in rooms:
        return True
    sig = room_signature(space)
    return sig is None or sig != rooms[space.Name]


def relabel(doc):
    """The room names of the shown overlay placed again (clear of the fixtures in the
    rooms now), without rebuilding the display; False when nothing is shown."""
    st = _overlay(doc)
    if st is None:
        return False
    st["labels"] = room_labels(st["building"])
    st["label_vis"] = None
    update_labels(doc)
    return True


def update_labels(doc):
    """Draw the room names that :func:`label_visibility` keeps for the clipping planes of
    the document's views now; True if the drawn set changed."""
    st = _overlay(doc)
    if st is None:
        return False
    try:
        planes = clip_planes(st["graphs"])
    except Exception:
        planes = []
    vis = tuple(bool(v) for v in label_visibility(st["building"], st["labels"], planes))
    if vis == st["label_vis"]:
        return False
    st["label_vis"] = vis
    node = st["label_node"]
    node.removeAllChildren()
    node.addChild(build_labels([lab for lab, v in zip(st["labels"], vis) if v]))
    return True


def shown_labels(doc):
    """The room names drawn now in ``doc``'s overlay: [(label, (x, y, z) mm)]."""
    st = _overlay(doc)
    if st is None or st["label_vis"] is None:
        return []
    return [lab for lab, v in zip(st["labels"], st["label_vis"]) if v]


def _graph_changed(name, sensor=None):
    try:
        update_labels(name)
    except Exception:              # a document closing under the sensor
        pass


def show_targets(doc, rooms=None):
    """Evaluate the rooms' targets on fine display meshes (finer still along target
    edges: :func:`target_mesh`) and show them on the document's scale."""
    from invrad_wb.app.pipeline import PipelineSettings, prepare
    from invrad_wb.gui import params
    opts = params.load_display()
    settings = PipelineSettings(flux_lm=1.0, resolution_m=opts["resolution_m"], rooms=rooms)
    building = prepare(doc, settings)
    vmax = document_scale(doc, building.scene.vertex_lux)
    mesh = target_mesh(building, vmax, base_dir=settings.base_dir)
    return show(doc, building, mesh["values"], "Target\nilluminance (lx)", "targets",
                targets=True, vmax=vmax, mesh=mesh)


def show_achieved(doc, building, achieved, vmax=None):
    """The achieved illuminance on the document's scale (:func:`document_scale`, the
    targets' view's: same colour = on target); ``vmax`` overrides it. The result is kept
    for :func:`show_deviation`."""
    _doc_state(doc, create=True).achieved = (building, np.asarray(achieved, dtype=np.float64))
    vmax = vmax or document_scale(doc, building.scene.vertex_lux)
    return show(doc, building, achieved, "Achieved\nilluminance (lx)", "achieved",
                targets=False, vmax=vmax)


def has_achieved(doc):
    return doc is not None and last_achieved(doc) is not None


def drop_achieved(doc):
    """Forget the achieved result (the fixtures changed: its deviation would be stale)."""
    st = _doc_state(doc)
    if st is not None:
        st.achieved = None


def last_achieved(doc):
    """(building, achieved lux per vertex) of the last achieved view of ``doc``, or None."""
    st = _doc_state(doc)
    return st.achieved if st is not None else None


def show_deviation(doc, limit=DEVIATION_LIMIT):
    """The last achieved view's deviation from the targets, -limit..+limit (the report's
    scale and colours). Returns the limit, or None without an achieved result."""
    got = last_achieved(doc)
    if got is None:
        return None
    building, achieved = got
    target = building.scene.vertex_lux
    ref = mean_target(target)
    # on the targets' display mesh (finer along a spot's edge): a smooth rim, not the
    # stair steps of the sampling mesh between vertices with and without a target
    mesh = target_mesh(building, document_scale(doc, target), carry=[achieved])
    dev = deviation(mesh["values"], mesh["carried"][0], ref)
    return show(doc, building, dev, "Deviation from\ntarget", "deviation", targets=False,
                vmax=float(limit), mesh=mesh, deviation=True)


def _switch(doc, title, mode_name, back, forth, ready=None):
    """A show/hide command: ``back(doc)`` when ``mode_name`` is shown (returns False),
    else ``forth(doc)`` (returns True). Errors are reported, not raised, like every GUI
    action, and leave no overlay."""
    import FreeCAD
    from invrad_wb.gui import messages
    doc = doc or FreeCAD.ActiveDocument
    if doc is None or (ready is not None and not ready(doc)):
        return False
    try:
        if is_shown(doc, mode_name):
            back(doc)
            return False
        forth(doc)
    except Exception as exc:
        hide(doc)
        messages.exception(title, exc)
        return False
    return True


def toggle_deviation(doc=None):
    """Switch between the achieved illuminance and its deviation from the targets; True
    if the deviation is shown afterwards."""
    return _switch(doc, "Show deviation", "deviation",
                   lambda d: show_achieved(d, *last_achieved(d)), show_deviation,
                   ready=has_achieved)


def toggle_targets(doc=None):
    """Show the targets, or hide them if they are shown; True if shown afterwards (no
    rooms, a bad target: reported)."""
    return _switch(doc, "Show targets", "targets", hide, show_targets)


def refresh(doc):
    """Rebuild the target display of ``doc`` if it is shown (after targets changed)."""
    if not is_shown(doc, "targets"):
        return
    try:
        show_targets(doc)
    except Exception as exc:             # e.g. the last target was deleted
        hide(doc)
        import FreeCAD
        FreeCAD.Console.PrintWarning(f"invrad: target display hidden: {exc}\n")


def state(doc):
    """The overlay's bookkeeping for ``doc`` (mode, vmax, triangles), or None."""
    ov = _overlay(doc)
    if ov is None:
        return None
    return {k: ov[k] for k in ("mode", "vmax", "triangles")}


def forget(doc_name):
    """Drop everything kept for a closed document."""
    st = _DOCS.pop(doc_name, None)
    if st is not None and st.overlay is not None:
        _detach(st.overlay)


def _detach(overlay):
    for sensor in overlay.get("sensors", []):
        try:
            sensor.detach()
        except Exception:
            pass


#: The left strip of the view that the legend takes (normalised width, of 2): framing
#: keeps the building right of it.
LEGEND_STRIP = 0.30


def frame_rooms(doc, view=None, aspect=None, slack=1.15):
    """Frame a 3D view on the document's rooms (their solids' bounding box), not on
    everything in it (a site's terrain, a far-off survey point): the building fills the
    view right of the legend's strip (``slack``: room for the walls and slabs around
    the rooms). ``aspect``: width / height of the picture to fill
    (default the view's). Orthographic views keep their direction; returns False (and
    fits everything) when the document has no readable room."""
    import FreeCADGui
    from pivy import coin
    from invrad_wb.app.rooms import find_spaces, room_shape
    view = view or FreeCADGui.getDocument(doc.Name).activeView()
    bb = None
    for sp in find_spaces(doc):
        try:
            b = room_shape(sp).BoundBox
        except Exception:             # a room without geometry frames nothing
            continue
        if bb is None:
            bb = b
        else:
            bb.add(b)
    if bb is None:
        view.fitAll()
        return False
    if aspect is None:
        try:
            w, h = view.getSize()
            aspect = w / max(h, 1)
        except Exception:
            aspect = 4.0 / 3.0
    cam = view.getCameraNode()
    share = 1.0 - LEGEND_STRIP / 2.0                  # the width right of the legend
    if not cam.isOfType(coin.SoOrthographicCamera.getClassTypeId()):
        box = coin.SbBox3f(bb.XMin, bb.YMin, bb.ZMin, bb.XMax, bb.YMax, bb.ZMax)
        cam.viewBoundingBox(box, aspect * share, slack)
        return True
    # orthographic: the box's corners on the view's axes (coin's viewBoundingBox fits
    # the box's bounding sphere, which left a plan a third empty)
    rot = cam.orientation.getValue()
    axes = np.array([list(rot.multVec(coin.SbVec3f(*a)).getValue())
                     for a in ((1, 0, 0), (0, 1, 0), (0, 0, 1))])
    corners = np.array([[x, y, z] for x in (bb.XMin, bb.XMax) for y in (bb.YMin, bb.YMax)
                        for z in (bb.ZMin, bb.ZMax)])
    proj = corners @ axes.T                           # (8, 3): right, up, back
    lo, hi = proj.min(axis=0), proj.max(axis=0)
    height = slack * max(hi[1] - lo[1], (hi[0] - lo[0]) / (aspect * share))
    width = height * max(aspect, 1.0)
    mid = 0.5 * (lo + hi)
    depth = hi[2] - lo[2]
    # the box in the middle of the part right of the legend, the eye in front of it
    eye = ((mid[0] - 0.5 * (LEGEND_STRIP / 2.0) * width) * axes[0] + mid[1] * axes[1]
           + (hi[2] + depth + 1000.0) * axes[2])
    cam.position.setValue(coin.SbVec3f(*map(float, eye)))
    cam.height.setValue(float(height))
    cam.focalDistance.setValue(float(depth + 1000.0 + 0.5 * depth))
    # the clipping planes around the building: an image saved before the viewer has
    # redrawn (its auto-clipping sets them then) used the previous camera's, and a view
    # just turned orthographic saved blank
    cam.nearDistance.setValue(1.0)
    cam.farDistance.setValue(float(3.0 * depth + 1000.0 + 10.0 * max(depth, 1000.0)))
    return True


#: name of the clipping planes of a storey view (:func:`storey_view`)
STOREY_CLIP_NAME = "InvRadStoreyClip"
#: a storey view cuts this far below the rooms' ceilings (metres): the roof, the slab
#: above and a ceiling fixture's top go, what hangs in the room stays
STOREY_CLIP_BELOW_M = 0.03


def ceiling_planes(spaces, below_m=STOREY_CLIP_BELOW_M):
    """The planes of the ceilings of ``spaces`` (their solids' faces that face up from the
    room: a flat ceiling, the slopes of a roof), each moved ``below_m`` into the room:
    ``[((3,) unit normal pointing down into the room, distance mm)]`` as coin keeps
    ``normal . p >= distance`` (what lies below every plane)."""
    from invrad_wb.app.rooms import room_shape
    out = []
    for sp in spaces:
        try:
            shape = room_shape(sp)
        except Exception:          # a room without a closed solid adds no plane
            continue
        for f in shape.Faces:
            if "Plane" not in type(f.Surface).__name__:
                continue
            u0, u1, v0, v1 = f.ParameterRange
            n = f.normalAt(0.5 * (u0 + u1), 0.5 * (v0 + v1))     # outward
            if n.z < 0.3:
                continue
            down = -np.array([n.x, n.y, n.z]) / n.Length
            p = np.array([f.CenterOfMass.x, f.CenterOfMass.y, f.CenterOfMass.z])
            d = float(down @ p) + 1000.0 * below_m
            if not any(np.allclose(down, q, atol=1e-3) and abs(d - e) < 1.0 for q, e in out):
                out.append((down, d))
    return out


def storey_view(doc, spaces, below_m=STOREY_CLIP_BELOW_M):
    """Show the rooms ``spaces`` (e.g. a storey's) from above: clipping planes just under
    their ceilings take away what is above them in every 3D view of ``doc`` (the roof, the
    slab and the storeys above, which FreeCAD 0.20 draws with their BuildingPart even when
    the elements are hidden, and NativeIFC's roof), while the room names, the legend, the
    false colour of the rooms and the fixtures under the ceilings stay. Replaces an earlier
    storey view; :func:`clear_storey_view` ends it. Returns the number of planes."""
    from pivy import coin
    clear_storey_view(doc)
    planes = ceiling_planes(spaces, below_m)
    for sg in _graphs(doc):
        at = 0
        ov = _overlay(doc)
        if ov is not None and sg.findChild(ov["legend"]) >= 0:
            at = sg.findChild(ov["legend"]) + 1      # the legend is never clipped
        for normal, dist in planes:
            node = coin.SoClipPlane()
            node.setName(STOREY_CLIP_NAME)
            node.plane = coin.SbPlane(coin.SbVec3f(*map(float, normal)), float(dist))
            sg.insertChild(node, at)
    update_labels(doc)
    return len(planes)


def clear_storey_view(doc):
    """Remove the clipping planes of :func:`storey_view` from ``doc``'s views; their
    number."""
    n = 0
    for sg in _graphs(doc):
        for i in reversed(range(sg.getNumChildren())):
            child = sg.getChild(i)
            if child.getName() == STOREY_CLIP_NAME:
                sg.removeChild(i)
                n += 1
    if n:
        update_labels(doc)
    return n
