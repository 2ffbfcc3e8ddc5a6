"""Where each room's name is written in the 3D view, and which names to draw (no GUI).

A room's name stands over its floor, clear of its walls, fixtures and the objects standing
in it (a stair, furniture); a name cut away by a clipping plane, or under a storey above
that hides its room, is not drawn (:func:`label_visibility`), so that one storey's names
never print over another's.
"""
import numpy as np

#: Room names: the height above a room's floor that objects standing in it must reach
#: into to count as obstacles for its name, and the floor step that makes another storey.
LABEL_CLEAR_HEIGHT_M = 2.0
#: Where a room's name is written: this far below its lowest ceiling, at least this high
#: above its floor (over a work plane).
LABEL_BELOW_CEILING_M = 0.3
LABEL_MIN_HEIGHT_M = 0.9
STOREY_STEP_M = 1.0
#: Objects that are never obstacles for a room's name (the envelope, the rooms, fixtures).
_NOT_OBSTACLES = {"Space", "Wall", "Structure", "Window", "Door", "Floor", "Building",
                  "Site", "BuildingPart", "Equipment", "Roof", "Covering", "InvRadTarget"}
_NOT_OBSTACLE_IFC = {"Slab", "Wall", "Window", "Door", "Roof", "Covering", "Beam", "Column",
                     "Light Fixture", "Building Storey", "Building", "Site", "Space"}
#: The same for NativeIFC objects (their ``IfcClass``).
_NOT_OBSTACLE_CLASS = {"IfcSlab", "IfcWall", "IfcWallStandardCase", "IfcWindow", "IfcDoor",
                       "IfcRoof", "IfcCovering", "IfcBeam", "IfcColumn", "IfcLightFixture",
                       "IfcBuildingStorey", "IfcBuilding", "IfcSite", "IfcSpace",
                       "IfcProject", "IfcOpeningElement", "IfcPlate", "IfcMember"}


#: The direction towards the eye of FreeCAD's isometric view (Std_ViewIsometric): room
#: names keep clear of what stands in a room both from above and in this view.
ISO_EYE = (1.0, -1.0, 1.0)
#: Pendant rods are sampled this often (metres) between a luminaire and its ceiling.
ROD_STEP_M = 0.1


def room_labels(building, height_m=None):
    """``[(room label, (x, y, z) mm)]``: where each room's name is written: inside the
    floor's outline as far as possible from the walls, from the room's light fixtures
    (with their pendant rods up to the ceiling) and from other objects standing in the
    room (a stair, furniture), so that the name covers none of them, seen from above (as
    on the design report's plans) and in FreeCAD's isometric view (:data:`ISO_EYE`: what
    stands below or above the name's height is moved along the view direction onto its
    plane, :func:`iso_shadow`); :data:`LABEL_BELOW_CEILING_M` below the room's lowest
    ceiling (at least :data:`LABEL_MIN_HEIGHT_M` above its floor), or ``height_m`` above
    its floor: seen from above at an angle the name then stands in the room's open top,
    not on the wall in front of it."""
    # the names are screen text (about 7 x 13 px a character); seen whole, a building of
    # extent X metres spans about 500 px: a character is about X / 70 m wide
    allv = building.scene.vertices
    char_m = float(np.max(np.ptp(allv[:, :2], axis=0))) / 70.0 if len(allv) else 0.1
    from invrad_wb.app.rooms import room_name
    out = []
    for p in building.rooms:
        # the name the user knows: a NativeIFC IfcSpace's LongName ("Wohnen"), not its
        # Label (the IFC Name, "2")
        name = room_name(p.space)
        m = p.mesh
        tri = m.triangles[m.floor_triangles] if m.floor_triangles.any() else m.triangles
        corners = m.vertices[tri]                       # (t, 3, 3) metres
        v = corners.reshape(-1, 3)
        lo = v.min(axis=0)
        c = 0.5 * (v.min(axis=0) + v.max(axis=0))[:2]
        ceil = [i for i, k in enumerate(m.face_kind) if k == "ceiling"]
        top = m.vertices[np.unique(m.triangles[np.isin(m.triangle_face, ceil)])] \
            if ceil else m.vertices
        ceiling_z = float(top[:, 2].min())
        if height_m is not None:
            z = lo[2] + height_m
        else:
            z = max(lo[2] + LABEL_MIN_HEIGHT_M, ceiling_z - LABEL_BELOW_CEILING_M)
        edges = _outline_edges(corners) if m.floor_triangles.any() else []
        if len(edges):
            fx, fr = _fixture_points(p.space, ceiling_z)
            obst = _obstacle_xyz(p.space, edges, lo[2], lo[2] + LABEL_CLEAR_HEIGHT_M)
            things = np.asarray(fx + obst, dtype=np.float64).reshape(-1, 3)
            radii = np.asarray(fr + [0.0] * len(obst), dtype=np.float64)
            c = place_label(edges, z, ceiling_z, things, radii, char_m, len(name))
        out.append((name, (1000.0 * c[0], 1000.0 * c[1], 1000.0 * z)))
    return out


#: The eye of a view from above (plans, Std_ViewTop).
TOP_EYE = (0.0, 0.0, 1.0)
#: What a name keeps clear of beyond the things themselves (metres): a fixture's body
#: outline, a wall's face.
LABEL_MARGIN_M = 0.1


def screen_axes(eye):
    """(right, up) unit vectors (3,) of an orthographic view from ``eye`` whose screen is
    upright (world Z up on screen; seen from straight above, X right and Y up)."""
    e = np.asarray(eye, dtype=np.float64)
    e = e / np.linalg.norm(e)
    right = np.cross((0.0, 0.0, 1.0), e)
    if np.linalg.norm(right) < 1e-9:                 # from straight above (or below)
        return np.array([1.0, 0.0, 0.0]), np.array([0.0, np.sign(e[2]) or 1.0, 0.0])
    right /= np.linalg.norm(right)
    return right, np.cross(e, right)


def text_box(char_m, n_chars):
    """A name's box on screen around its anchor, metres: (half width, half height,
    upward offset of its middle). FreeCAD draws it centred across and standing on the
    anchor (SoText2, CENTER): a character about ``char_m`` wide and 1.9 as tall."""
    h = 1.9 * char_m
    return 0.5 * char_m * max(n_chars, 1), 0.55 * h, 0.3 * h


def _disc_points(things, radii, k=16):
    """Each thing (k, 3) with radius > 0 replaced by ``k`` points on its horizontal
    circle (a fixture's body, as any view shows its outline), others kept."""
    things = np.asarray(things, dtype=np.float64).reshape(-1, 3)
    radii = np.asarray(radii, dtype=np.float64).reshape(-1)
    pts = [things[radii <= 0]]
    a = np.linspace(0.0, 2.0 * np.pi, k, endpoint=False)
    ring = np.stack([np.cos(a), np.sin(a), np.zeros_like(a)], axis=1)
    for c, r in zip(things[radii > 0], radii[radii > 0]):
        pts.append(c + r * ring)
        pts.append(c[None])
    return np.concatenate(pts) if pts else np.zeros((0, 3))


def label_clearance(anchors, z, points, box, eyes=(TOP_EYE, ISO_EYE)):
    """(g,) metres on screen between each anchor's name box (anchors (g, 2) in plan at
    height ``z``, ``box`` from :func:`text_box`) and the nearest of ``points`` (k, 3),
    the least over the views from ``eyes``; negative where the box covers a point."""
    anchors = np.asarray(anchors, dtype=np.float64).reshape(-1, 2)
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    best = np.full(len(anchors), np.inf)
    if not len(pts):
        return best
    hx, hy, up = box
    a3 = np.column_stack([anchors, np.full(len(anchors), float(z))])
    for eye in eyes:
        r, u = screen_axes(eye)
        sa = np.column_stack([a3 @ r, a3 @ u + up])
        sp = np.unique(np.round(np.column_stack([pts @ r, pts @ u]), 2), axis=0)
        block = max(1, 2_000_000 // len(sp))          # a few MB at a time
        for i in range(0, len(sa), block):
            s = sa[i:i + block]
            gap = np.maximum(np.abs(s[:, None, 0] - sp[None, :, 0]) - hx,
                             np.abs(s[:, None, 1] - sp[None, :, 1]) - hy)
            best[i:i + block] = np.minimum(best[i:i + block], gap.min(axis=1))
    return best


def place_label(edges, z, wall_top, things, radii, char_m, n_chars,
                eyes=(TOP_EYE, ISO_EYE), n=31):
    """Where a room's name is anchored (plan point (2,), metres, at height ``z``): inside
    the floor's outline ``edges`` (e, 2, 2), its box (:func:`text_box`) as far as possible
    from the walls (the outline's faces from ``z`` up to ``wall_top``) and from ``things``
    (k, 3): fixtures' discs of ``radii`` (k,) and points (radius 0: rods, stairs,
    furniture), as seen in every view from ``eyes`` (from above and FreeCAD's
    isometric); of the points with nearly the best clearance, the one nearest the middle.
    """
    from invrad_wb.core.geometry.outline import outline_raster
    edges = np.asarray(edges, dtype=np.float64).reshape(-1, 2, 2)
    g, lo, hi = outline_raster(edges, n)
    if len(g) == 0:
        return edges.reshape(-1, 2).mean(axis=0)
    box = text_box(char_m, n_chars)
    box = (box[0] + LABEL_MARGIN_M, box[1] + LABEL_MARGIN_M, box[2])
    wall = np.asarray(_edge_points(edges, 0.5 * char_m), dtype=np.float64).reshape(-1, 2)
    walls = np.concatenate([np.column_stack([wall, np.full(len(wall), h)])
                            for h in (float(z), max(float(wall_top), float(z)))])
    pts = np.concatenate([walls, _disc_points(things, radii)])
    d = label_clearance(g, z, pts, box, eyes)
    step = float(np.min((hi - lo) / (n - 1)))
    near_best = d >= d.max() - 0.25 * step
    mid = 0.5 * (lo + hi)
    k = np.flatnonzero(near_best)
    return g[k[int(np.argmin(np.linalg.norm(g[k] - mid, axis=1)))]]


def iso_shadow(points, z, eye=ISO_EYE):
    """(k, 2) plan points at height ``z`` that an orthographic view from ``eye`` shows
    where it shows ``points`` (k, 3), metres: each moved along the view direction."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    e = np.asarray(eye, dtype=np.float64)
    return pts[:, :2] - (pts[:, 2:3] - z) * (e[:2] / e[2])


def _edge_points(edges, step):
    """Points (metres) every ``step`` along plan edges (e, 2, 2)."""
    out = []
    for a, b in edges:
        n = max(int(np.ceil(np.linalg.norm(b - a) / max(step, 1e-3))), 1)
        t = np.linspace(0.0, 1.0, n + 1)[:, None]
        out += list(a + t * (b - a))
    return out


def label_visibility(building, labels, planes=()):
    """(k,) bool: which room names to draw, one storey's over another's.

    A name is hidden when a clipping plane cuts its room away (the point under the name
    :data:`LABEL_MIN_HEIGHT_M` above the floor), or when a room of a storey above (floor at least :data:`STOREY_STEP_M` higher)
    that the planes keep covers the name's point in plan: its floor hides the room below
    from above, and the name would be printed over the room upstairs (the FZK-Haus
    Galerie's name over the Flur below it).

    Parameters
    ----------
    building : BuildingScene
    labels : list from :func:`room_labels` (one per room, in order)
    planes : list of ((3,) normal, distance mm): coin clip planes, which keep the points
        with ``normal . p >= distance``
    """
    def kept(pts_mm):
        ok = np.ones(len(pts_mm), dtype=bool)
        for n, d in planes:
            ok &= pts_mm @ np.asarray(n, dtype=np.float64) >= d - 1e-6
        return ok
    pts = np.array([xyz for _, xyz in labels], dtype=np.float64).reshape(-1, 3)
    floors = []
    for p in building.rooms:
        m = p.mesh
        tri = m.triangles[m.floor_triangles] if m.floor_triangles.any() else m.triangles
        corners = m.vertices[tri]
        z = float(corners[:, :, 2].min()) if len(corners) else 0.0
        floors.append((z, corners[:, :, :2],
                       bool(kept(1000.0 * corners.reshape(-1, 3)).any()) if len(corners)
                       else False))
    # a room is seen when its name's spot LABEL_MIN_HEIGHT_M over the floor is kept (a
    # plan cut below the ceilings keeps the rooms under it)
    probe = pts.copy()
    probe[:, 2] = [1000.0 * (f[0] + LABEL_MIN_HEIGHT_M) for f in floors[:len(pts)]]
    vis = kept(probe)
    for i, (zi, _, _) in enumerate(floors):
        if not vis[i]:
            continue
        for j, (zj, tri, shown) in enumerate(floors):
            if j != i and shown and zj >= zi + STOREY_STEP_M and \
                    _in_triangles(pts[i, :2] / 1000.0, tri):
                vis[i] = False
                break
    return vis


def _in_triangles(p, tri):
    """Is the plan point ``p`` (2,) inside any of the triangles ``tri`` (t, 3, 2)?"""
    if not len(tri):
        return False
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]

    def cross(u, v):
        return u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]
    d1, d2, d3 = cross(b - a, p - a), cross(c - b, p - b), cross(a - c, p - c)
    neg = (d1 < 0) | (d2 < 0) | (d3 < 0)
    pos = (d1 > 0) | (d2 > 0) | (d3 > 0)
    return bool(np.any(~(neg & pos)))


def _obstacle_xyz(space, edges, z0, z1):
    """Points (metres, with their heights) of objects standing in a room between heights
    ``z0`` and ``z1`` (a stair, furniture, a railing): vertices of their shapes inside the floor's
    outline ``edges``. The building's envelope (walls, slabs, doors, windows, the rooms
    themselves) and the light fixtures (counted apart) are not obstacles."""
    from invrad_wb.app.document import object_type
    from invrad_wb.core.geometry.outline import inside_outline
    doc = getattr(space, "Document", None)
    if doc is None:
        return []
    lo = edges.reshape(-1, 2).min(axis=0) * 1000.0
    hi = edges.reshape(-1, 2).max(axis=0) * 1000.0
    out = []
    for obj in doc.Objects:
        try:
            if object_type(obj) in _NOT_OBSTACLES or getattr(obj, "IfcType", "") in \
                    _NOT_OBSTACLE_IFC or getattr(obj, "IfcClass", "") in \
                    _NOT_OBSTACLE_CLASS or not getattr(obj, "Visibility", True):
                continue
            shape = getattr(obj, "Shape", None)
            if shape is None or shape.isNull() or not shape.Vertexes:
                continue
            bb = shape.BoundBox
            if (bb.XMax < lo[0] or bb.XMin > hi[0] or bb.YMax < lo[1] or bb.YMin > hi[1]
                    or bb.ZMax < 1000.0 * z0 or bb.ZMin > 1000.0 * z1
                    or bb.XLength > 0.9 * (hi[0] - lo[0]) and bb.YLength > 0.9 * (hi[1] - lo[1])):
                continue
            xyz = _shape_points(shape)
            xyz = xyz[(xyz[:, 2] >= 1000.0 * z0 - 1.0) & (xyz[:, 2] <= 1000.0 * z1)] / 1000.0
        except Exception:          # an object without readable geometry is no obstacle
            continue
        if len(xyz):
            out += list(xyz[inside_outline(edges, xyz[:, :2])])
    xyz = _native_obstacles(space)
    if len(xyz):
        xyz = xyz[(xyz[:, 2] >= z0 - 1e-3) & (xyz[:, 2] <= z1)]
        out += list(xyz[inside_outline(edges, xyz[:, :2])])
    return out


def _shape_points(shape, step_mm=100.0):
    """(k, 3) points (mm) along a shape's edges every ``step_mm`` and its vertices: a
    cylinder's outline, not only its two seam vertices."""
    pts = [[v.Point.x, v.Point.y, v.Point.z] for v in shape.Vertexes]
    for e in shape.Edges:
        try:
            n = max(int(np.ceil(e.Length / step_mm)), 1)
            pts += [[p.x, p.y, p.z] for p in e.discretize(Number=n + 1)]
        except Exception:          # an edge that cannot be sampled keeps its vertices
            continue
    return np.asarray(pts, dtype=np.float64).reshape(-1, 3)


#: IFC classes that stand in a room and that a name must not cover (NativeIFC draws
#: them from the file: they are no document objects to read a shape from).
NATIVE_OBSTACLES = ("IfcStair", "IfcStairFlight", "IfcRamp", "IfcRampFlight", "IfcRailing",
                    "IfcFurnishingElement", "IfcFurniture", "IfcSanitaryTerminal")
_NATIVE_CACHE = {}       # id of the IFC file -> (k, 3) vertices, metres


def _native_obstacles(space):
    """(k, 3) vertices (metres, world coordinates) of the stairs, railings and furniture
    of a NativeIFC space's IFC file, from ifcopenshell's geometry (once per file); an
    empty array for a classic room or where the geometry cannot be read."""
    from invrad_wb.app.rooms import is_native
    if not is_native(space):
        return np.zeros((0, 3))
    try:
        from invrad_wb.app import nativeifc
        ifc = nativeifc.ifcfile(space)
    except Exception:
        return np.zeros((0, 3))
    got = _NATIVE_CACHE.get(id(ifc))
    if got is not None and got[0] is ifc:
        return got[1]
    try:
        from invrad_wb.app.roomzones import element_vertices
        pts = [v for _, _, v in element_vertices(ifc, NATIVE_OBSTACLES)]
    except Exception:
        pts = []
    xyz = np.concatenate(pts) if pts else np.zeros((0, 3))
    _NATIVE_CACHE[id(ifc)] = (ifc, xyz)
    return xyz


def _outline_edges(tri):
    """Boundary edges (e, 2, 2) in plan of a set of floor triangles (t, 3, 3), metres."""
    xy = np.round(tri[:, :, :2], 6)
    e = np.concatenate([xy[:, [0, 1]], xy[:, [1, 2]], xy[:, [2, 0]]])
    a, b = e[:, 0], e[:, 1]
    swap = (a[:, 0] > b[:, 0]) | ((a[:, 0] == b[:, 0]) & (a[:, 1] > b[:, 1]))
    key = np.where(swap[:, None], np.hstack([b, a]), np.hstack([a, b]))   # either direction
    _, inv, cnt = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    return e[cnt[np.asarray(inv).reshape(-1)] == 1]


def _fixture_points(space, ceiling_z):
    """Points (metres) of the light fixtures in a Space and their plan radii (metres):
    each luminaire with the radius of its body (a panel's half diagonal), and for a
    pendant its rod up to ``ceiling_z`` every :data:`ROD_STEP_M` (radius 0); none if
    unreadable."""
    try:
        from invrad_wb.app import fixtures
        from invrad_wb.app.fixturebody import fixture_size
        lums = [fixtures.fixture_luminaire(o)
                for o in fixtures.room_fixtures(space, generated_only=False)]
    except Exception:
        return [], []
    out, radii = [], []
    for lum in lums:
        x, y, z = np.asarray(lum.position, dtype=np.float64)
        try:
            size = fixture_size(lum)
            r = size[1] if size[0] == "disc" else 0.5 * float(np.hypot(size[1], size[2]))
        except Exception:
            r = 0.0
        n = max(int(np.ceil((ceiling_z - z) / ROD_STEP_M)), 0)
        out += [(x, y, z + k * (ceiling_z - z) / max(n, 1)) for k in range(n + 1)]
        radii += [float(r)] + [0.0] * n
    return out, radii
