"""Colour scales and room rasters of illuminance; PNG and EXR files (OpenImageIO).

Colour scales, per-value (the workbench's 3-D overlay uses them; the report's figures use
the same maps through matplotlib, :mod:`invrad_wb.core.output.figures`):

* :func:`false_colour`: illuminance on a linear scale ``vmin .. vmax`` lux in viridis
  (dark blue -> green -> yellow; perceptually ordered, readable in grey and by the colour
  blind). Values above ``vmax`` get the top colour. No target (NaN) is grey; a shade
  target (exactly 0 lx, "must stay dark") can be drawn black. :func:`nice_max` picks a
  round top of scale.
* :func:`diverging`: deviation from the target, ``-limit .. +limit`` (default +-50 %):
  blue = too dark, white = on target, red = too bright; values beyond the limit get the
  end colours.

Room layouts and rasters (the values behind the report's pictures, written as EXR):

* :func:`unfolded_layout`: every plane of a room laid flat, seen from inside the room: a
  box net. The floor is in plan (x to the right, y up) in the middle; each vertical wall
  is folded down about its foot into the floor's plane, so it lies beside the floor edge it
  stands on with its top away from the floor; the largest horizontal ceiling is attached
  beyond the top wall, mirrored as seen from below. Planes that do not fit that net (work
  planes, table tops, pillars, sloped ceilings, walls that would overlap in concave rooms)
  are each in their own (u, v) frame (walls: horizontal to the right, up is up),
  shelf-packed to the right of the net. :func:`unfolded_raster` samples it on pixels.
* :func:`plan_raster`: the room seen from above (orthographic): its upward-facing planes,
  the highest one where they overlap (a work plane hides the floor below it).

Rasters interpolate per-vertex values barycentrically over the faces (exactly the
piecewise-linear field the metrics integrate). :func:`save_png` and :func:`save_exr`
write atomically (temporary file with the right extension in the same folder, then
rename).
"""
from dataclasses import dataclass
import math

import numpy as np

from invrad_wb.core.model.oiio import oiio_module, read_pixels

from invrad_wb.core.io.atomic import atomic_path, write_error
from invrad_wb.core.geometry.raster import locate_points

# ---------------------------------------------------------------------------- colours


def _matplotlib_stops(name, n):
    """(n, 3) float64 0-255: matplotlib's colour map ``name`` at n evenly spaced points."""
    import matplotlib
    return matplotlib.colormaps[name](np.linspace(0.0, 1.0, n))[:, :3] * 255.0


_STOPS = {}


def _viridis():
    """:data:`VIRIDIS`, computed on first use: importing matplotlib costs a command that
    draws nothing (``locate``, whose requirement check imports this module) 0.2-0.3 s."""
    if "viridis" not in _STOPS:
        _STOPS["viridis"] = _matplotlib_stops("viridis", 9)
    return _STOPS["viridis"]


def __getattr__(name):
    #: VIRIDIS: viridis, matplotlib's (the report's figures use it, :func:`invrad_wb.core.
    #: output.figures.lux_cmap`) at 9 evenly spaced points, interpolated linearly (the
    #: workbench overlay, :mod:`invrad_wb.gui.display`, uses the same points: its colours
    #: match these images); made on first use (:func:`_viridis`)
    if name == "VIRIDIS":
        return _viridis()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


#: the deviation scale: matplotlib's RdBu_r (ColorBrewer RdBu reversed), blue (too dark) ->
#: white (on target) -> red (too bright), the map of the report's deviation figures
#: (:func:`invrad_wb.core.output.figures.deviation_cmap`)
DIVERGING_CMAP = "RdBu_r"
NAN_GREY = (150, 150, 150)          # no target
SHADE_BLACK = (5, 5, 5)             # target 0 lx (display.SHADE_RGB)

#: Default deviation scale: -50 % .. +50 %.
DEVIATION_LIMIT = 0.5


def _lut(stops, t):
    t = np.clip(t, 0.0, 1.0) * (len(stops) - 1)
    i = np.minimum(np.floor(t).astype(np.int64), len(stops) - 2)
    f = (t - i)[..., None]
    return stops[i] * (1 - f) + stops[i + 1] * f


def false_colour(values, vmin, vmax, shade=False):
    """Illuminance to viridis.

    Parameters
    ----------
    values : (...) float64, lux; NaN = no target
    vmin, vmax : float, lux at the bottom and top of the scale (linear; clipped outside)
    shade : bool
        Draw values of exactly 0 lx black (target images: "must stay dark").

    Returns
    -------
    (..., 3) uint8 RGB; NaN -> :data:`NAN_GREY`.
    """
    v = np.asarray(values, dtype=np.float64)
    t = (v - vmin) / max(float(vmax) - float(vmin), 1e-12)
    rgb = _lut(_viridis(), np.nan_to_num(t)).round().astype(np.uint8)
    rgb[~np.isfinite(v)] = NAN_GREY
    if shade:
        rgb[v == 0] = SHADE_BLACK
    return rgb


def diverging(values, limit=DEVIATION_LIMIT):
    """Relative deviation (0.1 = 10 % too bright) to blue / white / red.

    Parameters
    ----------
    values : (...) float64, fraction of the target; NaN = no target
    limit : float, the fraction drawn in the end colours (0.5 = +-50 %)

    Returns
    -------
    (..., 3) uint8 RGB; NaN -> :data:`NAN_GREY`.
    """
    import matplotlib
    v = np.asarray(values, dtype=np.float64)
    t = np.clip(np.nan_to_num(0.5 + 0.5 * v / max(float(limit), 1e-12), nan=0.5), 0.0, 1.0)
    rgb = (matplotlib.colormaps[DIVERGING_CMAP](t)[..., :3] * 255.0).round().astype(np.uint8)
    rgb[~np.isfinite(v)] = NAN_GREY
    return rgb


def nice_max(value):
    """A round top of scale >= ``value`` (1, 1.5, 2, 2.5, 3, 4, 5, 6, 8 x 10^k).

    The workbench overlay (:mod:`invrad_wb.gui.display`) uses this rule too.
    """
    v = float(value)
    if not np.isfinite(v) or v <= 0:
        return 1.0
    k = math.floor(math.log10(v))
    for m in (1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0):
        if m * 10 ** k >= v * (1 - 1e-9):
            return float(m * 10 ** k)
    return float(10 ** (k + 1))


# ---------------------------------------------------------------------------- rasters
@dataclass
class RoomRaster:
    """Which face, and where in it, each pixel of a room image shows.

    Attributes
    ----------
    face : (h, w) int64, scene face index, -1 = background
    bary : (h, w, 3) float64, barycentric weights of the face's corners
    plane : (h, w) int64, scene plane index, -1 = background
    metres_per_pixel : float
    transforms : dict plane index -> (A (2, 3), b (2,)): 2-D image frame ``X = A p + b``
        (metres, X to the right, Y up) of a 3-D point ``p`` on that plane
    x0, y1 : float, image frame coordinates (metres) of the left and top image edges
    layout : str, how the planes were placed (for captions)
    faces_of : (m, 3) int64, the scene's faces
    """
    face: np.ndarray
    bary: np.ndarray
    plane: np.ndarray
    metres_per_pixel: float
    transforms: dict
    x0: float
    y1: float
    layout: str = ""
    faces_of: np.ndarray = None     # the scene's faces (m, 3), for sample()

    @property
    def shape(self):
        return self.face.shape

    def sample(self, vertex_values):
        """(h, w) float64 values interpolated from per-vertex ``(n,)`` values; NaN off faces
        and on faces with a NaN corner."""
        v = np.asarray(vertex_values, dtype=np.float64)
        out = np.full(self.face.shape, np.nan)
        on = self.face >= 0
        if on.any():
            corner = self.faces_of[self.face[on]]
            vals = v[corner]
            bad = ~np.all(np.isfinite(vals), axis=1)
            res = np.einsum("kj,kj->k", self.bary[on], np.nan_to_num(vals))
            res[bad] = np.nan
            out[on] = res
        return out

    def pixel_of(self, points, plane):
        """Image (col, row) floats of 3-D points (k, 3) on ``plane`` (pixel centres at +0.5)."""
        A, b = self.transforms[int(plane)]
        xy = np.asarray(points, dtype=np.float64).reshape(-1, 3) @ A.T + b
        return np.stack([(xy[:, 0] - self.x0) / self.metres_per_pixel,
                         (self.y1 - xy[:, 1]) / self.metres_per_pixel], axis=1)


_MPP_STEPS = (0.005, 0.01, 0.015, 0.02, 0.025, 0.03, 0.04, 0.05, 0.075, 0.1, 0.15, 0.2,
              0.25, 0.3, 0.4, 0.5, 0.75, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0)


def auto_metres_per_pixel(extent_m, max_pixels):
    """The smallest round pixel size that fits ``extent_m`` metres into ``max_pixels``."""
    need = float(extent_m) / max(int(max_pixels), 16)
    for s in _MPP_STEPS:
        if s >= need * (1 - 1e-9):
            return s
    return nice_max(need)


def _scan_triangles(tri, h, w, chunk=1 << 22):
    """Pixels whose centres lie in triangles given in pixel coordinates.

    Parameters
    ----------
    tri : (k, 3, 2) float64, (col, row) of the corners; pixel (r, c) has its centre at
        (c + 0.5, r + 0.5)
    h, w : image size

    Yields
    ------
    (triangle, row, col, barycentric (j, 3)) arrays per chunk of triangles; a pixel on an
    edge shared by two triangles is yielded for both.
    """
    lo = np.floor(tri.min(axis=1) - 0.5).astype(np.int64) + 1     # first centre >= min
    hi = np.floor(tri.max(axis=1) - 0.5).astype(np.int64)          # last centre <= max
    lo = np.maximum(lo, 0)
    hi[:, 0] = np.minimum(hi[:, 0], w - 1)
    hi[:, 1] = np.minimum(hi[:, 1], h - 1)
    nx = np.maximum(hi[:, 0] - lo[:, 0] + 1, 0)
    ny = np.maximum(hi[:, 1] - lo[:, 1] + 1, 0)
    cnt = nx * ny
    a, b_, c = tri[:, 0], tri[:, 1], tri[:, 2]
    v0, v1 = b_ - a, c - a
    den = v0[:, 0] * v1[:, 1] - v1[:, 0] * v0[:, 1]
    good = np.abs(den) > 1e-12
    start = 0
    k = len(tri)
    while start < k:
        csum = np.cumsum(cnt[start:])
        stop = start + max(int(np.searchsorted(csum, chunk, side="right")), 1)
        idx = np.arange(start, min(stop, k))
        idx = idx[good[idx] & (cnt[idx] > 0)]
        start = stop
        if not len(idx):
            continue
        n = cnt[idx]
        tid = np.repeat(idx, n)
        off = np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)
        col = lo[tid, 0] + off % nx[tid]
        row = lo[tid, 1] + off // nx[tid]
        px = col + 0.5 - a[tid, 0]
        py = row + 0.5 - a[tid, 1]
        l1 = (px * v1[tid, 1] - v1[tid, 0] * py) / den[tid]
        l2 = (v0[tid, 0] * py - px * v0[tid, 1]) / den[tid]
        l0 = 1.0 - l1 - l2
        eps = -1e-9
        ok = (l0 >= eps) & (l1 >= eps) & (l2 >= eps)
        bw = np.clip(np.stack([l0[ok], l1[ok], l2[ok]], axis=1), 0.0, 1.0)
        bw /= bw.sum(axis=1, keepdims=True)
        yield tid[ok], row[ok], col[ok], bw


def _rasterise(scene, tiles, mpp=None, max_pixels=720, margin_px=(10, 10, 10, 10)):
    """Rasterise tiles [(plane, A, b, faces, priority)] into a :class:`RoomRaster`.

    Where tiles overlap, the higher priority wins (plan views: the higher plane).
    ``margin_px`` = (left, top, right, bottom).
    """
    tri2d_all, lo, hi = [], np.full(2, np.inf), np.full(2, -np.inf)
    for plane, A, b, faces, prio in tiles:
        t = scene.vertices[scene.faces[faces]] @ A.T + b        # (k, 3, 2)
        tri2d_all.append(t)
        lo = np.minimum(lo, t.reshape(-1, 2).min(0))
        hi = np.maximum(hi, t.reshape(-1, 2).max(0))
    span = hi - lo
    if mpp is None:
        mpp = auto_metres_per_pixel(float(max(span.max(), 1e-3)), max_pixels)
    ml, mt, mr, mb = margin_px
    w = int(math.ceil(span[0] / mpp - 1e-9)) + ml + mr
    h = int(math.ceil(span[1] / mpp - 1e-9)) + mt + mb
    x0 = lo[0] - ml * mpp
    y1 = hi[1] + mt * mpp
    face = np.full((h, w), -1, np.int64)
    bary = np.zeros((h, w, 3))
    plane_img = np.full((h, w), -1, np.int64)
    order = sorted(range(len(tiles)), key=lambda i: -tiles[i][4])
    for i in order:
        plane, A, b, faces, prio = tiles[i]
        # triangles in pixel coordinates (col, row); pixel (r, c) has its centre at +0.5
        t = np.stack([(tri2d_all[i][..., 0] - x0) / mpp, (y1 - tri2d_all[i][..., 1]) / mpp],
                     axis=-1)
        for ti, rr, cc, bw in _scan_triangles(t, h, w):
            free = face[rr, cc] < 0
            rr, cc = rr[free], cc[free]
            face[rr, cc] = np.asarray(faces)[ti[free]]
            bary[rr, cc] = bw[free]
            plane_img[rr, cc] = plane
    transforms = {int(p): (A, b) for p, A, b, _, _ in tiles}
    return RoomRaster(face=face, bary=bary, plane=plane_img, metres_per_pixel=float(mpp),
                      transforms=transforms, x0=float(x0), y1=float(y1),
                      faces_of=scene.faces)


def room_floor_z(scene, room):
    """Height (m) of a room's floor: its lowest upward-facing real plane (else lowest vertex)."""
    ups = [p for p in scene.planes if p.room == room and p.normal[2] > 0.9
           and not p.is_virtual]
    if ups:
        return float(min(p.origin[2] for p in ups))
    f = scene.faces[scene.face_room == room]
    return float(scene.vertices[f.reshape(-1), 2].min())


def _facing(n):
    n = np.asarray(n, dtype=np.float64)
    h = n[:2] / max(np.linalg.norm(n[:2]), 1e-12)
    ax = int(np.argmax(np.abs(h)))
    if abs(h[ax]) > 0.98:
        return ("+" if h[ax] > 0 else "-") + "xy"[ax]
    return f"({h[0]:+.2f}, {h[1]:+.2f})"


def describe_plane(plane, floor_z=None):
    """A plane in words: 'floor', 'ceiling', 'wall x = 0.00 m (facing +x)', 'wall facing
    (+0.71, -0.71)', 'work plane at 0.75 m', 'sloped ceiling', ...

    ``floor_z`` (the room's floor height) lets horizontal planes above the floor be told
    from it and gives work planes their height.
    """
    n = plane.normal
    z = float(plane.origin[2])
    if plane.is_virtual:
        if abs(n[2]) < 0.1:                # a vertical virtual face: where rooms meet
            return "open border"
        if floor_z is not None and abs(n[2]) > 0.9:
            return f"work plane at {z - floor_z:.2f} m"
        return "work plane"
    if n[2] > 0.9:
        if floor_z is not None and z - floor_z > 0.05:
            return f"horizontal surface at {z - floor_z:.2f} m"
        return "floor"
    if n[2] < -0.9:
        return "ceiling"
    if n[2] < -0.3:
        return "sloped ceiling"
    if n[2] > 0.3:
        return "sloped floor"
    f = _facing(n)
    if f[0] in "+-" and len(f) == 2:                 # axis-aligned: say where it stands
        ax = "xy".index(f[1])
        return f"wall {f[1]} = {plane.origin[ax]:.2f} m (facing {f})"
    return f"wall facing {f}"


def _short_label(plane, floor_z):
    """Label of a plane in images: 'floor', 'wall x = 0.00 m', 'ceiling', ..."""
    s = describe_plane(plane, floor_z)
    return s.split(" (facing")[0].replace("horizontal surface", "surface")


@dataclass
class UnfoldedLayout:
    """Where each plane of a room lies in a flat picture of the room (metres).

    Attributes
    ----------
    tiles : dict plane index -> (A (2, 3), b (2,)): picture coordinates ``X = A p + b``
        (metres, X to the right, Y up) of a 3-D point ``p`` on that plane
    labels : list of dict, one per plane: ``plane``, ``text`` ('floor', 'wall x = 0.00 m'),
        ``xy`` (where to write it, metres: walls of the net near their foot, the attached
        ceiling near the top wall, other planes at their centre), ``rotation`` (degrees:
        90 for the walls folded out to the left and right)
    layout : str, 'box net' or 'shelf'
    """
    tiles: dict
    labels: list
    layout: str


def _plane_extent(scene, plane, A, b):
    t = scene.vertices[scene.faces[plane.faces]].reshape(-1, 3) @ A.T + b
    return t.min(0), t.max(0)


def _net_cells(scene, plane, A, b, res):
    """Grid cells (of size ``res``) whose centre the plane covers in the net."""
    t = scene.vertices[scene.faces[plane.faces]] @ A.T + b
    lo_t = np.floor(t.reshape(-1, 2).min(0) / res).astype(np.int64)
    hi_t = np.ceil(t.reshape(-1, 2).max(0) / res).astype(np.int64)
    ii, jj = np.mgrid[lo_t[0]:hi_t[0] + 1, lo_t[1]:hi_t[1] + 1]
    ii, jj = ii.reshape(-1), jj.reshape(-1)
    tri, _ = locate_points(t, np.stack([(ii + 0.5) * res, (jj + 0.5) * res], 1))
    ok = tri >= 0
    return set(zip(ii[ok].tolist(), jj[ok].tolist()))


def _box_net(scene, planes, floor, floor_z):
    """The floor in plan and the vertical walls folded out around it, each wall that does
    not overlap what is already placed. Returns (net {plane: (A, b)}, the other planes)."""
    net = {floor.index: (np.array([[1.0, 0, 0], [0, 1.0, 0]]), np.zeros(2))}
    walls = sorted([p for p in planes if abs(p.normal[2]) < 0.02 and not p.is_virtual],
                   key=lambda p: -p.area)
    ext = float(max(np.ptp(scene.vertices[scene.faces[np.concatenate(
        [p.faces for p in planes])]].reshape(-1, 3), axis=0).max(), 1e-3))
    res = ext / 150.0
    occupied = _net_cells(scene, floor, *net[floor.index], res)
    others = []
    for p in walls:
        hxy = p.normal[:2] / np.linalg.norm(p.normal[:2])
        A = np.array([[1.0, 0, -hxy[0]], [0, 1.0, -hxy[1]]])
        b = hxy * floor_z
        mine = _net_cells(scene, p, A, b, res)
        if len(mine & occupied) > 0.01 * max(len(mine), 1):
            others.append(p)
            continue
        occupied |= mine
        net[p.index] = (A, b)
    others += [p for p in planes if p.index not in net and p not in others]
    return net, others


def _shelf_pack(scene, others, tiles, nlo, nhi, gap):
    """Place ``others`` each in its own (u, v) frame in rows to the right of the net
    (or alone, about square, when there is no net); fills ``tiles``."""
    sizes = []
    for p in others:
        A = np.stack([p.u, p.v])
        lo_p, hi_p = _plane_extent(scene, p, A, np.zeros(2))
        sizes.append((p, A, lo_p, hi_p - lo_p))
    sizes.sort(key=lambda s: -s[3][1])
    total = sum(float(s[3][0] * s[3][1]) for s in sizes)
    widest = max(float(s[3][0]) for s in sizes)
    if nlo is not None:
        limit = max(widest, 0.75 * float(nhi[1] - nlo[1]))
        x_start, y_top = float(nhi[0]) + 2 * gap, float(nhi[1])
    else:
        limit = max(widest, math.sqrt(1.6 * total))
        x_start, y_top = 0.0, 0.0
    x, row_h = x_start, 0.0
    for p, A, lo_p, size in sizes:
        if x > x_start and x + size[0] > x_start + limit + 1e-9:
            y_top -= row_h + gap
            x, row_h = x_start, 0.0
        tiles[p.index] = (A, np.array([x - lo_p[0], y_top - size[1] - lo_p[1]]))
        x += float(size[0]) + gap
        row_h = max(row_h, float(size[1]))


def unfolded_layout(scene, room):
    """All planes of a room laid flat, as a box net (see the module docstring).

    Returns
    -------
    :class:`UnfoldedLayout`
    """
    # open borders (vertical virtual faces where the room meets another with no wall)
    # have no target and are no surface: not drawn
    planes = [p for p in scene.planes if p.room == room
              and not (p.is_virtual and abs(p.normal[2]) < 0.1)]
    if not planes:
        raise ValueError(f"room {room} has no planes")
    floor_z = room_floor_z(scene, room)
    ups = [p for p in planes if p.normal[2] > 0.99 and not p.is_virtual
           and abs(p.origin[2] - floor_z) < 0.05]
    floor = max(ups, key=lambda p: p.area) if ups else None
    net, others = _box_net(scene, planes, floor, floor_z) if floor else ({}, list(planes))
    tiles = dict(net)
    nlo = nhi = None
    if net:
        los, his = zip(*(_plane_extent(scene, scene.planes[k], *net[k]) for k in net))
        nlo, nhi = np.min(los, axis=0), np.max(his, axis=0)
    gap = max(0.15, 0.02 * float(max(nhi - nlo))) if net else 0.15
    attached = None
    # the largest horizontal ceiling completes the net beyond its top edge
    ceilings = [p for p in others if p.normal[2] < -0.99 and not p.is_virtual]
    if net and ceilings:
        c = max(ceilings, key=lambda p: p.area)
        A = np.stack([c.u, c.v])
        # its u is +x (plane_basis), so keep x; put its bottom (v min) on the net's top
        lo_c, _ = _plane_extent(scene, c, A, np.zeros(2))
        tiles[c.index] = (A, np.array([0.0 if c.u[0] > 0.99 else nlo[0] - lo_c[0],
                                       nhi[1] - lo_c[1]]))
        attached = c.index
        others.remove(c)
        lo2, hi2 = _plane_extent(scene, c, *tiles[c.index])
        nlo, nhi = np.minimum(nlo, lo2), np.maximum(nhi, hi2)
    if others:
        _shelf_pack(scene, others, tiles, nlo, nhi, gap)
    labels = []
    for k, (A, b) in tiles.items():
        pl = scene.planes[k]
        lo_p, hi_p = _plane_extent(scene, pl, A, b)
        c = 0.5 * (lo_p + hi_p)
        # walls of the net: label near the foot (the floor edge), ceiling near the top wall
        inward = None
        if k in net and k != floor.index:
            inward = pl.normal[:2] / np.linalg.norm(pl.normal[:2])   # towards the floor
        elif k == attached:
            inward = np.array([0.0, -1.0])
        if inward is not None:
            half = 0.5 * abs(float((hi_p - lo_p) @ np.abs(inward)))
            c = c + inward * max(half - 0.3, 0.0)
        # walls folded out to the left or right read along their foot: written upright
        side = inward is not None and abs(inward[0]) > 0.7
        labels.append({"plane": int(k), "text": _short_label(pl, floor_z), "xy": c,
                       "rotation": 90 if side else 0})
    return UnfoldedLayout(tiles=tiles, labels=labels,
                          layout="box net" if net else "shelf")


def unfolded_raster(scene, room, metres_per_pixel=None, max_pixels=800, layout=None):
    """All planes of a room in one raster, laid out by :func:`unfolded_layout` (for the
    values of the unfolded pictures as EXR).

    Parameters
    ----------
    scene : Scene
    room : int, room id
    metres_per_pixel : float, optional (default: a round size that fits ``max_pixels``)
    layout : :class:`UnfoldedLayout`, optional (default: computed)

    Returns
    -------
    :class:`RoomRaster` (``layout`` is 'box net' or 'shelf')
    """
    lay = unfolded_layout(scene, room) if layout is None else layout
    tile_list = [(k, A, b, scene.planes[k].faces, 0) for k, (A, b) in lay.tiles.items()]
    r = _rasterise(scene, tile_list, metres_per_pixel, max_pixels)
    r.layout = lay.layout
    return r

def plan_raster(scene, room, metres_per_pixel=None, max_pixels=640,
                margin_px=(10, 10, 10, 10)):
    """The room's upward-facing planes seen from above, x to the right and y up.

    Where planes overlap the higher one is shown (a work plane hides the floor below).
    Returns a :class:`RoomRaster` (``layout`` 'plan'), or None if the room has no
    upward-facing plane.
    """
    ups = [p for p in scene.planes if p.room == room and p.normal[2] > 0.9]
    if not ups:
        return None
    A = np.array([[1.0, 0, 0], [0, 1.0, 0]])
    tiles = [(p.index, A, np.zeros(2), p.faces, float(p.origin[2])) for p in ups]
    r = _rasterise(scene, tiles, metres_per_pixel, max_pixels, margin_px)
    r.layout = "plan"
    return r


# ---------------------------------------------------------------------------- files
def _oiio():
    return oiio_module("writing images")


def _write(path, pixels, fmt, suffix, channel_names=None, compression=None):
    oiio = _oiio()
    pixels = np.ascontiguousarray(pixels)
    if pixels.ndim == 2:
        pixels = pixels[:, :, None]   # OpenImageIO misreads 2-D arrays
    if pixels.ndim != 3 or pixels.shape[0] < 1 or pixels.shape[1] < 1 \
            or not 1 <= pixels.shape[2] <= 4 and channel_names is None:
        raise ValueError(f"{path}: an image must be (h, w) or (h, w, c) with c in 1..4,"
                         f" got shape {pixels.shape}")
    h, w, c = pixels.shape
    spec = oiio.ImageSpec(w, h, c, fmt)
    if channel_names is not None:
        if len(channel_names) != c:
            raise ValueError(f"{path}: {len(channel_names)} channel names for {c} channels")
        spec.channelnames = tuple(str(n) for n in channel_names)
    if compression:
        spec.attribute("compression", compression)
    with atomic_path(path, suffix=suffix) as tmp:
        out = oiio.ImageOutput.create(tmp)
        if out is None:
            raise write_error(path, tmp, oiio.geterror())
        try:
            if not out.open(tmp, spec):
                raise write_error(path, tmp, out.geterror())
            if not out.write_image(pixels):
                raise write_error(path, tmp, out.geterror())
        finally:
            out.close()
    return path


def save_png(path, image):
    """Write an 8-bit PNG atomically.

    Parameters
    ----------
    path : str, written as PNG whatever its extension
    image : (h, w) grey, (h, w, 3) RGB or (h, w, 4) RGBA; uint8, bool, or float in [0, 1]
        (NaN -> 0)

    Returns
    -------
    path
    """
    oiio = _oiio()
    a = np.asarray(image)
    if a.dtype == bool:
        a = a.astype(np.uint8) * 255
    elif np.issubdtype(a.dtype, np.floating):
        a = np.round(np.clip(np.nan_to_num(a), 0.0, 1.0) * 255.0).astype(np.uint8)
    elif a.dtype != np.uint8:
        if a.size and (a.min() < 0 or a.max() > 255):
            raise ValueError(f"{path}: integer image values must be 0..255")
        a = a.astype(np.uint8)
    return _write(path, a, oiio.UINT8, ".png")


def save_exr(path, values, channel_names=None, half=False):
    """Write a float array as an OpenEXR file atomically (NaN kept).

    Parameters
    ----------
    values : (h, w) or (h, w, c) float (e.g. lux)
    channel_names : list of c str, optional (e.g. ['target', 'achieved']). OpenEXR stores
        channels sorted by name: readers should pick them by name.
    half : bool, store 16-bit floats (3 significant digits, up to 65504; half the size)
        instead of 32-bit
    """
    oiio = _oiio()
    return _write(path, np.asarray(values, dtype=np.float32), oiio.HALF if half
                  else oiio.FLOAT, ".exr", channel_names, "zip")


def read_image(path):
    """(h, w, c) float32 pixels of an image file (PNG scaled to [0, 1])."""
    try:
        return read_pixels(path).values
    except OSError as exc:
        raise OSError(f"cannot read {path}: {exc}") from None
