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

from invrad_wb.core.output import images as _images

#: The colour map and the scale rule are the report's (:mod:`invrad_wb.core.output.images`), so
#: that the 3D view and the report read the same: viridis, RGB in [0, 1] here.
VIRIDIS = _images.VIRIDIS / 255.0
nice_max = _images.nice_max
#: Colours (RGB in [0, 1]) of vertices without a target (the report's grey) and of shade
#: targets (0 lx, "must stay dark"; darker than the map's low end).
NO_TARGET_RGB = (150 / 255.0, 150 / 255.0, 150 / 255.0)
SHADE_RGB = (0.02, 0.02, 0.02)
EDGE_RGB = (0.1, 0.1, 0.1)

#: The deviation view's scale: -50 % .. +50 % (the report's).
DEVIATION_LIMIT = _images.DEVIATION_LIMIT
#: The lux scale's top over the largest target (:func:`lux_scale`).
SCALE_HEADROOM = 1.5
#: Refinement of the target display along target edges (:func:`target_mesh`): levels, and
#: the value step (fraction of the scale) across a triangle that counts as an edge.
EDGE_LEVELS = 3
EDGE_STEP = 0.2

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

#: Node names, so that a scene graph can be searched for the overlay.
OVERLAY_NAME = "InvRadFalseColour"
LEGEND_NAME = "InvRadLegend"


def colour_map(x):
    """Viridis: x in [0, 1] (any shape) -> (..., 3) RGB in [0, 1]."""
    t = np.clip(np.asarray(x, dtype=np.float64), 0.0, 1.0) * (len(VIRIDIS) - 1)
    i = np.minimum(np.floor(t).astype(np.int64), len(VIRIDIS) - 2)
    f = (t - i)[..., None]
    return VIRIDIS[i] * (1 - f) + VIRIDIS[i + 1] * f


def ticks(vmax, n=5):
    """``n`` evenly spaced tick values from 0 to ``vmax``."""
    return [vmax * i / (n - 1) for i in range(n)]


def colours(values, vmax, targets=True):
    """False colours of illuminance values.

    Parameters
    ----------
    values : (n,) float64, lux (NaN = no target)
    vmax : float, lux at the top of the scale
    targets : bool
        Target mode: NaN -> :data:`NO_TARGET_RGB`, exactly 0 -> :data:`SHADE_RGB`.
        Otherwise NaN is also grey and 0 is the bottom of the scale.

    Returns
    -------
    (n, 3) float64 RGB in [0, 1]
    """
    v = np.asarray(values, dtype=np.float64)
    rgb = colour_map(np.nan_to_num(v) / vmax)
    rgb[~np.isfinite(v)] = NO_TARGET_RGB
    if targets:
        rgb[np.isfinite(v) & (v == 0)] = SHADE_RGB
    return rgb


def label(v):
    return f"{v:.0f}" if v >= 10 or v == 0 else f"{v:.2g}"


def face_groups(building):
    """(m,) int: one id per boundary face of each room, and one per work plane."""
    groups = np.full(len(building.scene.faces), -1, dtype=np.int64)
    base = 0
    for p in building.rooms:
        start = p.faces.start
        n_surf = len(p.mesh.triangles)
        groups[start:start + n_surf] = base + p.mesh.triangle_face
        base += p.mesh.n_faces
        if p.n_work_plane:
            groups[start + n_surf:p.faces.stop] = base
            base += 1
    return groups


def open_faces(building):
    """(m,) bool: the faces of open borders (a room's boundary where it meets another
    room with no wall: virtual, no target); the overlay does not draw them."""
    sc = building.scene
    virt = np.asarray(sc.face_virtual, dtype=bool)
    out = np.zeros(len(sc.faces), dtype=bool)
    for p in building.rooms:
        rows = slice(p.faces.start, p.faces.start + len(p.mesh.triangles))
        out[rows] = virt[rows]
    return out


def boundary_edges(faces, groups):
    """(k, 2) vertex index pairs: edges used by one triangle only within their group."""
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    g = np.concatenate([groups, groups, groups])
    key = np.concatenate([np.sort(e, axis=1), g[:, None]], axis=1)
    uniq, inv, count = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    once = count[inv.reshape(-1)] == 1
    return e[once]


def overlay_geometry(building, values, offset_m=0.01, targets=True, vmax=None, mesh=None,
                     rgb=None):
    """What the overlay draws, in FreeCAD's millimetres.

    Parameters
    ----------
    building : BuildingScene
    values : (n,) float64, lux per vertex of ``building.scene`` (or of ``mesh``)
    mesh : dict from :func:`target_mesh`, optional: a finer display mesh to draw instead
        of the building's sampling mesh (``values`` are then per vertex of it)
    rgb : (n, 3) float64, optional: the vertices' colours (default :func:`colours` of the
        values, lux)

    Returns
    -------
    dict with
      points : (n, 3) float64, mm, offset ``offset_m`` along each vertex's room-side normal
      surfaces, work_plane : (k, 3) int64 triangles (counter-clockwise from the room)
      rgb : (n, 3) float64
      edges : (j, 2) int64, outlines of the room faces and work planes
      vmax : float, top of the scale (lux)
    """
    if mesh is None:
        sc = building.scene
        mesh = {"vertices": sc.vertices, "normals": sc.vertex_normals, "faces": sc.faces,
                "groups": face_groups(building),
                "virtual": np.asarray(sc.face_virtual, dtype=bool),
                "open": open_faces(building)}
    v = np.asarray(values, dtype=np.float64)
    if vmax is None:
        finite = v[np.isfinite(v)]
        vmax = nice_max(finite.max() if finite.size else 1.0)
    pts = (mesh["vertices"] + offset_m * mesh["normals"]) * 1000.0
    faces, virt = mesh["faces"], mesh["virtual"]
    # open borders are not surfaces: drawn, they would stand as a false-colour wall
    # between two rooms that have none
    keep = ~np.asarray(mesh.get("open", np.zeros(len(faces), dtype=bool)), dtype=bool)
    return {"points": pts, "surfaces": faces[~virt & keep], "work_plane": faces[virt & keep],
            "rgb": colours(v, vmax, targets) if rgb is None else np.asarray(rgb),
            "edges": boundary_edges(faces[keep], mesh["groups"][keep]),
            "vmax": float(vmax)}


def lux_scale(target_lux):
    """The one lux scale of a document's target and achieved views: the largest target
    with :data:`SCALE_HEADROOM` above it, rounded up (:func:`nice_max`), so that a target
    reads the same colour in both views and light up to half again as much stays
    readable (more takes the top colour, the top tick reads "<top>+")."""
    t = np.asarray(target_lux, dtype=np.float64) if target_lux is not None else np.zeros(0)
    t = t[np.isfinite(t)]
    return nice_max(SCALE_HEADROOM * t.max() if t.size else 1.0)


def subdivide(points, tris, mark, *per_vertex):
    """Conforming refinement: split the ``mark`` ed triangles in four, and their neighbours
    in two (or in four where two of their edges were split), so that no vertex lies on
    another triangle's edge (no cracks, no colour seams).

    Parameters
    ----------
    points : (n, 3) float64
    tris : (m, 3) int64
    mark : (m,) bool
    per_vertex : (n, ...) arrays interpolated at the new midpoints (e.g. normals)

    Returns
    -------
    points (n', 3), tris (m', 3), parent (m',) index of each new triangle's triangle in
    ``tris``, then the ``per_vertex`` arrays extended to n'.
    """
    tris = np.asarray(tris, dtype=np.int64)
    n = len(points)
    e = np.stack([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]], axis=1)   # (m, 3, 2)
    k = np.min(e, axis=2) * n + np.max(e, axis=2)                               # (m, 3)
    split = np.unique(k[np.asarray(mark, dtype=bool)])
    while True:
        s = np.isin(k, split)
        two = s.sum(axis=1) == 2
        if not two.any():
            break
        split = np.union1d(split, k[two][~s[two]])
    s = np.isin(k, split)
    c = s.sum(axis=1)
    a, b = split // n, split % n
    pts = np.concatenate([points, 0.5 * (points[a] + points[b])])
    extra = [np.concatenate([x, 0.5 * (x[a] + x[b])]) for x in per_vertex]
    mid = np.where(s, n + np.searchsorted(split, k), -1)                        # (m, 3)
    out, parent = [tris[c == 0]], [np.flatnonzero(c == 0)]
    one = np.flatnonzero(c == 1)
    if len(one):
        r = np.argmax(s[one], axis=1)
        t0, t1, t2 = (tris[one, (r + j) % 3] for j in range(3))
        m = mid[one, r]
        out += [np.stack([t0, m, t2], 1), np.stack([m, t1, t2], 1)]
        parent += [one, one]
    four = np.flatnonzero(c == 3)
    if len(four):
        t0, t1, t2 = tris[four, 0], tris[four, 1], tris[four, 2]
        m01, m12, m20 = mid[four, 0], mid[four, 1], mid[four, 2]
        out += [np.stack(q, 1) for q in ((t0, m01, m20), (m01, t1, m12), (m20, m12, t2),
                                         (m01, m12, m20))]
        parent += [four] * 4
    return (pts, np.concatenate(out), np.concatenate(parent), *extra)


def edge_triangles(tri_values, vmax, step=None):
    """(m,) bool: triangles across a target's edge, given their vertices' values (m, 3)
    lux: some vertices with a target and some without, or values differing by more than
    ``step`` (default :data:`EDGE_STEP`) times the top of the scale (a shade disc)."""
    v = np.asarray(tri_values, dtype=np.float64)
    fin = np.isfinite(v)
    mixed = fin.any(axis=1) & ~fin.all(axis=1)
    rng = np.where(fin, v, -np.inf).max(axis=1) - np.where(fin, v, np.inf).min(axis=1)
    rng = np.where(fin.any(axis=1), rng, 0.0)
    return mixed | (rng > (EDGE_STEP if step is None else step) * vmax)


def target_mesh(building, vmax, levels=None, base_dir=None, carry=()):
    """A display mesh for the targets, finer along their edges, with the targets on it.

    The building's sampling mesh draws a spot's round edge as stair steps one mesh cell
    high (per-vertex colours between a vertex with a target and one without). Here the
    triangles across an edge (:func:`edge_triangles`) are split (:func:`subdivide`) and
    the room's targets evaluated again on the new vertices, ``levels`` times (default
    :data:`EDGE_LEVELS`: steps 8 times smaller); the rest of the mesh is unchanged.
    ``carry``: per-vertex arrays of the building scene (the achieved light) taken along,
    linearly interpolated at the new vertices (as the coarse mesh would draw them).

    Returns
    -------
    dict: vertices (n, 3) m, normals (n, 3), faces (k, 3), groups (k,) as
    :func:`face_groups`, virtual (k,) bool (work planes), open (k,) bool (open borders,
    :func:`open_faces`), values (n,) lux, carried: the ``carry`` arrays on the display
    mesh's vertices
    """
    from invrad_wb.core.model import targets as CT
    sc = building.scene
    levels = EDGE_LEVELS if levels is None else int(levels)
    groups_all = face_groups(building)
    virt_all = np.asarray(sc.face_virtual, dtype=bool)
    open_all = open_faces(building)
    V, N, F, G, W, L, O = [], [], [], [], [], [], []
    carry = [np.asarray(c, dtype=np.float64) for c in carry]
    C = [[] for _ in carry]
    nv = 0
    for p in building.rooms:
        n_surf = len(p.mesh.triangles)
        s0 = p.faces.start
        for part, rows in (("surf", slice(s0, s0 + n_surf)), ("wp", slice(s0 + n_surf,
                                                                           p.faces.stop))):
            tri = sc.faces[rows]
            if not len(tri):
                continue
            uniq, inv = np.unique(tri, return_inverse=True)
            v, nrm = sc.vertices[uniq], sc.vertex_normals[uniq]
            t = np.asarray(inv).reshape(-1, 3)
            groups = groups_all[rows]
            opened = open_all[rows]
            vals = sc.vertex_lux[uniq] if sc.vertex_lux is not None else np.full(len(v),
                                                                                  np.nan)
            cv = [c[uniq] for c in carry]
            if part == "surf" and p.targets:
                tf = np.asarray(p.mesh.triangle_face)
                for _ in range(levels):
                    mark = edge_triangles(vals[t], vmax)
                    if not mark.any():
                        break
                    v, t, parent, nrm, *cv = subdivide(v, t, mark, nrm, *cv)
                    tf, groups, opened = tf[parent], groups[parent], opened[parent]
                    vals = CT.evaluate(v, t, tf, p.targets, source=p.space.Label,
                                       label=p.mesh.face_label, base_dir=base_dir)
                nrm = nrm / np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-12)
            V.append(v)
            N.append(nrm)
            F.append(t + nv)
            G.append(groups)
            W.append(np.full(len(t), part == "wp") & virt_all[rows][0])
            L.append(vals)
            O.append(opened)
            for acc, c in zip(C, cv):
                acc.append(c)
            nv += len(v)
    return {"vertices": np.concatenate(V), "normals": np.concatenate(N),
            "faces": np.concatenate(F), "groups": np.concatenate(G),
            "virtual": np.concatenate(W), "values": np.concatenate(L),
            "open": np.concatenate(O), "carried": [np.concatenate(acc) for acc in C]}


def room_labels(building, height_m=None):
    """``[(room label, (x, y, z) mm)]``: where each room's name is written: inside the
    floor's outline as far as possible from the walls, from the room's light fixtures and
    from other objects standing in the room (a stair, furniture), so that the name covers
    none of them (as on the design report's plans); :data:`LABEL_BELOW_CEILING_M` below
    the room's lowest ceiling (at least :data:`LABEL_MIN_HEIGHT_M` above its floor), or
    ``height_m`` above its floor: seen from above at an angle the name then stands in
    the room's open top, not on the wall in front of it."""
    from invrad_wb.core.output.design_report import label_point
    # the names are screen text (about 7 x 13 px a character); seen whole, a building of
    # extent X metres spans about 500 px: a character is about X / 70 m wide
    allv = building.scene.vertices
    char_m = float(np.max(np.ptp(allv[:, :2], axis=0))) / 70.0 if len(allv) else 0.1
    out = []
    for p in building.rooms:
        m = p.mesh
        tri = m.triangles[m.floor_triangles] if m.floor_triangles.any() else m.triangles
        corners = m.vertices[tri]                       # (t, 3, 3) metres
        v = corners.reshape(-1, 3)
        lo = v.min(axis=0)
        c = 0.5 * (v.min(axis=0) + v.max(axis=0))[:2]
        edges = _outline_edges(corners) if m.floor_triangles.any() else []
        if len(edges):
            half = (0.5 * char_m * max(len(p.space.Label), 1) + 0.1, char_m + 0.1)
            # the walls count as points too, in label boxes: a long name keeps further
            # from the walls beside it than from those above and below it
            avoid = (_fixture_xy(p.space) + _edge_points(edges, 0.5 * char_m)
                     + _obstacle_xy(p.space, edges, lo[2], lo[2] + LABEL_CLEAR_HEIGHT_M))
            c = label_point(edges, avoid, half_size=half)
        if height_m is not None:
            z = lo[2] + height_m
        else:
            ceil = [i for i, k in enumerate(m.face_kind) if k == "ceiling"]
            top = m.vertices[np.unique(m.triangles[np.isin(m.triangle_face, ceil)])] \
                if ceil else m.vertices
            z = max(lo[2] + LABEL_MIN_HEIGHT_M,
                    float(top[:, 2].min()) - LABEL_BELOW_CEILING_M)
        out.append((p.space.Label, (1000.0 * c[0], 1000.0 * c[1], 1000.0 * z)))
    return out


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


def _obstacle_xy(space, edges, z0, z1):
    """Plan points (metres) of objects standing in a room between heights ``z0`` and
    ``z1`` (a stair, furniture, a railing): vertices of their shapes inside the floor's
    outline ``edges``. The building's envelope (walls, slabs, doors, windows, the rooms
    themselves) and the light fixtures (counted apart) are not obstacles."""
    from invrad_wb.app.document import object_type
    from invrad_wb.core.output.design_report import _inside
    doc = getattr(space, "Document", None)
    if doc is None:
        return []
    lo = edges.reshape(-1, 2).min(axis=0) * 1000.0
    hi = edges.reshape(-1, 2).max(axis=0) * 1000.0
    out = []
    for obj in doc.Objects:
        try:
            if object_type(obj) in _NOT_OBSTACLES or getattr(obj, "IfcType", "") in \
                    _NOT_OBSTACLE_IFC or not getattr(obj, "Visibility", True):
                continue
            shape = getattr(obj, "Shape", None)
            if shape is None or shape.isNull() or not shape.Vertexes:
                continue
            bb = shape.BoundBox
            if (bb.XMax < lo[0] or bb.XMin > hi[0] or bb.YMax < lo[1] or bb.YMin > hi[1]
                    or bb.ZMax < 1000.0 * z0 or bb.ZMin > 1000.0 * z1
                    or bb.XLength > 0.9 * (hi[0] - lo[0]) and bb.YLength > 0.9 * (hi[1] - lo[1])):
                continue
            xy = np.array([[v.Point.x, v.Point.y] for v in shape.Vertexes
                           if 1000.0 * z0 - 1.0 <= v.Point.z <= 1000.0 * z1]) / 1000.0
        except Exception:          # an object without readable geometry is no obstacle
            continue
        if len(xy):
            out += list(xy[_inside(edges, xy)])
    return out


def _outline_edges(tri):
    """Boundary edges (e, 2, 2) in plan of a set of floor triangles (t, 3, 3), metres."""
    xy = np.round(tri[:, :, :2], 6)
    e = np.concatenate([xy[:, [0, 1]], xy[:, [1, 2]], xy[:, [2, 0]]])
    a, b = e[:, 0], e[:, 1]
    swap = (a[:, 0] > b[:, 0]) | ((a[:, 0] == b[:, 0]) & (a[:, 1] > b[:, 1]))
    key = np.where(swap[:, None], np.hstack([b, a]), np.hstack([a, b]))   # either direction
    _, inv, cnt = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    return e[cnt[np.asarray(inv).reshape(-1)] == 1]


def _fixture_xy(space):
    """Plan positions (metres) of the light fixtures in a Space (none if unreadable)."""
    try:
        from invrad_wb.app import fixtures
        return [fixtures.fixture_luminaire(o).position[:2]
                for o in fixtures.room_fixtures(space, generated_only=False)]
    except Exception:
        return []


# ------------------------------------------------------------------------- coin3d
_STATE = {}         # doc name -> {"node", "graphs", "mode", "building", "values", ...}


def _coin():
    from pivy import coin
    return coin


def _indexed(tris):
    idx = np.full((len(tris), 4), -1, dtype=np.int64)
    idx[:, :3] = tris
    return [int(i) for i in idx.reshape(-1)]


def _face_set(coin, tris, two_sided=False):
    sep = coin.SoSeparator()
    hints = coin.SoShapeHints()
    hints.vertexOrdering = coin.SoShapeHints.COUNTERCLOCKWISE
    hints.shapeType = (coin.SoShapeHints.UNKNOWN_SHAPE_TYPE if two_sided
                       else coin.SoShapeHints.SOLID)
    sep.addChild(hints)
    fs = coin.SoIndexedFaceSet()
    fs.coordIndex.setValues(0, 4 * len(tris), _indexed(tris))
    sep.addChild(fs)
    return sep


def build_labels(labels):
    """Room names in the 3D view (screen-aligned text, drawn last and on top: the
    translucent work plane is drawn after opaque things and would cover them)."""
    coin = _coin()
    sep = coin.SoAnnotation()
    pick = coin.SoPickStyle()
    pick.style = coin.SoPickStyle.UNPICKABLE
    sep.addChild(pick)
    light = coin.SoLightModel()
    light.model = coin.SoLightModel.BASE_COLOR
    sep.addChild(light)
    mat = coin.SoMaterial()
    mat.diffuseColor = (0.0, 0.0, 0.0)
    sep.addChild(mat)
    font = coin.SoFont()
    font.name = "Sans:Bold"
    font.size = 14
    sep.addChild(font)
    for name, (x, y, z) in labels:
        t = coin.SoSeparator()
        tr = coin.SoTranslation()
        tr.translation = (float(x), float(y), float(z))
        t.addChild(tr)
        txt = coin.SoText2()
        txt.string = name
        txt.justification = coin.SoText2.CENTER
        t.addChild(txt)
        sep.addChild(t)
    return sep


def build_overlay(geom, work_plane_transparency=0.25):
    """The coin node of an :func:`overlay_geometry` (surfaces, work plane, outlines)."""
    coin = _coin()
    root = coin.SoSeparator()
    root.setName(OVERLAY_NAME)
    pick = coin.SoPickStyle()
    pick.style = coin.SoPickStyle.UNPICKABLE
    root.addChild(pick)
    light = coin.SoLightModel()
    light.model = coin.SoLightModel.BASE_COLOR
    root.addChild(light)
    coords = coin.SoCoordinate3()
    pts = geom["points"]
    coords.point.setValues(0, len(pts), [tuple(map(float, p)) for p in pts])
    root.addChild(coords)

    faces = coin.SoSeparator()
    offset = coin.SoPolygonOffset()          # faces behind their own outlines
    offset.factor = 1.0
    offset.units = 1.0
    faces.addChild(offset)
    bind = coin.SoMaterialBinding()
    bind.value = coin.SoMaterialBinding.PER_VERTEX_INDEXED
    faces.addChild(bind)
    mat = coin.SoMaterial()
    rgb = geom["rgb"]
    mat.diffuseColor.setValues(0, len(rgb), [tuple(map(float, c)) for c in rgb])
    faces.addChild(mat)
    if len(geom["surfaces"]):
        faces.addChild(_face_set(coin, geom["surfaces"]))
    if len(geom["work_plane"]):
        wp = coin.SoSeparator()
        wmat = coin.SoMaterial()
        wmat.diffuseColor.setValues(0, len(rgb), [tuple(map(float, c)) for c in rgb])
        wmat.transparency.setValues(0, len(rgb), [float(work_plane_transparency)] * len(rgb))
        wp.addChild(wmat)
        wp.addChild(_face_set(coin, geom["work_plane"], two_sided=True))
        faces.addChild(wp)
    root.addChild(faces)

    if len(geom["edges"]):
        lines = coin.SoSeparator()
        lmat = coin.SoMaterial()
        lmat.diffuseColor = EDGE_RGB
        lines.addChild(lmat)
        style = coin.SoDrawStyle()
        style.lineWidth = 1.5
        lines.addChild(style)
        ls = coin.SoIndexedLineSet()
        e = geom["edges"]
        idx = np.full((len(e), 3), -1, dtype=np.int64)
        idx[:, :2] = e
        ls.coordIndex.setValues(0, idx.size, [int(i) for i in idx.reshape(-1)])
        lines.addChild(ls)
        root.addChild(lines)
    return root


def _text(coin, x, y, s, size=None, just=None):
    sep = coin.SoSeparator()
    tr = coin.SoTranslation()
    tr.translation = (x, y, 0.0)
    sep.addChild(tr)
    if size:
        font = coin.SoFont()
        font.name = "Sans"
        font.size = size
        sep.addChild(font)
    t = coin.SoText2()
    t.string = s
    if just == "right":
        t.justification = coin.SoText2.RIGHT
    sep.addChild(t)
    return sep


def _quad(coin, x0, y0, x1, y1, rgb, z=0.0):
    sep = coin.SoSeparator()
    m = coin.SoMaterial()
    m.diffuseColor = rgb
    sep.addChild(m)
    c = coin.SoCoordinate3()
    c.point.setValues(0, 4, [(x0, y0, z), (x1, y0, z), (x1, y1, z), (x0, y1, z)])
    sep.addChild(c)
    f = coin.SoFaceSet()
    f.numVertices.setValue(4)
    sep.addChild(f)
    return sep


def legend_layout(title, vmax, swatches, over=False, vmin=0.0, fmt=None):
    """Positions of the legend's parts in normalised view coordinates ([-1, 1]^2).

    The bar runs from ``vmin`` (0 lx, or -limit for deviations) to ``vmax``; ``fmt``
    writes a tick value (default :func:`label`).

    Returns a dict of plain numbers and strings (tested headless): the panel, the colour
    bar, the ticks ``[(y, text)]`` and the swatches ``[(y, rgb, text)]``.
    """
    fmt = fmt or label
    x0, x1 = -0.985, -0.70
    bar = (-0.965, -0.915)
    y_bar0 = -0.55 + 0.09 * (2 - len(swatches))
    y_bar1 = 0.5
    span = float(vmax) - float(vmin)
    tick_list = [(y_bar0 + (y_bar1 - y_bar0) * t / span, fmt(vmin + t))
                 for t in ticks(span)]
    if over:                       # values above the scale take its top colour
        tick_list[-1] = (tick_list[-1][0], tick_list[-1][1] + "+")
    sw = []
    y = y_bar0 - 0.1
    for rgb, text in swatches:
        sw.append((y, rgb, text))
        y -= 0.09
    bottom = (y + 0.09 - 0.06) if sw else (y_bar0 - 0.06)
    title_lines = title.split("\n")
    y_top = y_bar1 + 0.1 + 0.055 * len(title_lines)
    return {"panel": (x0, bottom, x1, y_top), "bar": (bar[0], y_bar0, bar[1], y_bar1),
            "ticks": tick_list, "swatches": sw,
            "title": [(y_bar1 + 0.07 + 0.055 * (len(title_lines) - 1 - i), s)
                      for i, s in enumerate(title_lines)]}


def build_legend(title, vmax, swatches=(), over=False, vmin=0.0, cmap=None, fmt=None):
    """Screen-space legend: colour bar ``vmin``..``vmax`` (lux by default; ``cmap`` maps
    values to (n, 3) RGB, default viridis over 0..vmax) with ticks, swatches, title."""
    coin = _coin()
    lay = legend_layout(title, vmax, list(swatches), over, vmin=vmin, fmt=fmt)
    skip = coin.SoType.fromName("SoSkipBoundingGroup").createInstance()
    skip.setName(LEGEND_NAME)
    ann = coin.SoAnnotation()
    skip.addChild(ann)
    pick = coin.SoPickStyle()
    pick.style = coin.SoPickStyle.UNPICKABLE
    ann.addChild(pick)
    cam = coin.SoOrthographicCamera()
    # LEAVE_AS_IS (4): normalised [-1, 1] view coordinates; pivy 0.6 lacks the name
    cam.viewportMapping = getattr(coin.SoCamera, "LEAVE_AS_IS", 4)
    cam.position = (0.0, 0.0, 5.0)
    cam.height = 2.0
    cam.nearDistance = 1.0
    cam.farDistance = 10.0
    ann.addChild(cam)
    light = coin.SoLightModel()
    light.model = coin.SoLightModel.BASE_COLOR
    ann.addChild(light)
    px0, py0, px1, py1 = lay["panel"]
    ann.addChild(_quad(coin, px0 - 0.004, py0 - 0.006, px1 + 0.004, py1 + 0.006,
                       (0.35, 0.35, 0.35), z=-0.2))
    ann.addChild(_quad(coin, px0, py0, px1, py1, (1.0, 1.0, 1.0), z=-0.1))
    bx0, by0, bx1, by1 = lay["bar"]
    n = 48
    ys = np.linspace(by0, by1, n + 1)
    vals = np.linspace(vmin, vmax, n + 1)
    cols = cmap(vals) if cmap is not None else colours(vals, vmax, targets=False)
    bar = coin.SoSeparator()
    bind = coin.SoMaterialBinding()
    bind.value = coin.SoMaterialBinding.PER_VERTEX_INDEXED
    bar.addChild(bind)
    mat = coin.SoMaterial()
    mat.diffuseColor.setValues(0, len(cols), [tuple(map(float, c)) for c in cols])
    bar.addChild(mat)
    pts = [(bx0, float(y), 0.0) for y in ys] + [(bx1, float(y), 0.0) for y in ys]
    coords = coin.SoCoordinate3()
    coords.point.setValues(0, len(pts), pts)
    bar.addChild(coords)
    idx, midx = [], []
    for i in range(n):
        quad = [i, n + 1 + i, n + 2 + i, i + 1]
        idx += quad + [-1]
        midx += [i, i, i + 1, i + 1, -1]
    fs = coin.SoIndexedFaceSet()
    fs.coordIndex.setValues(0, len(idx), idx)
    fs.materialIndex.setValues(0, len(midx), midx)
    bar.addChild(fs)
    ann.addChild(bar)
    lines = coin.SoSeparator()
    lm = coin.SoMaterial()
    lm.diffuseColor = (0.0, 0.0, 0.0)
    lines.addChild(lm)
    lpts, lidx = [(bx0, by0, 0.01), (bx1, by0, 0.01), (bx1, by1, 0.01), (bx0, by1, 0.01)], \
        [0, 1, 2, 3, 0, -1]
    for y, _ in lay["ticks"]:
        k = len(lpts)
        lpts += [(bx1, y, 0.01), (bx1 + 0.012, y, 0.01)]
        lidx += [k, k + 1, -1]
    lc = coin.SoCoordinate3()
    lc.point.setValues(0, len(lpts), lpts)
    lines.addChild(lc)
    ls = coin.SoIndexedLineSet()
    ls.coordIndex.setValues(0, len(lidx), lidx)
    lines.addChild(ls)
    ann.addChild(lines)
    text = coin.SoSeparator()
    tm = coin.SoMaterial()
    tm.diffuseColor = (0.0, 0.0, 0.0)
    text.addChild(tm)
    font = coin.SoFont()
    font.name = "Sans"
    font.size = 13
    text.addChild(font)
    for y, s in lay["ticks"]:
        text.addChild(_text(coin, bx1 + 0.02, y - 0.015, s))
    for y, s in lay["title"]:
        text.addChild(_text(coin, px0 + 0.012, y, s))
    for y, rgb, s in lay["swatches"]:
        ann.addChild(_quad(coin, bx0, y - 0.03, bx1, y + 0.03, rgb, z=0.0))
        text.addChild(_text(coin, bx1 + 0.02, y - 0.015, s))
    ann.addChild(text)
    return skip


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
    st = _STATE.get(doc.Name)
    return st is not None and (mode is None or st["mode"] == mode)


def mode(doc):
    st = _STATE.get(doc.Name)
    return st["mode"] if st else None


def hide(doc):
    """Remove the overlay of ``doc`` from its views (no-op if none)."""
    st = _STATE.pop(doc.Name, None)
    if st is None:
        return False
    for sensor in st.get("sensors", []):
        try:
            sensor.detach()
        except Exception:
            pass
    for sg in st["graphs"]:
        for node in (st["node"], st["legend"]):
            try:
                if sg.findChild(node) >= 0:
                    sg.removeChild(node)
            except Exception:
                pass
    return True


def target_scale(building):
    """Top of the scale for a building's targets (lux): :func:`lux_scale` of them."""
    return lux_scale(building.scene.vertex_lux)


_SCALES = {}        # doc name -> the lux scale its views share


def document_scale(doc, target_lux):
    """The lux scale of ``doc``'s target and achieved views, chosen once: by
    :func:`lux_scale` on the first view, then kept while the largest target still fits
    under it with its headroom (5 % slack: meshes of other resolutions sample a spot's
    peak a little differently, one step of the rounding); new when the targets changed
    more (a brighter target, or one a step lower as after an undo)."""
    t = np.asarray(target_lux, dtype=np.float64) if target_lux is not None else np.zeros(0)
    t = t[np.isfinite(t)]
    need = SCALE_HEADROOM * (t.max() if t.size else 0.0)
    old = _SCALES.get(doc.Name)
    new = lux_scale(t)
    if old is not None and need <= old * 1.05 and new >= 0.75 * old:
        return old
    _SCALES[doc.Name] = new
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
    coin = _coin()
    node = coin.SoSeparator()
    node.setName(OVERLAY_NAME + "Root")
    node.addChild(build_overlay(geom, opts["work_plane_transparency"]))
    v = np.asarray(values, dtype=np.float64)
    over = not deviation and bool(np.any(v[np.isfinite(v)] > geom["vmax"] * (1 + 1e-9)))
    swatches = []
    scale = {}
    if deviation:
        scale = {"vmin": -geom["vmax"], "fmt": _percent,
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
    _STATE[doc.Name] = {"node": node, "legend": legend, "graphs": graphs,
                        "mode": mode_name,
                        "building": building, "vmax": geom["vmax"],
                        "triangles": len(geom["surfaces"]) + len(geom["work_plane"]),
                        "labels": room_labels(building), "label_node": label_node,
                        "label_vis": None, "sensors": []}
    update_labels(doc)
    # a clipping plane toggled or moved later shows and hides the names again
    for sg in graphs:
        try:
            sensor = coin.SoNodeSensor(_graph_changed, doc.Name)
            sensor.attach(sg)
            _STATE[doc.Name]["sensors"].append(sensor)
        except Exception:          # without the sensor the names follow at the next show
            pass
    return geom["vmax"]


def clip_planes(graphs):
    """The active clipping planes (Std_ToggleClipPlane, section views) in scene graphs:
    ``[((3,) normal, distance mm)]``; coin keeps ``normal . p >= distance``."""
    coin = _coin()
    out = []
    for sg in graphs:
        sa = coin.SoSearchAction()
        sa.setType(coin.SoClipPlane.getClassTypeId(), True)
        sa.setInterest(coin.SoSearchAction.ALL)
        sa.apply(sg)
        paths = sa.getPaths()
        for i in range(paths.getLength()):
            node = paths[i].getTail()
            if hasattr(node, "on") and not node.on.getValue():
                continue
            pl = node.plane.getValue()
            n = pl.getNormal()
            out.append(((float(n[0]), float(n[1]), float(n[2])),
                        float(pl.getDistanceFromOrigin())))
    return out


def update_labels(doc):
    """Draw the room names that :func:`label_visibility` keeps for the clipping planes of
    the document's views now; True if the drawn set changed."""
    st = _STATE.get(doc if isinstance(doc, str) else doc.Name)
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
    st = _STATE.get(doc.Name)
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
    _ACHIEVED[doc.Name] = (building, np.asarray(achieved, dtype=np.float64))
    vmax = vmax or document_scale(doc, building.scene.vertex_lux)
    return show(doc, building, achieved, "Achieved\nilluminance (lx)", "achieved",
                targets=False, vmax=vmax)


_ACHIEVED = {}      # doc name -> (building, achieved lux) of the last achieved view


def _mean_target(target):
    """The mean positive target (lux), NaN without one: the deviation's reference."""
    t = np.asarray(target, dtype=np.float64) if target is not None else np.zeros(0)
    pos = t[np.isfinite(t) & (t > 0)]
    return float(pos.mean()) if pos.size else np.nan


def deviation(target, achieved, reference=None):
    """Relative deviation per vertex, (E - T) / T, as the report computes it (shade
    points, and a spot's rim below 10 % of it: against the ``reference``, default the
    mean positive target); NaN where there is no target."""
    from invrad_wb.core.output.report import relative_deviation
    t = np.asarray(target, dtype=np.float64)
    ref = _mean_target(t) if reference is None else reference
    return relative_deviation(t, achieved, ref)


def deviation_colours(values, limit=DEVIATION_LIMIT):
    """The report's deviation colours, RGB in [0, 1]: blue too dark, white on target, red
    too bright, full at +-``limit``; NaN (no target) grey."""
    return _images.diverging(values, limit).astype(np.float64) / 255.0


def _percent(x):
    return f"{100.0 * x:+.0f} %" if abs(x) > 1e-9 else "0 %"


def has_achieved(doc):
    return doc is not None and doc.Name in _ACHIEVED


def drop_achieved(doc):
    """Forget the achieved result (the fixtures changed: its deviation would be stale)."""
    _ACHIEVED.pop(doc.Name, None)


def show_deviation(doc, limit=DEVIATION_LIMIT):
    """The last achieved view's deviation from the targets, -limit..+limit (the report's
    scale and colours). Returns the limit, or None without an achieved result."""
    got = _ACHIEVED.get(doc.Name)
    if got is None:
        return None
    building, achieved = got
    target = building.scene.vertex_lux
    ref = _mean_target(target)
    # on the targets' display mesh (finer along a spot's edge): a smooth rim, not the
    # stair steps of the sampling mesh between vertices with and without a target
    mesh = target_mesh(building, document_scale(doc, target), carry=[achieved])
    dev = deviation(mesh["values"], mesh["carried"][0], ref)
    return show(doc, building, dev, "Deviation from\ntarget", "deviation", targets=False,
                vmax=float(limit), mesh=mesh, deviation=True)


def toggle_deviation(doc=None):
    """Switch between the achieved illuminance and its deviation from the targets; True
    if the deviation is shown afterwards."""
    import FreeCAD
    from invrad_wb.gui import messages
    doc = doc or FreeCAD.ActiveDocument
    if doc is None or not has_achieved(doc):
        return False
    try:
        if is_shown(doc, "deviation"):
            building, achieved = _ACHIEVED[doc.Name]
            show_achieved(doc, building, achieved)
            return False
        show_deviation(doc)
    except Exception as exc:
        hide(doc)
        messages.exception("Show deviation", exc)
        return False
    return True


def toggle_targets(doc=None):
    """Show the targets, or hide them if they are shown; True if shown afterwards.

    Errors (no rooms, a bad target) are reported, not raised, like every GUI action.
    """
    import FreeCAD
    from invrad_wb.gui import messages
    doc = doc or FreeCAD.ActiveDocument
    if doc is None:
        return False
    if is_shown(doc, "targets"):
        hide(doc)
        return False
    try:
        show_targets(doc)
    except Exception as exc:
        hide(doc)
        messages.exception("Show targets", exc)
        return False
    return True


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
    st = _STATE.get(doc.Name)
    if st is None:
        return None
    return {k: st[k] for k in ("mode", "vmax", "triangles")}


def forget(doc_name):
    st = _STATE.pop(doc_name, None)
    for sensor in (st or {}).get("sensors", []):
        try:
            sensor.detach()
        except Exception:
            pass
    _SCALES.pop(doc_name, None)
    _ACHIEVED.pop(doc_name, None)
