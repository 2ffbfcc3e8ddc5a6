"""False-colour images of illuminance for people to look at, written with OpenImageIO.

Colour scales (both documented in every image by a labelled colour bar):

* :func:`false_colour`: illuminance on a linear scale ``vmin .. vmax`` lux in viridis
  (dark blue -> green -> yellow; perceptually ordered, readable in grey and by the colour
  blind; the same 9 stops as the workbench's 3D overlay). Values above ``vmax`` get the top
  colour. No target (NaN) is grey, hatched in maps; a shade target (exactly 0 lx, "must
  stay dark") can be drawn black.
* :func:`diverging`: deviation from the target, ``-limit .. +limit`` (default +-50 %):
  blue = too dark, white = on target, red = too bright; values beyond the limit get the
  end colours.

Room maps are rasterised from per-vertex values by barycentric interpolation over the
faces (exactly the piecewise-linear field the metrics integrate):

* :func:`unfolded_raster`: every plane of a room, seen from inside the room. Layout: a box
  net. The floor is drawn in plan (x to the right, y up) in the middle; each vertical wall
  is folded down about its foot into the floor's plane, so it lies beside the floor edge it
  stands on with its top away from the floor (read it rotated so that the floor edge is at
  the bottom); the largest horizontal ceiling is attached beyond the top wall, mirrored as
  seen from below. Planes that do not fit that net (work planes, table tops, pillars,
  sloped ceilings, walls that would overlap in concave rooms) are drawn each in its own
  (u, v) frame (walls: horizontal to the right, up is up) and shelf-packed to the right of
  the net. Every plane is outlined and labelled ("floor", "wall +x", ...).
* :func:`plan_raster`: the room seen from above (orthographic): its upward-facing planes,
  the highest one where they overlap (a work plane hides the floor below it).

Files: :func:`save_png` and :func:`save_exr` write atomically (temporary file with the
right extension in the same folder, then rename), for anyone who needs an image out.
"""
from dataclasses import dataclass, field
import math

import numpy as np

from invrad_wb.errors import InvradError
from invrad_wb.core.io.oiio import oiio_module, read_pixels

from invrad_wb.core.io.atomic import atomic_path
from invrad_wb.core.geometry.raster import locate_points

# ---------------------------------------------------------------------------- colours
#: viridis, matplotlib's values at 9 evenly spaced points, interpolated linearly
#: (the workbench overlay, :mod:`invrad_wb.gui.display`, uses it too)
VIRIDIS = np.array([[68, 1, 84], [71, 44, 122], [59, 81, 139], [44, 113, 142],
                    [33, 144, 141], [39, 173, 129], [92, 200, 99], [170, 220, 50],
                    [253, 231, 37]], dtype=np.float64)
#: ColorBrewer RdBu (7 classes), blue (too dark) -> white (on target) -> red (too bright)
DIVERGING_STOPS = np.array([[33, 102, 172], [103, 169, 207], [209, 229, 240],
                            [247, 247, 247], [253, 219, 199], [239, 138, 98],
                            [178, 24, 43]], dtype=np.float64)
NAN_GREY = (150, 150, 150)          # no target (hatched with HATCH_LIGHT in maps)
HATCH_LIGHT = (205, 205, 205)
SHADE_BLACK = (5, 5, 5)             # target 0 lx (display.SHADE_RGB)
BACKGROUND = (255, 255, 255)        # off the faces
OUTLINE = (45, 45, 45)              # plane outlines
TEXT = (20, 20, 20)

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
    rgb = _lut(VIRIDIS, np.nan_to_num(t)).round().astype(np.uint8)
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
    v = np.asarray(values, dtype=np.float64)
    t = 0.5 + 0.5 * v / max(float(limit), 1e-12)
    rgb = _lut(DIVERGING_STOPS, np.nan_to_num(t, nan=0.5)).round().astype(np.uint8)
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


def _nice_step(span, n=5):
    raw = span / max(n, 1)
    k = math.floor(math.log10(raw)) if raw > 0 else 0
    for m in (1, 2, 2.5, 5, 10):
        if m * 10 ** k >= raw * (1 - 1e-9):
            return m * 10 ** k
    return 10 ** (k + 1)


def lux_ticks(vmin, vmax, n=5):
    """Round tick values from vmin to vmax, about ``n`` intervals."""
    step = _nice_step(float(vmax) - float(vmin), n)
    first = math.ceil(vmin / step - 1e-9) * step
    return [float(round(t, 10)) for t in np.arange(first, vmax + 1e-9 * step, step)]


def _fmt_tick(v):
    if v == 0:
        return "0"
    if abs(v) >= 10 or float(v).is_integer():
        return f"{v:.0f}"
    return f"{v:.2g}"


# ---------------------------------------------------------------------------- text
_FONT = ["DroidSans"]


def draw_text(img, items, size=13):
    """Draw text into an RGB uint8 image with OpenImageIO's bundled font.

    Parameters
    ----------
    img : (h, w, 3) uint8
    items : iterable of (x, y, text) or (x, y, text, dict) with optional keys
        ``colour`` (RGB 0-255), ``align`` ('left', 'center', 'right'), ``valign``
        ('baseline', 'top', 'center', 'bottom'), ``shadow`` (pixels of dark outline),
        ``halo`` (RGB of a 2-pixel outline, e.g. white behind black text), ``box`` (RGB
        of a translucent box behind the text), ``size``.

    Returns
    -------
    (h, w, 3) uint8, a new image. Without text rendering (no FreeType) the image is
    returned unchanged: the pictures stay valid, only unlabelled.
    """
    items = list(items)
    if not items:
        return img
    try:
        oiio = oiio_module("drawing text")
    except InvradError:
        return img
    img = np.array(img, dtype=np.uint8, copy=True)
    for it in items:                       # label boxes first, text over them
        opt = it[3] if len(it) > 3 else {}
        if opt.get("box") is not None:
            _text_box(img, it[0], it[1], it[2], int(opt.get("size", size)),
                      opt.get("align", "left"), opt.get("valign", "baseline"), opt["box"])
    buf = oiio.ImageBuf(np.ascontiguousarray(img, dtype=np.float32) / 255.0)
    drew = False

    def put(x, y, text, kw):
        ok = oiio.ImageBufAlgo.render_text(buf, int(round(x)), int(round(y)), str(text),
                                           fontname=_FONT[0], **kw)
        if not ok and _FONT[0]:
            _FONT[0] = ""                      # fall back to OpenImageIO's default font
            ok = oiio.ImageBufAlgo.render_text(buf, int(round(x)), int(round(y)),
                                               str(text), fontname="", **kw)
        return ok

    for it in items:
        x, y, text = it[:3]
        opt = it[3] if len(it) > 3 else {}
        kw = dict(fontsize=int(opt.get("size", size)),
                  alignx=opt.get("align", "left"), aligny=opt.get("valign", "baseline"),
                  shadow=int(opt.get("shadow", 0)))
        halo = opt.get("halo")
        if halo is not None:
            hk = dict(kw, textcolor=tuple(c / 255.0 for c in halo))
            for dx, dy in ((-1, -1), (0, -1), (1, -1), (-1, 0), (1, 0), (-1, 1), (0, 1),
                           (1, 1), (-2, 0), (2, 0), (0, -2), (0, 2)):
                put(x + dx, y + dy, text, hk)
        kw["textcolor"] = tuple(c / 255.0 for c in opt.get("colour", TEXT))
        drew = put(x, y, text, kw) or drew
    if not drew:
        return img
    return np.clip(np.round(buf.get_pixels(oiio.FLOAT) * 255.0), 0, 255).astype(np.uint8)


def _text_box(img, x, y, text, size, align, valign, colour, alpha=0.8, pad=3):
    """Blend a box behind where :func:`draw_text` will put ``text`` (in place)."""
    try:
        oiio = oiio_module("measuring text")
        r = oiio.ImageBufAlgo.text_size(str(text), size, _FONT[0])
        x0, x1, y0, y1 = r.xbegin, r.xend, r.ybegin, r.yend
        if not r.defined:
            raise ValueError
    except Exception:       # noqa: BLE001 - measuring is best effort
        x0, x1, y0, y1 = 0, int(0.6 * size * len(str(text))), -int(0.75 * size), 2
    w, h = x1 - x0, y1 - y0
    left = {"left": x + x0, "center": x - w / 2, "right": x - w}.get(align, x + x0)
    top = {"baseline": y + y0, "top": y, "center": y - h / 2, "bottom": y - h}.get(
        valign, y + y0)
    r0, r1 = max(int(top - pad), 0), min(int(top + h + pad + 1), img.shape[0])
    c0, c1 = max(int(left - pad), 0), min(int(left + w + pad + 1), img.shape[1])
    if r1 > r0 and c1 > c0:
        sub = img[r0:r1, c0:c1].astype(np.float64)
        img[r0:r1, c0:c1] = np.round(sub * (1 - alpha) + np.asarray(colour) * alpha)


def text_width(text, size=13):
    """Width in pixels of ``text`` (an estimate if the font cannot be measured)."""
    try:
        oiio = oiio_module("measuring text")
        r = oiio.ImageBufAlgo.text_size(str(text), size, _FONT[0])
        if r.defined:
            return int(r.xend - r.xbegin)
    except Exception:       # noqa: BLE001 - measuring is best effort
        pass
    return int(0.6 * size * len(str(text)))


# ---------------------------------------------------------------------------- colour bars
def colour_bar(vmin, vmax, kind="lux", width=320, label=None, ticks=None, swatches=None,
               over=False):
    """A labelled horizontal colour bar.

    Parameters
    ----------
    vmin, vmax : float
        Lux for ``kind='lux'``; fractions for ``kind='deviation'`` (ticks shown in %).
    kind : {'lux', 'deviation'}
    width : int, pixels of the bar itself
    label : str, the title under the bar (default by ``kind``)
    ticks : list of float, optional
    swatches : list of (rgb, text), extra legend entries (e.g. no target = grey)
    over : bool, mark the top end "and above" (values beyond are clipped to it)

    Returns
    -------
    (h, w, 3) uint8
    """
    ml, mr = 34, 46
    bar_h, top = 16, 6
    t = np.linspace(0, 1, width)
    vals = vmin + t * (vmax - vmin)
    if kind == "deviation":
        row = diverging(vals, max(abs(vmin), abs(vmax)))
        if ticks is None:
            ticks = list(np.linspace(vmin, vmax, 5))
        lab = [f"{100 * x:+.0f} %" if abs(x) > 1e-12 else "0 %" for x in ticks]
        label = label or "deviation from target (achieved - target) / target"
    else:
        row = false_colour(vals, vmin, vmax)
        if ticks is None:
            ticks = lux_ticks(vmin, vmax)
        lab = [_fmt_tick(x) for x in ticks]
        if over and lab:
            lab[-1] += "+"
        label = label or "illuminance (lx)"
    swatches = list(swatches or [])
    h = top + bar_h + 6 + 14 + 20 + (20 if swatches else 0)
    w = ml + width + mr
    img = np.full((h, w, 3), BACKGROUND, np.uint8)
    img[top:top + bar_h, ml:ml + width] = row[None]
    img[top - 1, ml - 1:ml + width + 1] = OUTLINE
    img[top + bar_h, ml - 1:ml + width + 1] = OUTLINE
    img[top - 1:top + bar_h + 1, ml - 1] = OUTLINE
    img[top - 1:top + bar_h + 1, ml + width] = OUTLINE
    texts = []
    for x, s in zip(ticks, lab):
        px = ml + int(round((x - vmin) / max(vmax - vmin, 1e-12) * (width - 1)))
        img[top + bar_h:top + bar_h + 5, max(px - 0, 0):px + 1] = OUTLINE
        texts.append((px, top + bar_h + 18, s, {"align": "center", "size": 12}))
    y = top + bar_h + 38
    if kind == "deviation":
        texts.append((ml, y, "too dark", {"size": 12, "colour": tuple(DIVERGING_STOPS[0])}))
        texts.append((ml + width, y, "too bright",
                      {"size": 12, "align": "right", "colour": tuple(DIVERGING_STOPS[-1])}))
        texts.append((ml + width // 2, y, label.split(" (")[0], {"size": 12,
                                                                 "align": "center"}))
    else:
        texts.append((ml + width // 2, y, label, {"size": 12, "align": "center"}))
    if swatches:
        x = ml
        y0 = y + 8
        for rgb, text in swatches:
            sw = np.empty((12, 18, 3), np.uint8)
            sw[:] = rgb
            if tuple(rgb) == NAN_GREY:
                _hatch(sw, np.ones(sw.shape[:2], bool))
            img[y0:y0 + 12, x:x + 18] = sw
            img[y0, x:x + 18] = OUTLINE
            img[y0 + 11, x:x + 18] = OUTLINE
            img[y0:y0 + 12, x] = OUTLINE
            img[y0:y0 + 12, x + 17] = OUTLINE
            texts.append((x + 23, y0 + 10, text, {"size": 12}))
            x += 23 + text_width(text, 12) + 16
        if x > w:
            img = np.concatenate([img, np.full((h, x - w, 3), BACKGROUND, np.uint8)], axis=1)
    return draw_text(img, texts)


def _hatch(rgb, mask, period=6):
    """Diagonal grey stripes (the 'no target' pattern) where ``mask``."""
    h, w = mask.shape
    yy, xx = np.mgrid[:h, :w]
    stripe = ((xx + yy) % period) < period // 2
    rgb[mask & stripe] = NAN_GREY
    rgb[mask & ~stripe] = HATCH_LIGHT


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
    labels : list of dict, one per plane: ``x``, ``y`` (pixel centre of its tile),
        ``text``, ``w``, ``h`` (tile size in pixels), ``anchor`` (where to write it, or
        None for the centre)
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
    labels: list = field(default_factory=list)
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


def unfolded_raster(scene, room, metres_per_pixel=None, max_pixels=800):
    """All planes of a room in one image, as a box net (see the module docstring).

    Parameters
    ----------
    scene : Scene
    room : int, room id
    metres_per_pixel : float, optional (default: a round size that fits ``max_pixels``)

    Returns
    -------
    :class:`RoomRaster` (``layout`` is 'box net' or 'shelf')
    """
    planes = [p for p in scene.planes if p.room == room]
    if not planes:
        raise ValueError(f"room {room} has no planes")
    floor_z = room_floor_z(scene, room)
    ups = [p for p in planes if p.normal[2] > 0.99 and not p.is_virtual
           and abs(p.origin[2] - floor_z) < 0.05]
    floor = max(ups, key=lambda p: p.area) if ups else None
    net, others = {}, []
    if floor is not None:
        net[floor.index] = (np.array([[1.0, 0, 0], [0, 1.0, 0]]), np.zeros(2))
        walls = sorted([p for p in planes if abs(p.normal[2]) < 0.02 and not p.is_virtual],
                       key=lambda p: -p.area)
        ext = float(max(np.ptp(scene.vertices[scene.faces[np.concatenate(
            [p.faces for p in planes])]].reshape(-1, 3), axis=0).max(), 1e-3))
        res = ext / 300.0

        def cells(plane, A, b):
            """Grid cells (of size ``res``) whose centre the plane covers in the net."""
            t = scene.vertices[scene.faces[plane.faces]] @ A.T + b
            lo_t = np.floor(t.reshape(-1, 2).min(0) / res).astype(np.int64)
            hi_t = np.ceil(t.reshape(-1, 2).max(0) / res).astype(np.int64)
            ii, jj = np.mgrid[lo_t[0]:hi_t[0] + 1, lo_t[1]:hi_t[1] + 1]
            ii, jj = ii.reshape(-1), jj.reshape(-1)
            tri, _ = locate_points(t, np.stack([(ii + 0.5) * res, (jj + 0.5) * res], 1))
            ok = tri >= 0
            return set(zip(ii[ok].tolist(), jj[ok].tolist()))

        occupied = cells(floor, *net[floor.index])
        for p in walls:
            hxy = p.normal[:2] / np.linalg.norm(p.normal[:2])
            A = np.array([[1.0, 0, -hxy[0]], [0, 1.0, -hxy[1]]])
            b = hxy * floor_z
            mine = cells(p, A, b)
            if len(mine & occupied) > 0.01 * max(len(mine), 1):
                others.append(p)
                continue
            occupied |= mine
            net[p.index] = (A, b)
        placed = set(net)
        others += [p for p in planes if p.index not in placed and p not in others]
    else:
        others = list(planes)

    tiles = {k: v for k, v in net.items()}

    def extent(pl, A, b):
        t = scene.vertices[scene.faces[pl.faces]].reshape(-1, 3) @ A.T + b
        return t.min(0), t.max(0)

    if net:
        los, his = zip(*(extent(scene.planes[k], *tiles[k]) for k in tiles))
        nlo, nhi = np.min(los, axis=0), np.max(his, axis=0)
    else:
        nlo = nhi = np.zeros(2)
    gap = max(0.15, 0.02 * float(max(nhi - nlo)) if net else 0.15)
    attached = None
    # the largest horizontal ceiling completes the net beyond its top edge
    ceilings = [p for p in others if p.normal[2] < -0.99 and not p.is_virtual]
    if net and ceilings:
        c = max(ceilings, key=lambda p: p.area)
        A = np.stack([c.u, c.v])
        # its u is +x (plane_basis), so keep x; put its bottom (v min) on the net's top
        lo_c, hi_c = extent(c, A, np.zeros(2))
        b = np.array([0.0 if c.u[0] > 0.99 else nlo[0] - lo_c[0], nhi[1] - lo_c[1]])
        tiles[c.index] = (A, b)
        attached = c.index
        others.remove(c)
        lo2, hi2 = extent(c, A, b)
        nlo, nhi = np.minimum(nlo, lo2), np.maximum(nhi, hi2)
    # shelf-pack the rest, each in its own (u, v) frame
    if others:
        sizes = []
        for p in others:
            A = np.stack([p.u, p.v])
            lo_p, hi_p = extent(p, A, np.zeros(2))
            sizes.append((p, A, lo_p, hi_p - lo_p))
        sizes.sort(key=lambda s: -s[3][1])
        total = sum(float(s[3][0] * s[3][1]) for s in sizes)
        widest = max(float(s[3][0]) for s in sizes)
        if net:
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
            b = np.array([x - lo_p[0], y_top - size[1] - lo_p[1]])
            tiles[p.index] = (A, b)
            x += float(size[0]) + gap
            row_h = max(row_h, float(size[1]))
    tile_list = [(k, A, b, scene.planes[k].faces, 0) for k, (A, b) in tiles.items()]
    r = _rasterise(scene, tile_list, metres_per_pixel, max_pixels)
    r.layout = "box net" if net else "shelf"
    mpp = r.metres_per_pixel
    for k, (A, b) in tiles.items():
        pl = scene.planes[k]
        lo_p, hi_p = extent(pl, A, b)
        c = 0.5 * (lo_p + hi_p)
        size_m = hi_p - lo_p
        # walls of the net: label near the foot (the floor edge), ceiling near the top wall
        inward = None
        if k in net and k != floor.index:
            inward = pl.normal[:2] / np.linalg.norm(pl.normal[:2])   # towards the floor
        elif k == attached:
            inward = np.array([0.0, -1.0])
        anchor = None
        if inward is not None:
            half = 0.5 * abs(float(size_m @ np.abs(inward)))
            shift = max(half - 16 * mpp, 0.0)
            anchor = c + inward * shift
        r.labels.append({"x": (c[0] - r.x0) / mpp, "y": (r.y1 - c[1]) / mpp,
                         "text": _short_label(pl, floor_z),
                         "w": float(size_m[0] / mpp), "h": float(size_m[1] / mpp),
                         "anchor": None if anchor is None else
                         ((anchor[0] - r.x0) / mpp, (r.y1 - anchor[1]) / mpp)})
    return r


#: margins (left, top, right, bottom) of plan images, room for the axes
PLAN_MARGIN = (46, 26, 14, 40)


def plan_raster(scene, room, metres_per_pixel=None, max_pixels=640, margin_px=PLAN_MARGIN):
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


# ---------------------------------------------------------------------------- drawing
def paint(raster, values, colour_fn, outline=True):
    """Colour a raster: (h, w) values -> (h, w, 3) uint8 with background, hatched NaN
    and plane outlines."""
    on = raster.face >= 0
    rgb = np.full(raster.shape + (3,), BACKGROUND, np.uint8)
    ok = on & np.isfinite(values)
    if ok.any():
        rgb[ok] = colour_fn(values[ok])
    _hatch(rgb, on & ~np.isfinite(values))
    if outline:
        p = raster.plane
        edge = np.zeros(p.shape, bool)
        edge[:, 1:] |= p[:, 1:] != p[:, :-1]
        edge[:, :-1] |= p[:, 1:] != p[:, :-1]
        edge[1:] |= p[1:] != p[:-1]
        edge[:-1] |= p[1:] != p[:-1]
        edge[0] = edge[-1] = True
        edge[:, 0] = edge[:, -1] = True
        rgb[edge & on] = OUTLINE
    return rgb


def outline_mask(rgb, mask, colour=(0, 0, 0), dash=4):
    """Draw the boundary of ``mask`` (h, w) bool as a dashed line (in place), e.g. the
    shade targets."""
    e = np.zeros(mask.shape, bool)
    e[:, 1:] |= mask[:, 1:] & ~mask[:, :-1]
    e[:, :-1] |= mask[:, :-1] & ~mask[:, 1:]
    e[1:] |= mask[1:] & ~mask[:-1]
    e[:-1] |= mask[:-1] & ~mask[1:]
    yy, xx = np.mgrid[:mask.shape[0], :mask.shape[1]]
    on = ((xx + yy) // dash) % 2 == 0
    rgb[e & on] = colour
    rgb[e & ~on] = (255, 255, 255)
    return rgb


def contours(rgb, raster, values, step, colour=(0, 0, 0), alpha=0.45):
    """Blend iso-lines of ``values`` every ``step`` into ``rgb`` (in place)."""
    if not step or step <= 0:
        return rgb
    lvl = np.floor(np.where(np.isfinite(values), values, -1.0) / step)
    on = (raster.face >= 0) & np.isfinite(values)
    e = np.zeros(lvl.shape, bool)
    d = (lvl[:, 1:] != lvl[:, :-1]) & on[:, 1:] & on[:, :-1]
    e[:, 1:] |= d
    d = (lvl[1:] != lvl[:-1]) & on[1:] & on[:-1]
    e[1:] |= d
    rgb[e] = (rgb[e] * (1 - alpha) + np.asarray(colour) * alpha).astype(np.uint8)
    return rgb


def _disc(img, cx, cy, r, colour):
    h, w, _ = img.shape
    y0, y1 = max(int(cy - r - 1), 0), min(int(cy + r + 2), h)
    x0, x1 = max(int(cx - r - 1), 0), min(int(cx + r + 2), w)
    if y1 <= y0 or x1 <= x0:
        return
    yy, xx = np.mgrid[y0:y1, x0:x1]
    m = (xx + 0.5 - cx) ** 2 + (yy + 0.5 - cy) ** 2 <= r * r
    img[y0:y1, x0:x1][m] = colour


def mark_luminaires(img, marks):
    """Draw luminaires as marked circles: [(col, row, radius_px, label)] -> new image.

    A black ring with a white inner ring, a black centre dot and the label beside it.
    """
    texts = []
    for cx, cy, r, label in marks:
        r = max(float(r), 6.0)
        _disc(img, cx, cy, r + 2.0, (0, 0, 0))
        _disc(img, cx, cy, r, (255, 255, 255))
        _disc(img, cx, cy, r - 1.5, (0, 0, 0))
        _disc(img, cx, cy, r - 3.0, (255, 255, 255))
        _disc(img, cx, cy, 1.8, (0, 0, 0))
        if label:
            texts.append((cx + r + 6, cy - r + 4, label,
                          {"box": (255, 255, 255), "size": 13}))
    return draw_text(img, texts)


def _rotated_text(img, cx, cy, text, size, box=(255, 255, 255)):
    """Paste ``text`` turned 90 degrees (reading upwards) centred at (cx, cy), in place."""
    w = text_width(text, size) + 8
    h = size + 8
    tile = draw_text(np.full((h, w, 3), box, np.uint8),
                     [(w // 2, h // 2, text, {"size": size, "align": "center",
                                              "valign": "center"})])
    tile = np.rot90(tile)                       # counter-clockwise: reads bottom to top
    th, tw = tile.shape[:2]
    r0, c0 = int(round(cy - th / 2)), int(round(cx - tw / 2))
    rr0, cc0 = max(r0, 0), max(c0, 0)
    rr1, cc1 = min(r0 + th, img.shape[0]), min(c0 + tw, img.shape[1])
    if rr1 > rr0 and cc1 > cc0:
        sub = img[rr0:rr1, cc0:cc1].astype(np.float64)
        t = tile[rr0 - r0:rr1 - r0, cc0 - c0:cc1 - c0].astype(np.float64)
        # the box is translucent, the glyphs opaque
        ink = (t.min(axis=2, keepdims=True) < 200)
        img[rr0:rr1, cc0:cc1] = np.where(ink, t, np.round(sub * 0.2 + t * 0.8))
    return img


def label_planes(img, raster, size=13):
    """Write each plane's label at its centre on a translucent white box; labels of narrow
    upright tiles are turned to read upwards."""
    flat = []
    img = np.array(img, dtype=np.uint8, copy=True)
    for lab in raster.labels:
        x, y, t, w, h = lab["x"], lab["y"], lab["text"], lab["w"], lab["h"]
        tw = text_width(t, size)
        if tw > w - 4 and h > w and h >= 0.8 * tw:
            _rotated_text(img, x, y, t, size)
        else:
            if lab.get("anchor") is not None:
                x, y = lab["anchor"]
            flat.append((x, y, t, {"box": (255, 255, 255), "size": size,
                                   "align": "center", "valign": "center"}))
    return draw_text(img, flat)


def scale_bar(img, raster, x=12, y=None, colour=OUTLINE):
    """A metre scale bar in the bottom-left corner (in place), returns the new image."""
    mpp = raster.metres_per_pixel
    length = _nice_step(80 * mpp, 1)
    px = int(round(length / mpp))
    h = img.shape[0]
    y = h - 8 if y is None else y
    if px < 4 or px + x >= img.shape[1]:
        return img
    img[y - 1:y + 1, x:x + px] = colour
    img[y - 5:y + 1, x:x + 1] = colour
    img[y - 5:y + 1, x + px - 1:x + px] = colour
    return draw_text(img, [(x + px + 5, y, f"{_fmt_tick(length)} m", {"size": 11})])


def plan_axes(img, raster, margin_px=PLAN_MARGIN):
    """Metre ticks along the bottom and left of a plan image (x right, y up)."""
    mpp = raster.metres_per_pixel
    h, w, _ = img.shape
    ml, mt, mr, mb = margin_px
    xa, xb = raster.x0 + ml * mpp, raster.x0 + (w - mr) * mpp
    yb, ya = raster.y1 - (h - mb) * mpp, raster.y1 - mt * mpp
    step = _nice_step(max(xb - xa, ya - yb), 6)
    texts = []
    base = h - mb + 4
    img[base, ml:w - mr] = OUTLINE
    for xv in np.arange(math.ceil(xa / step - 1e-9) * step, xb + 1e-9, step):
        c = int(round((xv - raster.x0) / mpp))
        if 0 <= c < w:
            img[base:base + 5, c] = OUTLINE
            texts.append((c, base + 18, _fmt_tick(round(xv, 6)),
                          {"align": "center", "size": 11}))
    left = ml - 5
    img[mt:h - mb, left] = OUTLINE
    for yv in np.arange(math.ceil(yb / step - 1e-9) * step, ya + 1e-9, step):
        rr = int(round((raster.y1 - yv) / mpp))
        if 0 <= rr < h:
            img[rr, left - 5:left] = OUTLINE
            texts.append((left - 8, rr + 4, _fmt_tick(round(yv, 6)),
                          {"align": "right", "size": 11}))
    texts.append((ml + (w - ml - mr) // 2, h - 4, "x (m)", {"align": "center", "size": 11}))
    texts.append((left, mt - 9, "y (m)", {"size": 11, "align": "center"}))
    return draw_text(img, texts)


def _wrap(text, width, size):
    lines, line = [], ""
    for word in str(text).split(" "):
        trial = f"{line} {word}".strip()
        if line and text_width(trial, size) > width:
            lines.append(line)
            line = word
        else:
            line = trial
    if line:
        lines.append(line)
    return lines


def compose(title, parts, subtitle=None, pad=10):
    """Stack a title line, images (each centred) and an optional subtitle (wrapped)."""
    width = max(p.shape[1] for p in parts) + 2 * pad
    rows = [np.full((30, width, 3), BACKGROUND, np.uint8)]
    for p in parts:
        row = np.full((p.shape[0] + 6, width, 3), BACKGROUND, np.uint8)
        left = (width - p.shape[1]) // 2
        row[3:3 + p.shape[0], left:left + p.shape[1]] = p
        rows.append(row)
    img = np.concatenate(rows, axis=0)
    texts = [(pad, 21, title, {"size": 15})]
    if subtitle:
        lines = _wrap(subtitle, width - 2 * pad, 11)
        y = img.shape[0] + 12
        img = np.concatenate([img, np.full((15 * len(lines) + 6, width, 3), BACKGROUND,
                                           np.uint8)], axis=0)
        for k, line in enumerate(lines):
            texts.append((pad, y + 15 * k, line, {"size": 11, "colour": (90, 90, 90)}))
    return draw_text(img, texts)


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
            raise OSError(f"cannot write {path}: {oiio.geterror()}")
        try:
            if not out.open(tmp, spec):
                raise OSError(f"cannot write {path}: {out.geterror()}")
            if not out.write_image(pixels):
                raise OSError(f"cannot write {path}: {out.geterror()}")
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
