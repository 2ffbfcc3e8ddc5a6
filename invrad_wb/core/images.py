"""False-colour images of illuminance for people to look at, written with OpenImageIO.

* :func:`false_colour`: a perceptually ordered map (viridis, dark blue -> yellow) with a
  fixed, documented scale; NaN (no target) is grey.
* :func:`diverging`: deviation maps, blue = too dark, white = on target, red = too bright.
* :func:`unfold_room`: a room's planes rasterised "unfolded", each in its own (u, v)
  coordinates (u to the right, v up), packed into rows and numbered like the report's
  plane list; pixels off the faces are background.
* :func:`plan_view`: the room seen from above (work plane if it has one, else floor) with
  the luminaires drawn as rings.
* :func:`save_png`, :func:`save_exr`: atomic writes; one-channel images are written as
  ``(h, w, 1)`` (OpenImageIO writes garbage for a 2-D ``(h, w)`` array).
"""
import numpy as np

from .atomic import atomic_path
from .raster import locate_points, plane_triangles_2d

#: viridis, sampled at 9 evenly spaced points (matplotlib's values)
_VIRIDIS = np.array([[68, 1, 84], [71, 44, 122], [59, 81, 139], [44, 113, 142],
                     [33, 144, 141], [39, 173, 129], [92, 200, 99], [170, 220, 50],
                     [253, 231, 37]], dtype=np.float64)
_DIVERGING = np.array([[33, 102, 172], [103, 169, 207], [209, 229, 240], [247, 247, 247],
                       [253, 219, 199], [239, 138, 98], [178, 24, 43]], dtype=np.float64)
NAN_GREY = (150, 150, 150)
BACKGROUND = (255, 255, 255)


def _lut(stops, t):
    t = np.clip(t, 0.0, 1.0) * (len(stops) - 1)
    i = np.minimum(np.floor(t).astype(np.int64), len(stops) - 2)
    f = (t - i)[..., None]
    return stops[i] * (1 - f) + stops[i + 1] * f


def false_colour(values, vmin, vmax):
    """(…) float -> (…, 3) uint8 viridis; NaN -> grey. Linear scale vmin..vmax (lux)."""
    v = np.asarray(values, dtype=np.float64)
    t = (v - vmin) / max(vmax - vmin, 1e-12)
    rgb = _lut(_VIRIDIS, np.nan_to_num(t)).round().astype(np.uint8)
    rgb[~np.isfinite(v)] = NAN_GREY
    return rgb


def diverging(values, limit):
    """Signed deviation -> blue (-limit) / white (0) / red (+limit); NaN -> grey."""
    v = np.asarray(values, dtype=np.float64)
    t = 0.5 + 0.5 * v / max(limit, 1e-12)
    rgb = _lut(_DIVERGING, np.nan_to_num(t, nan=0.5)).round().astype(np.uint8)
    rgb[~np.isfinite(v)] = NAN_GREY
    return rgb


def colour_bar(kind="viridis", width=256, height=16):
    """A horizontal colour bar image (height, width, 3), low values on the left."""
    t = np.linspace(0, 1, width)
    row = (_lut(_VIRIDIS, t) if kind == "viridis" else _lut(_DIVERGING, t)).round()
    return np.repeat(row[None].astype(np.uint8), height, axis=0)


# ---------------------------------------------------------------------------- digits
_FONT = {  # 3 x 5 bitmap digits
    "0": "111101101101111", "1": "010110010010111", "2": "111001111100111",
    "3": "111001111001111", "4": "101101111001001", "5": "111100111001111",
    "6": "111100111101111", "7": "111001010010010", "8": "111101111101111",
    "9": "111101111001111"}


def draw_text(rgb, text, top, left, scale=2, colour=(0, 0, 0)):
    """Draw digits into an image (in place) with a tiny 3x5 bitmap font."""
    x = left
    for ch in str(text):
        bits = _FONT.get(ch)
        if bits is None:
            x += 4 * scale
            continue
        glyph = np.array([int(b) for b in bits], dtype=bool).reshape(5, 3)
        glyph = np.repeat(np.repeat(glyph, scale, axis=0), scale, axis=1)
        h, w = glyph.shape
        y0, y1 = max(top, 0), min(top + h, rgb.shape[0])
        x0, x1 = max(x, 0), min(x + w, rgb.shape[1])
        if y1 > y0 and x1 > x0:
            sub = glyph[y0 - top:y1 - top, x0 - x:x1 - x]
            rgb[y0:y1, x0:x1][sub] = colour
        x += 4 * scale
    return rgb


# ---------------------------------------------------------------------------- rasters
def plane_raster(scene, plane, vertex_values, pixel):
    """Values of one plane on a (rows, cols) grid: columns along u, rows along v (v up).

    Returns
    -------
    values : (rows, cols) float64, NaN where there is no target
    on_face : (rows, cols) bool
    """
    nu = max(1, int(np.ceil(plane.size[0] / pixel)))
    nv = max(1, int(np.ceil(plane.size[1] / pixel)))
    u = (np.arange(nu) + 0.5) * plane.size[0] / nu
    v = (np.arange(nv) + 0.5) * plane.size[1] / nv
    U, V = np.meshgrid(u, v[::-1])                  # row 0 is the top (largest v)
    pts = np.stack([U.reshape(-1), V.reshape(-1)], axis=1)
    tri, bary = locate_points(plane_triangles_2d(scene, plane), pts)
    vals = np.full(len(pts), np.nan)
    ok = tri >= 0
    faces = scene.faces[plane.faces[tri[ok]]]
    vals[ok] = np.einsum("kj,kj->k", bary[ok], vertex_values[faces])
    return vals.reshape(nv, nu), ok.reshape(nv, nu)


def unfold_room(scene, room_planes, vertex_values, colour_fn, pixel=None, max_width=900,
                gap=6, label=True):
    """All planes of a room side by side, numbered by their position in ``room_planes``.

    Parameters
    ----------
    room_planes : list of Plane
    vertex_values : (n,) float64 per scene vertex
    colour_fn : callable(values (h, w)) -> (h, w, 3) uint8
    pixel : float, metres per pixel (default: the largest plane about 240 px wide)

    Returns
    -------
    (h, w, 3) uint8 image and the list of (plane index, top, left, rows, cols) tiles
    """
    if pixel is None:
        big = max(max(p.size) for p in room_planes)
        pixel = max(big / 240.0, 0.01)
    tiles = []
    for k, p in enumerate(room_planes):
        vals, on = plane_raster(scene, p, vertex_values, pixel)
        rgb = colour_fn(vals)
        rgb[~on] = (235, 235, 235)
        if label:
            n = len(str(k + 1))
            rgb[:14, :8 * n + 5] = (255, 255, 255)
            draw_text(rgb, k + 1, 2, 3, scale=2, colour=(0, 0, 0))
        tiles.append(rgb)
    # shelf packing, tallest first
    order = sorted(range(len(tiles)), key=lambda i: -tiles[i].shape[0])
    rows, row, width, placed = [], [], 0, {}
    for i in order:
        t = tiles[i]
        if row and width + t.shape[1] + gap > max_width:
            rows.append(row)
            row, width = [], 0
        row.append(i)
        width += t.shape[1] + gap
    if row:
        rows.append(row)
    W = max(sum(tiles[i].shape[1] + gap for i in r) for r in rows) + gap
    H = sum(max(tiles[i].shape[0] for i in r) + gap for r in rows) + gap
    img = np.full((H, W, 3), BACKGROUND, np.uint8)
    top = gap
    layout = []
    for r in rows:
        left = gap
        h = max(tiles[i].shape[0] for i in r)
        for i in r:
            t = tiles[i]
            img[top:top + t.shape[0], left:left + t.shape[1]] = t
            layout.append((room_planes[i].index, top, left, t.shape[0], t.shape[1]))
            left += t.shape[1] + gap
        top += h + gap
    return img, layout


def _ring(img, cx, cy, r, colour, width=1.5):
    h, w, _ = img.shape
    y, x = np.ogrid[:h, :w]
    d = np.sqrt((x - cx) ** 2 + (y - cy) ** 2)
    img[np.abs(d - r) <= width] = colour


def plan_view(scene, faces, vertex_values, colour_fn, luminaires=(), pixel=None, size=420):
    """Top view (x right, y up) of the given horizontal faces with luminaires as rings.

    Returns (h, w, 3) uint8 and (x0, y0, pixel) of the image's lower-left corner.
    """
    tri = scene.vertices[scene.faces[faces]]
    lo = tri.reshape(-1, 3).min(0)
    hi = tri.reshape(-1, 3).max(0)
    span = float(max(hi[0] - lo[0], hi[1] - lo[1], 1e-6))
    if pixel is None:
        pixel = span / size
    margin = 12
    nx = int(np.ceil((hi[0] - lo[0]) / pixel)) + 2 * margin
    ny = int(np.ceil((hi[1] - lo[1]) / pixel)) + 2 * margin
    x0, y0 = lo[0] - margin * pixel, lo[1] - margin * pixel
    xs = x0 + (np.arange(nx) + 0.5) * pixel
    ys = y0 + (np.arange(ny)[::-1] + 0.5) * pixel
    X, Y = np.meshgrid(xs, ys)
    pts = np.stack([X.reshape(-1), Y.reshape(-1)], axis=1)
    t, bary = locate_points(tri[:, :, :2], pts)
    vals = np.full(len(pts), np.nan)
    ok = t >= 0
    vals[ok] = np.einsum("kj,kj->k", bary[ok], vertex_values[scene.faces[faces[t[ok]]]])
    img = colour_fn(vals.reshape(ny, nx))
    img[~ok.reshape(ny, nx)] = BACKGROUND
    for k, lum in enumerate(luminaires):
        cx = (lum.position[0] - x0) / pixel - 0.5
        cy = (ny - 1) - ((lum.position[1] - y0) / pixel - 0.5)
        _ring(img, cx, cy, 7, (0, 0, 0), 2.2)
        _ring(img, cx, cy, 7, (255, 255, 255), 1.0)
        n = len(str(k + 1))
        top, left = int(cy) - 6, int(cx) + 11
        img[max(top - 1, 0):max(top + 12, 0), max(left - 2, 0):max(left + 8 * n + 1, 0)] = \
            (255, 255, 255)
        draw_text(img, k + 1, top, left, scale=2, colour=(0, 0, 0))
    return img, (x0, y0, pixel)


# ---------------------------------------------------------------------------- files
def _write(path, pixels, fmt):
    import OpenImageIO as oiio
    pixels = np.ascontiguousarray(pixels)
    if pixels.ndim == 2:
        pixels = pixels[:, :, None]
    h, w, c = pixels.shape
    with atomic_path(path) as tmp:
        out = oiio.ImageOutput.create(tmp)
        if out is None:
            raise OSError(f"cannot write {path}: {oiio.geterror()}")
        try:
            if not out.open(tmp, oiio.ImageSpec(w, h, c, fmt)):
                raise OSError(f"cannot write {path}: {out.geterror()}")
            if not out.write_image(pixels):
                raise OSError(f"cannot write {path}: {out.geterror()}")
        finally:
            out.close()
    return path


def save_png(path, image):
    """Write an (h, w) or (h, w, 3) uint8 image as PNG, atomically."""
    import OpenImageIO as oiio
    return _write(path, np.asarray(image, dtype=np.uint8), oiio.UINT8)


def save_exr(path, values):
    """Write an (h, w) or (h, w, c) float array as EXR (float32), atomically."""
    import OpenImageIO as oiio
    return _write(path, np.asarray(values, dtype=np.float32), oiio.FLOAT)
