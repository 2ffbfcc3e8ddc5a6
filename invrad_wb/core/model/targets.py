"""Lighting targets -> target illuminance (lux) per vertex of a room mesh.

An architect does not type lux per vertex: she says "500 lx on this desk face", "a bright
spot here", "keep this wall dark", "this image on that wall", "300 lx on the work plane".
This module turns such *target specifications* into the per-vertex ``vertex_lux`` of a
:class:`~invrad_wb.core.model.scene.Scene`. It knows nothing of FreeCAD: surfaces are plain
integer ids (the workbench uses FreeCAD's face index), positions are metres.

The room mesh
-------------
``vertices (n, 3)`` metres, ``triangles (m, 3)`` (counter-clockwise seen from the room) and
``triangle_surface (m,) int``: the surface (face of the room's boundary) each triangle
belongs to. A vertex must belong to a single surface, so that a target on the floor does
not leak up the walls through shared corner vertices; :func:`split_surfaces` makes it so.

Targets (all lux values finite and >= 0; NaN means "no target")
---------------------------------------------------------------
:class:`UniformTarget`   ``lux`` on whole surfaces.
:class:`TextureTarget`   an illuminance image on one surface: ``pixel * lux_scale``. The
    image covers the surface's bounding rectangle in its plane as seen from inside the
    room: image x runs along ``u`` and image row 0 is at the top (largest ``v``), with
    ``(u, v) = plane_basis(inward normal)``, i.e. on a wall x runs to the right and rows
    run downwards as you face the wall; on a floor x runs along +X and up along +Y
    (a plan view); on a ceiling x runs along +X and up along -Y. Pixels are read with
    OpenImageIO as floats (8-bit images give 0..1); colour images use their luminance
    (Rec. 709 weights); pixels whose alpha is below 0.5 and NaN pixels are "no target".
:class:`SpotTarget`      a painted spot: ``peak_lux * w(d / radius)`` within ``radius_m`` of
    ``centre`` (3-D distance, on the spot's surface or the listed ``surfaces``), nothing
    outside it. Falloff ``w``:

    * ``"cosine"`` (default): ``w(x) = (1 + cos(pi x)) / 2``, smooth, 1 at the centre,
      0.5 at half the radius, 0 (with zero slope) at the rim;
    * ``"gaussian"``: ``w(x) = exp(-(3 x)^2 / 2)``, a gaussian with sigma = radius / 3,
      cut at the radius (where it has fallen to 1.1 %);
    * ``"flat"``: ``w = 1`` inside the radius (a disk).
:class:`ShadeTarget`     0 lx ("must stay dark") on whole surfaces, or on a disk
    (``centre``, ``radius_m``) of them.
:class:`WorkPlaneTarget` the room's required illuminance on a horizontal virtual receiver
    plane ``height_m`` above the floor (0.75 m by default, the usual desk height), without a
    border zone ``margin_m`` along the walls. See :func:`work_plane`.

Combination rule (:func:`evaluate`): start from "no target" everywhere; apply uniform and
texture targets in the given order (a later one replaces an earlier one where it has a
value); then spots add to it taking the maximum (a spot on a 100 lx uniform surface rises
from 100 lx to its peak; a spot alone fades to 0 lx at its rim); shades come last and win.
"""
from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

from invrad_wb.errors import SceneError
from invrad_wb.core.model.scene import plane_basis, winding_number

FALLOFFS = ("cosine", "gaussian", "flat")



# --------------------------------------------------------------------------- specs
@dataclass
class UniformTarget:
    """``lux`` on every vertex of the given surfaces."""
    surfaces: Sequence[int]
    lux: float
    name: str = "uniform target"


@dataclass
class SpotTarget:
    """A painted spot: ``peak_lux * w(d / radius_m)`` within ``radius_m`` of ``centre``.

    ``centre`` is in metres (on ``surface``); ``surfaces`` (default: ``[surface]``) are the
    surfaces the spot may fall on, e.g. a floor and the wall it meets.
    """
    surface: int
    centre: Sequence[float]
    radius_m: float
    peak_lux: float
    falloff: str = "cosine"
    surfaces: Optional[Sequence[int]] = None
    name: str = "spot target"


@dataclass
class TextureTarget:
    """An illuminance image on one surface: lux = pixel value * ``lux_scale``.

    ``image`` is a path read with OpenImageIO or a ``(h, w)`` array (NaN = no target).
    """
    surface: int
    image: object
    lux_scale: float = 1.0
    name: str = "texture target"


@dataclass
class ShadeTarget:
    """0 lx on whole ``surfaces``, or only within ``radius_m`` of ``centre`` (metres)."""
    surfaces: Sequence[int]
    centre: Optional[Sequence[float]] = None
    radius_m: Optional[float] = None
    name: str = "shade target"


@dataclass
class WorkPlaneTarget:
    """The required illuminance ``lux`` on a work plane ``height_m`` above the floor."""
    lux: float
    height_m: float = 0.75
    margin_m: float = 0.0
    name: str = "work plane"


# --------------------------------------------------------------------------- checks
def check_lux(value, what, source=None):
    """A target illuminance: finite and >= 0. Returns it as float or raises SceneError."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise SceneError(f"{what} is {value!r}: illuminance must be a number of lux", source)
    if not np.isfinite(x):
        raise SceneError(f"{what} is {x} lx: illuminance must be a finite number"
                         " (0 = must stay dark)", source)
    if x < 0:
        raise SceneError(f"{what} is {x} lx: illuminance cannot be negative"
                         " (0 = must stay dark)", source)
    return x


def _check_length(value, what, source, allow_zero=False):
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise SceneError(f"{what} is {value!r}: must be a length in metres", source)
    if not np.isfinite(x) or x < 0 or (x == 0 and not allow_zero):
        raise SceneError(f"{what} is {value!r} m: must be a finite length"
                         f" {'>=' if allow_zero else '>'} 0", source)
    return x


def _point(value, what, source):
    try:
        p = np.asarray(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        p = np.zeros(0)
    if p.shape != (3,) or not np.all(np.isfinite(p)):
        raise SceneError(f"{what} must be three finite coordinates in metres, got {value!r}",
                         source)
    return p


def _default_label(i):
    return f"surface {i}"


# --------------------------------------------------------------------------- mesh helpers
def vertex_surfaces(triangles, triangle_surface, n_vertices, source=None, label=_default_label):
    """(n,) surface id of each vertex (-1 if unused); refuses vertices shared by surfaces."""
    tri = np.asarray(triangles, dtype=np.int64)
    ts = np.asarray(triangle_surface, dtype=np.int64)
    vs = np.full(n_vertices, -1, dtype=np.int64)
    corners = tri.reshape(-1)
    surf = np.repeat(ts, 3)
    vs[corners] = surf
    clash = vs[corners] != surf
    if clash.any():
        i = int(np.flatnonzero(clash)[0])
        raise SceneError(f"vertex {int(corners[i])} is shared by {label(int(surf[i]))} and"
                         f" {label(int(vs[corners[i]]))}; split the mesh per surface first"
                         " (targets.split_surfaces)", source)
    return vs


def split_surfaces(vertices, triangles, triangle_surface):
    """Duplicate vertices shared by several surfaces.

    Returns
    -------
    vertices : (n', 3) float64
    triangles : (m, 3) int64
    vertex_source : (n',) int64, index of each new vertex in the input ``vertices``
    """
    tri = np.asarray(triangles, dtype=np.int64)
    ts = np.repeat(np.asarray(triangle_surface, dtype=np.int64), 3)
    pairs = np.stack([tri.reshape(-1), ts], axis=1)
    upairs, inv = np.unique(pairs, axis=0, return_inverse=True)
    src = upairs[:, 0]
    return (np.asarray(vertices, dtype=np.float64)[src], inv.reshape(-1, 3).astype(np.int64),
            src)


@dataclass
class SurfaceFrame:
    """Plane frame of one surface: inward normal, in-plane basis and bounding rectangle."""
    normal: np.ndarray
    u: np.ndarray
    v: np.ndarray
    lo: np.ndarray        # (2,) min (u, v) of the surface's vertices, metres
    hi: np.ndarray        # (2,) max (u, v)
    area: float


def surface_frames(vertices, triangles, triangle_surface):
    """``{surface id: SurfaceFrame}`` from the surfaces' triangles (area-weighted normal)."""
    v = np.asarray(vertices, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.int64)
    ts = np.asarray(triangle_surface, dtype=np.int64)
    p = v[tri]
    cross = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    frames = {}
    for s in np.unique(ts):
        sel = ts == s
        n = cross[sel].sum(0)
        norm = np.linalg.norm(n)
        if norm == 0:
            continue
        n = n / norm
        u, w = plane_basis(n)
        pts = p[sel].reshape(-1, 3)
        uv = np.stack([pts @ u, pts @ w], axis=1)
        frames[int(s)] = SurfaceFrame(n, u, w, uv.min(0), uv.max(0),
                                      0.5 * float(np.linalg.norm(cross[sel], axis=1).sum()))
    return frames


def falloff_weight(x, falloff="cosine"):
    """Spot weight at relative distance ``x = d / radius`` (array), 0 outside ``x > 1``."""
    x = np.asarray(x, dtype=np.float64)
    inside = x <= 1.0
    if falloff == "cosine":
        w = 0.5 * (1.0 + np.cos(np.pi * np.clip(x, 0.0, 1.0)))
    elif falloff == "gaussian":
        w = np.exp(-0.5 * (3.0 * x) ** 2)
    elif falloff == "flat":
        w = np.ones_like(x)
    else:
        raise SceneError(f"unknown spot falloff {falloff!r}: use one of {', '.join(FALLOFFS)}")
    return np.where(inside, w, 0.0)


# --------------------------------------------------------------------------- images
def load_lux_image(path, source=None):
    """Read an illuminance image with OpenImageIO.

    Returns
    -------
    (h, w) float64: the first channel of a grey image or the Rec. 709 luminance of a colour
    one (as floats: 8-bit images give 0..1); NaN where alpha < 0.5. Row 0 is the top row.
    """
    from invrad_wb.core.model.oiio import read_lux_image
    try:
        return read_lux_image(path).values
    except OSError as exc:
        raise SceneError(f"cannot read illuminance image {path}: {exc}", source)


def sample_image_clamped(image, st):
    """Bilinear lookup of a (h, w) image at (k, 2) coordinates in [0, 1]^2 (clamped).

    ``s`` runs along image x, ``t`` from the bottom row (0) to the top row (1). NaN pixels
    are left out of the interpolation; a point whose four pixels are all NaN gets NaN.
    """
    h, w = image.shape
    x = np.clip(st[:, 0], 0.0, 1.0) * w - 0.5
    y = (1.0 - np.clip(st[:, 1], 0.0, 1.0)) * h - 0.5
    x0 = np.floor(x).astype(np.int64)
    y0 = np.floor(y).astype(np.int64)
    fx, fy = x - x0, y - y0
    acc = np.zeros(len(st))
    wsum = np.zeros(len(st))
    for dx, dy, wt in ((0, 0, (1 - fx) * (1 - fy)), (1, 0, fx * (1 - fy)),
                       (0, 1, (1 - fx) * fy), (1, 1, fx * fy)):
        val = image[np.clip(y0 + dy, 0, h - 1), np.clip(x0 + dx, 0, w - 1)]
        ok = np.isfinite(val)
        acc += np.where(ok, val, 0.0) * wt
        wsum += np.where(ok, wt, 0.0)
    out = np.full(len(st), np.nan)
    good = wsum > 1e-12
    out[good] = acc[good] / wsum[good]
    return out


def texture_coordinates(points, frame):
    """(k, 2) image coordinates in [0, 1]^2 of points on a surface (see the module doc)."""
    uv = np.stack([points @ frame.u, points @ frame.v], axis=1)
    ext = np.maximum(frame.hi - frame.lo, 1e-12)
    return (uv - frame.lo) / ext


# --------------------------------------------------------------------------- evaluation
def evaluate(vertices, triangles, triangle_surface, targets, source=None,
             label=_default_label, base_dir=None):
    """Target illuminance per vertex of a room mesh.

    Parameters
    ----------
    vertices : (n, 3) float64, metres
    triangles : (m, 3) int
    triangle_surface : (m,) int
        Surface id of each triangle; vertices must not be shared by surfaces.
    targets : list of UniformTarget, SpotTarget, TextureTarget, ShadeTarget
        (:class:`WorkPlaneTarget` s are ignored here: see :func:`work_plane`.)
    source : str, optional
        Room name for error messages.
    label : callable, optional
        Surface id -> name used in error messages (e.g. ``lambda i: f"Face{i+1}"``).
    base_dir : str, optional
        Folder that relative image paths are relative to.

    Returns
    -------
    (n,) float64 lux; NaN where no target applies.

    Raises
    ------
    SceneError
        Naming the target (and surface) at fault: unknown surface, bad lux, bad radius,
        unreadable image.
    """
    room = _RoomSurfaces(vertices, triangles, triangle_surface, source, label)
    lux = np.full(len(room.vertices), np.nan)
    spots, shades = [], []
    for t in targets:
        if isinstance(t, WorkPlaneTarget):
            continue
        if isinstance(t, UniformTarget):
            value = check_lux(t.lux, f"{t.name}: lux", source)
            lux[room.select(t, t.surfaces)] = value
        elif isinstance(t, TextureTarget):
            _apply_texture(room, t, lux, base_dir)
        elif isinstance(t, SpotTarget):
            spots.append(t)
        elif isinstance(t, ShadeTarget):
            shades.append(t)
        else:
            raise SceneError(f"unknown target type {type(t).__name__}", source)
    # spots brighten what uniform and texture targets set; shades darken everything last
    for t in spots:
        _apply_spot(room, t, lux)
    for t in shades:
        _apply_shade(room, t, lux)
    return lux


class _RoomSurfaces:
    """A room mesh seen by :func:`evaluate`: surface ids per vertex and their frames."""

    def __init__(self, vertices, triangles, triangle_surface, source, label):
        self.vertices = np.asarray(vertices, dtype=np.float64)
        self.triangles = np.asarray(triangles, dtype=np.int64)
        self.triangle_surface = np.asarray(triangle_surface, dtype=np.int64)
        self.vertex_surface = vertex_surfaces(self.triangles, self.triangle_surface,
                                              len(self.vertices), source, label)
        self.known = set(np.unique(self.triangle_surface).tolist())
        self.source = source
        self.label = label
        self._frames = None

    def select(self, t, ids):
        """(n,) bool: the vertices on surfaces ``ids`` of target ``t`` (checked)."""
        out = []
        for s in ids:
            try:
                s = int(s)
            except (TypeError, ValueError):
                raise SceneError(f"{t.name}: surface {s!r} is not a surface id", self.source)
            if s not in self.known:
                have = sorted(self.known)
                raise SceneError(f"{t.name}: {self.label(s)} does not exist; the room has"
                                 f" {len(have)} surfaces ({self.label(have[0])} .."
                                 f" {self.label(have[-1])})", self.source)
            out.append(s)
        if not out:
            raise SceneError(f"{t.name}: no surfaces given", self.source)
        return np.isin(self.vertex_surface, out)

    def frame(self, surface):
        """The :class:`SurfaceFrame` of one surface (all frames computed once)."""
        if self._frames is None:
            self._frames = surface_frames(self.vertices, self.triangles,
                                          self.triangle_surface)
        return self._frames[int(surface)]


def _texture_image(t, base_dir, source):
    """The (h, w) float64 illuminance image of a TextureTarget (path or array), checked."""
    img = t.image
    if isinstance(img, (str, bytes)) or hasattr(img, "__fspath__"):
        import os
        path = os.fspath(img)
        if base_dir and not os.path.isabs(path):
            path = os.path.join(base_dir, path)
        if not os.path.isfile(path):
            raise SceneError(f"{t.name}: illuminance image {path} does not exist",
                             source)
        img = load_lux_image(path, source)
    img = np.asarray(img, dtype=np.float64)
    if img.ndim != 2 or min(img.shape) < 1:
        raise SceneError(f"{t.name}: illuminance image must be 2-D, has shape"
                         f" {img.shape}", source)
    fin = img[np.isfinite(img)]
    if np.isinf(img).any() or (fin < 0).any():
        raise SceneError(f"{t.name}: illuminance image has negative or infinite"
                         " pixels", source)
    return img


def _apply_texture(room, t, lux, base_dir):
    """Set ``lux`` (n,) on the texture's surface from its image (NaN pixels: no target)."""
    scale = check_lux(t.lux_scale, f"{t.name}: lux scale", room.source)
    sel = room.select(t, [t.surface])
    img = _texture_image(t, base_dir, room.source)
    idx = np.flatnonzero(sel)
    vals = sample_image_clamped(img, texture_coordinates(room.vertices[idx],
                                                         room.frame(t.surface)))
    vals *= scale
    ok = np.isfinite(vals)
    lux[idx[ok]] = vals[ok]


def _apply_spot(room, t, lux):
    """Raise ``lux`` (n,) to the spot's falloff within its radius (max with what is set)."""
    source = room.source
    peak = check_lux(t.peak_lux, f"{t.name}: peak lux", source)
    r = _check_length(t.radius_m, f"{t.name}: radius", source)
    c = _point(t.centre, f"{t.name}: centre", source)
    if t.falloff not in FALLOFFS:
        raise SceneError(f"{t.name}: unknown falloff {t.falloff!r}; use one of"
                         f" {', '.join(FALLOFFS)}", source)
    ids = [t.surface] if t.surfaces is None else list(t.surfaces)
    if t.surface not in ids:
        ids.append(t.surface)
    sel = np.flatnonzero(room.select(t, ids))
    d = np.linalg.norm(room.vertices[sel] - c, axis=1) / r
    inside = d <= 1.0
    val = peak * falloff_weight(d[inside], t.falloff)
    tgt = sel[inside]
    lux[tgt] = np.fmax(lux[tgt], val)


def _apply_shade(room, t, lux):
    """Set ``lux`` (n,) to 0 on the shade's surfaces, or within its disk."""
    source = room.source
    sel = room.select(t, t.surfaces)
    if t.centre is not None or t.radius_m is not None:
        if t.centre is None or t.radius_m is None:
            raise SceneError(f"{t.name}: a shaded disk needs both a centre and a radius",
                             source)
        r = _check_length(t.radius_m, f"{t.name}: radius", source)
        c = _point(t.centre, f"{t.name}: centre", source)
        sel &= np.linalg.norm(room.vertices - c, axis=1) <= r
    lux[sel] = 0.0


def boundary_edges(vertices, triangles, tol=1e-6):
    """(k, 2, 3) segments of the edges used by one triangle only (after welding by position)."""
    v = np.asarray(vertices, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.int64)
    if len(tri) == 0:
        return np.zeros((0, 2, 3))
    q = np.round(v / tol).astype(np.int64)
    _, weld = np.unique(q, axis=0, return_inverse=True)
    weld = weld.reshape(-1)
    f = weld[tri]
    a = f.reshape(-1)
    b = f[:, [1, 2, 0]].reshape(-1)
    key = np.stack([np.minimum(a, b), np.maximum(a, b)], axis=1)
    _, inv, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    once = counts[inv.reshape(-1)] == 1
    ia = tri.reshape(-1)[once]
    ib = tri[:, [1, 2, 0]].reshape(-1)[once]
    return np.stack([v[ia], v[ib]], axis=1)


def distance_to_segments(points, segments, chunk=256):
    """(k,) distance of each point to the nearest of (s, 2, 3) segments (inf if none)."""
    points = np.asarray(points, dtype=np.float64)
    out = np.full(len(points), np.inf)
    if len(segments) == 0:
        return out
    a, b = segments[:, 0], segments[:, 1]
    ab = b - a
    ll = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-30)
    for s in range(0, len(points), chunk):
        p = points[s:s + chunk, None, :]
        t = np.clip(np.einsum("kij,ij->ki", p - a, ab) / ll, 0.0, 1.0)
        d = np.linalg.norm(p - (a + t[..., None] * ab), axis=2)
        out[s:s + chunk] = d.min(axis=1)
    return out


#: free height needed above a work plane for it to be a work place (metres)
WORK_PLANE_HEADROOM_M = 0.6


def work_plane(vertices, triangles, floor, target, source=None, check_inside=True,
               surface=None):
    """Virtual work-plane triangles for a room: its floor lifted by ``target.height_m``.

    Parameters
    ----------
    vertices : (n, 3) float64, metres
    triangles : (m, 3) int
        The room's (closed) surface mesh, inward normals.
    floor : (m,) bool
        Which triangles are floor (face up, normal +Z).
    target : WorkPlaneTarget
    check_inside : bool
        Drop work-plane triangles that leave the room or have less than
        ``WORK_PLANE_HEADROOM_M`` of room above them (e.g. under a low sloped ceiling),
        tested with the generalised winding number of the room surface.
    surface : ((k, 3) float64, (j, 3) int), optional
        A coarser triangulation of the same closed room surface for that test (its cost
        grows with work-plane triangles times surface triangles); default: the mesh.

    Returns
    -------
    wp_vertices : (k, 3) float64, metres
    wp_triangles : (j, 3) int64, facing up (+Z)
    wp_lux : (k,) float64: ``target.lux``, NaN within ``margin_m`` of the floor's outline.

    Raises
    ------
    SceneError
        No floor, a height outside the room, bad lux/height/margin.
    """
    lux = check_lux(target.lux, f"{target.name}: lux", source)
    h = _check_length(target.height_m, f"{target.name}: height", source)
    margin = _check_length(target.margin_m, f"{target.name}: margin", source,
                           allow_zero=True)
    v = np.asarray(vertices, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.int64)
    floor = np.asarray(floor, dtype=bool).reshape(-1)
    if not floor.any():
        raise SceneError(f"{target.name}: the room has no floor (no upward-facing surface)"
                         " to put a work plane on", source)
    ftri = tri[floor]
    used, inv = np.unique(ftri.reshape(-1), return_inverse=True)
    fv = v[used]
    wtri = inv.reshape(-1, 3).astype(np.int64)
    p = fv[wtri]
    up = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])[:, 2] >= 0
    wtri[~up] = wtri[~up][:, [0, 2, 1]]
    wv = fv + np.array([0.0, 0.0, h])
    top = float(v[:, 2].max())
    if h >= top - float(fv[:, 2].min()):
        raise SceneError(f"{target.name}: height {h} m is not below the ceiling (the room"
                         f" is {top - float(fv[:, 2].min()):.2f} m high)", source)
    if check_inside:
        centroids = wv[wtri].mean(axis=1)
        sv, st = (v, tri) if surface is None else (np.asarray(surface[0], dtype=np.float64),
                                                  np.asarray(surface[1], dtype=np.int64))
        # a work place also needs head room above the desk: under a low sloped roof
        # the work plane stops where less than WORK_PLANE_HEADROOM_M is left above it
        w = winding_number(sv[st], np.concatenate(
            [centroids, centroids + [0.0, 0.0, WORK_PLANE_HEADROOM_M]]))
        keep = (np.abs(w[:len(centroids)]) > 0.5) & (np.abs(w[len(centroids):]) > 0.5)
        if not keep.any():
            raise SceneError(f"{target.name}: a work plane {h} m above the floor lies"
                             " outside the room", source)
        wtri = wtri[keep]
        wv, wtri = _compact(wv, wtri)
    wl = np.full(len(wv), lux)
    if margin > 0:
        d = distance_to_segments(wv - [0.0, 0.0, h], boundary_edges(fv, inv.reshape(-1, 3)))
        wl[d < margin] = np.nan
        if np.isnan(wl).all():
            raise SceneError(f"{target.name}: a margin of {margin} m leaves no work plane",
                             source)
    return wv, wtri, wl


def _compact(vertices, triangles):
    used, inv = np.unique(triangles.reshape(-1), return_inverse=True)
    return vertices[used], inv.reshape(-1, 3).astype(np.int64)


def require_targets(scene, source, lux=None, texture=None):
    """Refuse (:class:`SceneError`, one line naming the file) a scene without any target
    illuminance: every vertex NaN ("no target") and, with a texture, every pixel NaN or
    masked. Locating or verifying against no target would only print 0 luminaires.

    ``source`` is the scene file; ``lux``/``texture`` the sidecar or image that gave the
    targets (named instead, since that is the file to fix)."""
    t = scene.vertex_targets()
    if np.isfinite(t).any():
        return
    tex = getattr(scene, "lux_texture", None)
    if tex is not None and np.isfinite(np.asarray(tex, dtype=float)).any():
        return
    if texture:
        raise SceneError("every pixel of the illuminance texture is NaN or transparent (no"
                         " target anywhere): nothing to light", str(texture))
    if lux:
        raise SceneError(f"no value of the lux sidecar gives a target on {source} (all NaN"
                         " or unmatched): nothing to light", str(lux))
    raise SceneError(f"every target of its {len(t)} vertices is NaN (no target anywhere):"
                     " nothing to light; give target lux per vertex, a --lux sidecar or a"
                     " --texture", str(source))


def no_luminaire_reason(scene):
    """Why a result without luminaires is right, or None when the targets ask for light.

    A scene whose every target is 0 lx (shade) asks for darkness: no luminaire is the
    answer."""
    t = scene.vertex_targets()
    fin = np.isfinite(t)
    if fin.any() and not (t[fin] > 0).any():
        return f"every one of its {int(fin.sum())} targets is 0 lx (shade): no light is asked for"
    return None
