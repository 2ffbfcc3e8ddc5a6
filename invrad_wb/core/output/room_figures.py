"""The verification report's figures of one room, drawn with matplotlib.

Every figure draws the per-vertex values on the room's own triangles (``tripcolor`` with
Gouraud shading: the piecewise-linear field the metrics integrate, no resampling), so a
room's picture holds exactly its faces and nothing of its neighbours. Per room:

* :func:`unfolded_pair`: target and achieved illuminance of every plane, laid flat as a
  box net (:func:`invrad_wb.core.output.images.unfolded_layout`), side by side with one
  colour bar: the room's lux scale, chosen once;
* :func:`deviation_pair`: the deviation from the target, unfolded and from above, with
  one diverging colour bar (per cent);
* :func:`plan_pair`: the room from above, false colour with labelled iso-lux lines and
  the luminaires, beside a grid of values (EN 12464-1 grid spacing) on the same scale.

All return PNG bytes (:func:`invrad_wb.core.output.figures.png`).
"""
from dataclasses import dataclass

import numpy as np

from invrad_wb.core.output import figures as F
from invrad_wb.core.output.images import unfolded_layout, room_floor_z
from invrad_wb.core.geometry.raster import locate_points

#: largest number of value-grid points along one side (readable numbers)
MAX_GRID_SIDE = 14
#: luminaires on the unfolded surfaces are labelled up to this many
MAX_UNFOLDED_LABELS = 8
_XY = np.array([[1.0, 0, 0], [0, 1.0, 0]])


@dataclass
class RoomView:
    """What a room's figures show.

    Attributes
    ----------
    scene : Scene
    room : int, room id
    name : str, the room's name (titles)
    target, achieved : (n,) float64, lux per scene vertex (NaN target = none, 0 = shade)
    deviation : (n,) float64, (E - T) / T per vertex (fraction), NaN where no target (the
        EXR's; the pictures take theirs from the display mesh)
    lux_max : float, top of the room's lux scale
    limit : float, deviation at the ends of its scale (fraction)
    lum_xyz : (k, 3) float64, the room's luminaires (metres)
    lum_labels : list of k str ('L1', ...)
    lux_min : float, bottom of the lux scale (0 unless the caller fixes a range)
    layout : UnfoldedLayout, optional (computed once on first use)
    mesh : DisplayMesh, optional (what is drawn; default the scene's own faces)
    reference : float, lux: the room's target mean (deviation on shade targets)
    """
    scene: object
    room: int
    name: str
    target: np.ndarray
    achieved: np.ndarray
    deviation: np.ndarray
    lux_max: float
    limit: float
    lum_xyz: np.ndarray
    lum_labels: list
    lux_min: float = 0.0
    layout: object = None
    mesh: object = None
    reference: float = float("nan")

    def display(self):
        """The :class:`DisplayMesh` drawn (default: the scene's faces as they are)."""
        if self.mesh is None:
            self.mesh = display_mesh(self.scene, self.room, self.target, self.achieved,
                                     self.lux_max, self.reference)
        return self.mesh

    def unfolded(self):
        if self.layout is None:
            self.layout = unfolded_layout(self.scene, self.room)
        return self.layout

    def norm(self):
        return F.lux_norm(self.lux_max, self.lux_min)


def _field(ax, mesh, plane, A, b, kind, cmap, norm):
    """Draw the display mesh's ``kind`` values on one plane, mapped by ``X = A p + b``:
    Gouraud-shaded where all three corners have a value, the no-target grey elsewhere."""
    from matplotlib.tri import Triangulation
    from matplotlib.collections import PolyCollection
    tri = mesh.tri[mesh.plane == plane]
    if not len(tri):
        return
    verts, inv = np.unique(tri.reshape(-1), return_inverse=True)
    xy = mesh.xyz[verts] @ A.T + b
    tri = inv.reshape(-1, 3)
    v = mesh.values(kind)[verts]
    if kind == "deviation":
        v = 100.0 * v
    bad = ~np.all(np.isfinite(v[tri]), axis=1)
    if bad.any():
        ax.add_collection(PolyCollection(xy[tri[bad]], facecolors=F.NO_TARGET,
                                         edgecolors=F.NO_TARGET, linewidths=0.3))
    if (~bad).any():
        t = Triangulation(xy[:, 0], xy[:, 1], tri)
        t.set_mask(bad)
        ax.tripcolor(t, np.nan_to_num(v), shading="gouraud", cmap=cmap, norm=norm,
                     rasterized=True)


def _outline(ax, scene, faces, A, b, **kw):
    e = F.boundary_edges(scene.faces[faces])
    F.draw_segments(ax, scene.vertices[e] @ A.T + b, **kw)


def _shade(ax, scene, faces, A, b, target, fill):
    """Shade targets (all corners 0 lx): filled black (target views) or outlined dashed."""
    f = np.asarray(faces)[np.all(target[scene.faces[faces]] == 0, axis=1)]
    if not len(f):
        return False
    if fill:
        from matplotlib.collections import PolyCollection
        ax.add_collection(PolyCollection(scene.vertices[scene.faces[f]] @ A.T + b,
                                         facecolors=F.SHADE, edgecolors=F.SHADE,
                                         linewidths=0.3))
    else:
        _outline(ax, scene, f, A, b, colors="black", linewidths=1.0, linestyles="--")
    return True


def _unfolded(ax, view, lay, cmap, norm, kind):
    """One unfolded view of the room: every plane's field, outline and label."""
    s = view.scene
    mesh = view.display()
    for k, (A, b) in lay.tiles.items():
        faces = s.planes[k].faces
        _field(ax, mesh, k, A, b, kind, cmap, norm)
        _shade(ax, s, faces, A, b, view.target, fill=kind == "target")
        _outline(ax, s, faces, A, b, colors="0.2", linewidths=0.8)
    for lab in lay.labels:
        ax.text(lab["xy"][0], lab["xy"][1], lab["text"], ha="center", va="center",
                rotation=lab.get("rotation", 0), fontsize=7, bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none",
                                        alpha=0.8), zorder=5)
    if kind != "target":
        xy, labels = unfolded_marks(view, lay)
        # many rings on small tiles: unlabelled (the plan from above names them)
        F.luminaire_marks(ax, xy, labels if len(labels) <= MAX_UNFOLDED_LABELS else None,
                          size=6)
    _frame(ax, [s.vertices[s.faces[s.planes[k].faces]].reshape(-1, 3) @ A.T + b
                for k, (A, b) in lay.tiles.items()])


def _frame(ax, point_sets, bar=True):
    pts = np.concatenate([p.reshape(-1, 2) for p in point_sets])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    pad = 0.03 * float(max(hi - lo))
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    ax.set_aspect("equal")
    ax.set_axis_off()
    if bar:
        F.scale_bar(ax, F.round_length(float(max(hi - lo))))


def unfolded_marks(view, lay, max_dist=0.35):
    """Where the room's luminaires appear on the unfolded planes: those mounted on (within
    ``max_dist`` of) a real plane, at their foot point on it (the nearest such plane; the
    first tile on a tie). Returns ((k, 2) metres, labels).

    One pass per plane over all luminaires at once (a loop per luminaire and plane took
    5.5 s of a verify with 10,000 luminaires)."""
    s = view.scene
    pos = np.asarray(view.lum_xyz, dtype=np.float64).reshape(-1, 3)
    n = len(pos)
    best_d = np.full(n, np.inf)
    best_xy = np.zeros((n, 2))
    for k, (A, b) in lay.tiles.items():
        p = s.planes[k]
        if p.is_virtual or not n:
            continue
        d = p.signed_distance(pos)
        foot = pos - d[:, None] * p.normal
        uv = p.to_plane_coords(foot)
        ok = ((d >= -0.01) & (d <= max_dist) & (d < best_d)
              & np.all(uv >= -1e-6, axis=1) & np.all(uv <= np.asarray(p.size) + 1e-6, axis=1))
        best_d[ok] = d[ok]
        best_xy[ok] = foot[ok] @ np.asarray(A).T + b
    hit = np.isfinite(best_d)
    labels = [lab for lab, h in zip(view.lum_labels, hit) if h]
    return best_xy[hit].reshape(-1, 2), labels


def _extent(view, lay):
    s = view.scene
    pts = np.concatenate([s.vertices[s.faces[s.planes[k].faces]].reshape(-1, 3) @ A.T + b
                          for k, (A, b) in lay.tiles.items()])
    return pts.max(axis=0) - pts.min(axis=0)


def _pair_figure(spans, height_cap=3.9):
    """A figure with two panels whose data spans are ``spans`` [(w, h), (w, h)] metres,
    at the page width, and a colour-bar axis at the right. Returns (fig, ax1, ax2, cax)."""
    total_w = sum(float(w) for w, _ in spans)
    avail = F.PAGE_WIDTH_IN - 1.0
    s = avail / max(total_w, 1e-6)
    h = min(height_cap, max(float(hh) for _, hh in spans) * s + 0.5)
    fig = F.figure(F.PAGE_WIDTH_IN, max(h, 2.2))
    gs = fig.add_gridspec(1, 3, width_ratios=[max(spans[0][0], 1e-3),
                                              max(spans[1][0], 1e-3), 0.03 * total_w],
                          wspace=0.08, left=0.01, right=0.92, top=0.93, bottom=0.02)
    return fig, fig.add_subplot(gs[0]), fig.add_subplot(gs[1]), fig.add_subplot(gs[2])


def _lux_bar(fig, cax, norm):
    from matplotlib.cm import ScalarMappable
    cb = fig.colorbar(ScalarMappable(norm=norm, cmap=F.lux_cmap()), cax=cax, extend="max")
    cb.set_label("illuminance (lx)", fontsize=8)
    cb.ax.tick_params(labelsize=7.5)
    return cb


def unfolded_pair(view):
    """PNG of the room's target and achieved illuminance, unfolded, one colour bar."""
    lay = view.unfolded()
    span = _extent(view, lay)
    fig, a1, a2, cax = _pair_figure([span, span])
    norm = view.norm()
    cmap = F.lux_cmap()
    _unfolded(a1, view, lay, cmap, norm, "target")
    _unfolded(a2, view, lay, cmap, norm, "achieved")
    a1.set_title(f"{view.name}: target", fontsize=9)
    a2.set_title(f"{view.name}: achieved", fontsize=9)
    _lux_bar(fig, cax, norm)
    return F.png(fig)


def _plan_planes(scene, room):
    """The room's upward-facing planes, lowest first (the higher drawn over the lower)."""
    ups = [p for p in scene.planes if p.room == room and p.normal[2] > 0.9]
    return sorted(ups, key=lambda p: float(p.origin[2]))


def _plan(ax, view, kind, cmap, norm, shade_fill=False):
    s = view.scene
    ups = _plan_planes(s, view.room)
    for p in ups:
        _field(ax, view.display(), p.index, _XY, np.zeros(2), kind, cmap, norm)
        _shade(ax, s, p.faces, _XY, np.zeros(2), view.target, fill=shade_fill)
    for p in ups:
        _outline(ax, s, p.faces, _XY, np.zeros(2), colors="0.2", linewidths=0.8)
    return ups


def deviation_pair(view):
    """PNG of the deviation from the target: unfolded and from above, one colour bar (%)."""
    from matplotlib.colors import Normalize
    from matplotlib.cm import ScalarMappable
    lay = view.unfolded()
    ups = _plan_planes(view.scene, view.room)
    span = _extent(view, lay)
    pspan = _plan_span(view.scene, ups) if ups else span
    fig, a1, a2, cax = _pair_figure([span, pspan])
    norm = Normalize(-100.0 * view.limit, 100.0 * view.limit)
    cmap = F.deviation_cmap()
    _unfolded(a1, view, lay, cmap, norm, "deviation")
    a1.set_title(f"{view.name}: all surfaces", fontsize=9)
    if ups:
        _plan(a2, view, "deviation", cmap, norm)
        F.luminaire_marks(a2, view.lum_xyz[:, :2], view.lum_labels, size=6)
        _plan_axes(a2, view.scene, ups)
        a2.set_title(f"{view.name}: from above", fontsize=9)
    else:
        a2.set_axis_off()
    cb = fig.colorbar(ScalarMappable(norm=norm, cmap=cmap), cax=cax, extend="both")
    cb.set_label("deviation from target (%)\nblue too dark, red too bright", fontsize=8)
    cb.ax.tick_params(labelsize=7.5)
    return F.png(fig)


def _plan_span(scene, ups):
    pts = np.concatenate([scene.vertices[scene.faces[p.faces]].reshape(-1, 3)[:, :2]
                          for p in ups])
    return pts.max(axis=0) - pts.min(axis=0) + np.array([0.6, 0.4])


def _plan_axes(ax, scene, ups):
    pts = np.concatenate([scene.vertices[scene.faces[p.faces]].reshape(-1, 3)[:, :2]
                          for p in ups])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    pad = 0.03 * float(max(hi - lo))
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    ax.set_aspect("equal")
    ax.tick_params(labelsize=7)
    ax.set_xlabel("x (m)", fontsize=7.5, labelpad=1)
    ax.set_ylabel("y (m)", fontsize=7.5, labelpad=1)


def value_grid(scene, plane, values, max_side=MAX_GRID_SIDE):
    """Values at the centres of an EN 12464-1 calculation grid over a plane seen from
    above (spacing ``p = 0.2 * 5^log10(d)``, ``d`` its longer side; at most ``max_side``
    points along a side).

    Returns
    -------
    points : (k, 2) float64, x, y metres (only those on the plane)
    values : (k,) float64, lux, linear over the faces
    cell : (2,) float64, the cell size (metres)
    """
    from invrad_wb.core.output.metrics import grid_spacing
    tri = scene.vertices[scene.faces[plane.faces]][:, :, :2]
    lo, hi = tri.reshape(-1, 2).min(axis=0), tri.reshape(-1, 2).max(axis=0)
    size = np.maximum(hi - lo, 1e-6)
    p = max(grid_spacing(float(size.max())), float(size.max()) / max_side)
    n = np.maximum(1, np.ceil(size / p - 1e-9)).astype(int)
    cell = size / n
    gx = lo[0] + (np.arange(n[0]) + 0.5) * cell[0]
    gy = lo[1] + (np.arange(n[1]) + 0.5) * cell[1]
    pts = np.stack(np.meshgrid(gx, gy), -1).reshape(-1, 2)
    t, bary = locate_points(tri, pts)
    ok = t >= 0
    v = np.einsum("kj,kj->k", bary[ok], values[scene.faces[plane.faces[t[ok]]]])
    return pts[ok], v, cell


def _grid_panel(ax, view, top, norm, cmap):
    """The value grid: each cell in its colour with its value written in it."""
    from matplotlib.collections import PolyCollection
    s = view.scene
    pts, v, cell = value_grid(s, top, view.achieved)
    h = 0.5 * cell
    boxes = np.stack([pts + [-h[0], -h[1]], pts + [h[0], -h[1]], pts + [h[0], h[1]],
                      pts + [-h[0], h[1]]], axis=1)
    rgba = cmap(norm(v))
    ax.add_collection(PolyCollection(boxes, facecolors=rgba, edgecolors="white",
                                     linewidths=0.6))
    lum = rgba[:, :3] @ [0.299, 0.587, 0.114]
    # the widest number fills at most 80 % of its cell (a digit is ~0.6 em wide)
    chars = max(len(f"{x:.0f}") for x in v) if len(v) else 3
    cell_pt = 72 * min(float(cell[0]), 1.6 * float(cell[1])) * _inch_per_metre(ax)
    fs = float(np.clip(0.8 * cell_pt / (0.62 * chars), 4.0, 9.0))
    for (x, y), val, l in zip(pts, v, lum):
        ax.text(x, y, f"{val:.0f}", ha="center", va="center", fontsize=fs,
                color="black" if l > 0.5 else "white")
    for p in _plan_planes(s, view.room):
        _outline(ax, s, p.faces, _XY, np.zeros(2), colors="0.2", linewidths=0.8)
    return len(v), cell


def _inch_per_metre(ax):
    """Inches per metre of an equal-aspect axis (its box shrinks to the data's shape)."""
    fig = ax.figure
    pos = ax.get_position()
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    return min(pos.width * fig.get_figwidth() / max(x1 - x0, 1e-6),
               pos.height * fig.get_figheight() / max(y1 - y0, 1e-6))


def plan_pair(view, required=None):
    """PNG of the room from above: false colour, labelled iso-lux lines and luminaires
    beside the value grid, one colour bar (the room's lux scale). ``required``: the target
    Em (lux), drawn among the iso-lux lines."""
    s = view.scene
    ups = _plan_planes(s, view.room)
    if not ups:
        return None
    span = _plan_span(s, ups)
    fig, a1, a2, cax = _pair_figure([span, span])
    norm, cmap = view.norm(), F.lux_cmap()
    _plan(a1, view, "achieved", cmap, norm)
    top = max(ups, key=lambda p: (round(float(p.origin[2]), 3), p.area))
    iso = _iso_lines(a1, view.display(), top.index, required)
    F.luminaire_marks(a1, view.lum_xyz[:, :2], view.lum_labels)
    for ax in (a1, a2):
        _plan_axes(ax, s, ups)
    if iso is not None:       # labelled where they fit, on the panel as drawn
        F.label_iso_lines(a1, iso[0], required, avoid=view.lum_xyz[:, :2], field=iso[1])
    a2.set_ylabel("")
    a2.tick_params(labelleft=False)
    n, cell = _grid_panel(a2, view, top, norm, cmap)
    what = _plane_words(s, view.room, top)
    a1.set_title(f"{view.name}: {what}, iso-lux lines", fontsize=9)
    a2.set_title(f"{view.name}: values (lx), grid {cell[0]:.2f} x {cell[1]:.2f} m",
                 fontsize=9)
    _lux_bar(fig, cax, norm)
    return F.png(fig)


def _plane_words(scene, room, plane):
    from invrad_wb.core.output.images import describe_plane
    return describe_plane(plane, room_floor_z(scene, room))


def _iso_lines(ax, mesh, plane, required):
    """Iso-lux lines over one plane (matplotlib's tricontour): (contour set, its
    triangulation) for :func:`~.figures.label_iso_lines`, or None."""
    from matplotlib.tri import Triangulation
    tri = mesh.tri[mesh.plane == plane]
    verts, inv = np.unique(tri.reshape(-1), return_inverse=True)
    v = mesh.achieved[verts]
    if len(verts) < 3 or not np.all(np.isfinite(v)):
        return
    levels = F.iso_levels(v, required)
    if not levels:
        return
    t = Triangulation(mesh.xyz[verts, 0], mesh.xyz[verts, 1], inv.reshape(-1, 3))
    cs = ax.tricontour(t, v, levels=levels, colors=F.ISO_COLOUR, linewidths=0.9)
    return cs, t


def scale_top(target, achieved, faces_of_room, scene):
    """The room's lux scale: a round top above its highest target and the 99th
    percentile of the achieved light on its target points."""
    from invrad_wb.core.output.images import nice_max
    verts = np.unique(scene.faces[faces_of_room].reshape(-1))
    t = target[verts]
    has = np.isfinite(t)
    tmax = float(t[has].max()) if has.any() else 0.0
    a = achieved[verts][has & np.isfinite(achieved[verts])]
    if not len(a):
        a = achieved[verts][np.isfinite(achieved[verts])]
    p99 = float(np.percentile(a, 99)) if len(a) else 0.0
    return nice_max(max(tmax, p99, 1e-3))



# ---------------------------------------------------------------------------- display mesh
#: a face whose corners differ by more than this fraction of the room's scale is split in
#: four for the pictures (steep light next to a luminaire)
REFINE_FRACTION = 0.15
#: how many times a face may be split (up to 4^levels sub-triangles)
REFINE_LEVELS = 2


@dataclass
class DisplayMesh:
    """The room's faces as drawn: the scene's own, split where the light is steep.

    The pictures draw the piecewise-linear field of the mesh. Where a luminaire sits close
    to a surface the light there peaks between vertices, and the linear field of a coarse
    mesh draws the peak as a polygon (an octagonal saturated blob). Split faces get the
    direct light computed exactly at their new corners (the forward solver's own
    :func:`~invrad_wb.core.forward.direct.direct_illuminance`, occlusion included) plus the
    interreflected light interpolated linearly (it is smooth); targets are interpolated
    (they are linear per face by definition). The metrics keep the scene's vertex field.

    Attributes
    ----------
    xyz : (k, 3) float64, points (metres); the scene's vertices of the room come first
    tri : (t, 3) int64, triangles into ``xyz``
    plane : (t,) int64, scene plane of each triangle
    target, achieved : (k,) float64, lux
    deviation : (k,) float64, fraction (as :func:`~invrad_wb.core.output.metrics.
        relative_deviation`)
    n_split : int, how many faces were split (all levels)
    """
    xyz: np.ndarray
    tri: np.ndarray
    plane: np.ndarray
    target: np.ndarray
    achieved: np.ndarray
    deviation: np.ndarray
    n_split: int = 0

    def values(self, kind):
        return {"target": self.target, "achieved": self.achieved,
                "deviation": self.deviation}[kind]


def display_mesh(scene, room, target, achieved, lux_max, reference, luminaires=None,
                 backend="auto", fraction=REFINE_FRACTION, levels=REFINE_LEVELS):
    """The room's :class:`DisplayMesh` (``luminaires`` None: the scene's faces as they
    are). ``reference``: the room's target mean (lux) for deviations on shade targets."""
    from invrad_wb.core.output.metrics import relative_deviation
    faces = np.flatnonzero(scene.face_room == room)
    verts, inv = np.unique(scene.faces[faces].reshape(-1), return_inverse=True)
    xyz = scene.vertices[verts].copy()
    tri = inv.reshape(-1, 3)
    plane = scene.face_plane[faces]
    T, E = target[verts].copy(), achieved[verts].copy()
    n_split = 0
    if luminaires:
        normal = scene.vertex_normals[verts]
        direct = np.full(len(xyz), np.nan)
        for _ in range(levels):
            steep = np.ptp(E[tri], axis=1) > fraction * lux_max
            if not steep.any():
                break
            n_split += int(steep.sum())
            xyz, tri, plane, T, E, normal, direct = _split_faces(
                scene, xyz, tri, plane, T, E, normal, direct, steep, luminaires, backend)
    D = relative_deviation(T, E, reference)
    return DisplayMesh(xyz, tri, np.asarray(plane, np.int64), T, E, D, n_split)


def _split_faces(scene, xyz, tri, plane, T, E, normal, direct, steep, luminaires,
                 backend):
    """Split the ``steep`` faces in four at their edge midpoints; new points get the exact
    direct light plus the interpolated indirect light."""
    from invrad_wb.core.forward.direct import direct_illuminance
    from invrad_wb.core.forward.render import scene_bvh
    st = tri[steep]
    edges = np.sort(np.concatenate([st[:, [0, 1]], st[:, [1, 2]], st[:, [2, 0]]]), axis=1)
    uniq, e_inv = np.unique(edges, axis=0, return_inverse=True)
    mid = len(xyz) + np.arange(len(uniq))
    m01, m12, m20 = e_inv.reshape(3, -1)
    a, b = uniq[:, 0], uniq[:, 1]
    # direct light where it is not known yet: the split edges' ends and the midpoints
    new_xyz = 0.5 * (xyz[a] + xyz[b])
    new_n = normal[a]
    need = np.unique(uniq.reshape(-1))
    need = need[np.isnan(direct[need])]
    pts = np.concatenate([xyz[need], new_xyz])
    nrm = np.concatenate([normal[need], new_n])
    d = direct_illuminance(pts, nrm, luminaires, bvh=scene_bvh(scene), backend=backend)
    direct[need] = d[:len(need)]
    indirect = 0.5 * ((E[a] - direct[a]) + (E[b] - direct[b]))
    new_d = d[len(need):]
    xyz = np.concatenate([xyz, new_xyz])
    normal = np.concatenate([normal, new_n])
    direct = np.concatenate([direct, new_d])
    E = np.concatenate([E, np.maximum(new_d + indirect, 0.0)])
    T = np.concatenate([T, 0.5 * (T[a] + T[b])])
    m01, m12, m20 = mid[m01], mid[m12], mid[m20]
    kids = np.concatenate([np.stack([st[:, 0], m01, m20], 1), np.stack([m01, st[:, 1], m12], 1),
                           np.stack([m20, m12, st[:, 2]], 1), np.stack([m01, m12, m20], 1)])
    tri = np.concatenate([tri[~steep], kids])
    plane = np.concatenate([plane[~steep], np.tile(plane[steep], 4)])
    return xyz, tri, plane, T, E, normal, direct
