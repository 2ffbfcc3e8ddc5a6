"""False colours and the display mesh of the target/achieved/deviation views (no GUI).

* the colour map and the scale rule are the report's (:mod:`invrad_wb.core.output.images`),
  so that the 3D view and the report read the same: viridis for lux, the report's
  blue-white-red for deviations; "no target" grey and shade targets near black;
* :func:`overlay_geometry`: the points, triangles, colours and outlines the overlay draws;
* :func:`target_mesh`: the targets' display mesh, refined along target edges
  (:func:`subdivide`, :func:`edge_triangles`) so that a round spot looks round;
* :func:`legend_layout`: where the legend's parts go, in normalised view coordinates.

Tested headless; :mod:`.coinnodes` turns these into coin nodes.
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
    faces = np.asarray(faces, dtype=np.int64)
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    g = np.concatenate([groups, groups, groups]).astype(np.int64)
    if not len(e):
        return e
    # one int64 per (group, edge): np.unique on rows (axis=0) sorts them as opaque
    # records, 10x slower; FZK-Haus's display mesh froze the GUI for minutes after
    # Locate (318 k triangles: 3.9 -> 0.35 s on a busy machine)
    n = int(e.max()) + 1
    g = g - g.min()                   # ids from 0 (a face of no group is -1)
    lo, hi = e.min(axis=1), e.max(axis=1)
    if (int(g.max()) + 1) * n * n < 2 ** 62:
        key = (g * n + lo) * n + hi
        _, inv, count = np.unique(key, return_inverse=True, return_counts=True)
    else:                             # too many vertices for one int64 key
        key = np.stack([g, lo, hi], axis=1)
        _, inv, count = np.unique(key, axis=0, return_inverse=True, return_counts=True)
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


def mean_target(target):
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
    ref = mean_target(t) if reference is None else reference
    return relative_deviation(t, achieved, ref)


def deviation_colours(values, limit=DEVIATION_LIMIT):
    """The report's deviation colours, RGB in [0, 1]: blue too dark, white on target, red
    too bright, full at +-``limit``; NaN (no target) grey."""
    return _images.diverging(values, limit).astype(np.float64) / 255.0


def percent(x):
    return f"{100.0 * x:+.0f} %" if abs(x) > 1e-9 else "0 %"


