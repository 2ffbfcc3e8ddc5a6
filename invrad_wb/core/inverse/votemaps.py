"""Vote maps: one raster per plane a luminaire may sit on, plus the dummy planes.

Each map is a grid of candidate luminaire positions at ``pixel`` metres on a plane:

* a *surface* map for every real plane of a room (the luminaire is mounted on it and faces
  along the plane's normal); pixels off the plane's faces are masked out;
* *dummy* maps (thesis 3.2.5): horizontal layers from the ceiling down, for luminaires in
  mid-air (pendants). One-sided layers (the thesis) hold downward-facing luminaires;
  two-sided layers (its future work) add an upward-facing map at the same height. Pixels
  outside the room's footprint or too close to the ceiling/floor are masked out.

All maps live in one flat float32 buffer (``offsets``) so that a kernel can write any of them.
"""
from dataclasses import dataclass, field

import numpy as np

from invrad_wb.errors import SettingsError
from invrad_wb.core.geometry.raster import locate_points, plane_triangles_2d
from invrad_wb.core.model.scene import plane_basis


@dataclass
class VoteMap:
    """One candidate-position raster.

    Attributes
    ----------
    kind : {'surface', 'dummy'}
    plane : int
        Scene plane index (surface maps) or -1.
    layer : int
        Dummy layer index (dummy maps) or -1.
    room : int
    normal : (3,) float64
        Facing direction of a luminaire on this map (surface maps: the plane's normal).
    offset : float
        The map's plane: ``normal . x + offset = 0``; points in front have positive
        ``normal . x + offset`` (metres).
    origin, u, v : (3,) float64
        Pixel (i, j) has its centre at ``origin + (i + 0.5) * pixel * u + (j + 0.5) * pixel * v``.
    shape : (nu, nv)
    pixel : float, metres
    mask : (nu, nv) bool
        Pixels where a luminaire may be placed.
    start : int
        Offset of this map in the flat buffer (row-major over (i, j); rows padded to
        ``stride`` pixels).
    stride : int
        Padded row length (multiple of 16) of the flat buffer layout, rows along j.
    """

    kind: str
    plane: int
    layer: int
    room: int
    normal: np.ndarray
    offset: float
    origin: np.ndarray
    u: np.ndarray
    v: np.ndarray
    shape: tuple
    pixel: float
    mask: np.ndarray
    start: int = 0
    stride: int = 0
    height: float = float("nan")
    face_test: object = None

    @property
    def name(self):
        if self.kind == "surface":
            return f"plane{self.plane:03d}"
        side = "down" if self.normal[2] < 0 else "up"
        return f"dummy{self.layer:02d}_{side}_z{self.height:.2f}m"

    def pixel_centres(self):
        """(nu, nv, 3) float64 world positions of the pixel centres."""
        nu, nv = self.shape
        i = (np.arange(nu) + 0.5) * self.pixel
        j = (np.arange(nv) + 0.5) * self.pixel
        return (self.origin + i[:, None, None] * self.u + j[None, :, None] * self.v)

    def to_world(self, ij):
        """Continuous pixel coordinates (k, 2) (pixel centres at +0.5) -> (k, 3) positions."""
        ij = np.asarray(ij, dtype=np.float64)
        return (self.origin + ij[:, :1] * self.pixel * self.u
                + ij[:, 1:2] * self.pixel * self.v)


def _align(n, m=16):
    return ((n + m - 1) // m) * m


class FaceTest:
    """Exact "is this 2-D point on the faces?" for points near the mask's border.

    The pixel masks say whether a pixel's centre is on a face; a pixel at the border is
    partly off the faces, so a point there is checked against the triangles themselves
    (those whose bounding box holds it).
    """

    def __init__(self, tri2d, mask, origin2d, pixel):
        self.tri = np.asarray(tri2d, dtype=np.float64)
        self.lo = self.tri.min(axis=1)
        self.hi = self.tri.max(axis=1)
        m = np.pad(mask, 1)
        inner = m[1:-1, 1:-1].copy()
        for di in (-1, 0, 1):
            for dj in (-1, 0, 1):
                inner &= m[1 + di:m.shape[0] - 1 + di, 1 + dj:m.shape[1] - 1 + dj]
        self.inner = inner
        self.origin = np.asarray(origin2d, dtype=np.float64)
        self.pixel = pixel

    def contains(self, q, i, j, tol=1e-9):
        """q (2,) in the same 2-D frame as the triangles; (i, j) its pixel.

        The triangles whose bounding box (grown by ``tol``) holds q are those listed in q's
        cell of :meth:`_cells` that pass the box test: the same ones, in the same order, as
        the box test of every triangle (the office example's floor has 4,800 triangles and
        the mid-air clamp asks this of every trial position off the footprint's inner
        pixels)."""
        if self.inner[i, j]:
            return True
        g0, cell, shape, starts, tris = self._cells(tol)
        c = np.floor((q - g0) / cell)
        c = np.where(np.isfinite(c), c, 0.0)
        cid = (min(max(int(c[0]), 0), shape[0] - 1) * shape[1]
               + min(max(int(c[1]), 0), shape[1] - 1))
        cand = tris[starts[cid]:starts[cid + 1]]
        sel = cand[np.all((self.lo[cand] <= q + tol) & (self.hi[cand] >= q - tol), axis=1)]
        if len(sel) == 0:
            return False
        from invrad_wb.core.geometry.raster import barycentric_2d
        b = barycentric_2d(self.tri[sel], np.broadcast_to(q, (len(sel), 2)))
        return bool(np.any(np.all(b >= -tol, axis=1)))

    def contains_all(self, q, i, j, tol=1e-9):
        """(n,) bool: :meth:`contains` of points q (n, 2) with pixels (i, j) (n,) each,
        with the same arithmetic, all at once."""
        out = self.inner[i, j].copy()
        rest = np.flatnonzero(~out)
        if len(rest) == 0:
            return out
        qr = q[rest]
        pi, ti = self._box_pairs(qr, tol)
        if len(pi):
            from invrad_wb.core.geometry.raster import barycentric_2d
            b = barycentric_2d(self.tri[ti], qr[pi])
            out[rest[pi[np.all(b >= -tol, axis=1)]]] = True
        return out

    def _box_pairs(self, qr, tol):
        """(point, triangle) index pairs where point qr (n, 2) lies in the triangle's
        bounding box grown by ``tol``: the same pairs, in the same order, as the test of
        every point against every triangle, but only against the triangles listed in the
        point's cell of a uniform grid (:meth:`_cells`); with thousands of triangles per
        plane that test was most of a mount-clearance check."""
        g0, cell, shape, starts, tris = self._cells(tol)
        c = np.floor((qr - g0) / cell)
        c = np.where(np.isfinite(c), c, 0.0)
        ci = np.clip(c[:, 0], 0, shape[0] - 1).astype(np.int64)
        cj = np.clip(c[:, 1], 0, shape[1] - 1).astype(np.int64)
        cid = ci * shape[1] + cj
        a, n = starts[cid], starts[cid + 1] - starts[cid]
        pi = np.repeat(np.arange(len(qr)), n)
        ti = tris[np.repeat(a, n) + (np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n))]
        near = np.all((self.lo[ti] <= qr[pi] + tol) & (self.hi[ti] >= qr[pi] - tol), axis=1)
        return pi[near], ti[near]

    def _cells(self, tol):
        """A uniform grid over the triangles' bounding boxes grown by ``tol`` and a margin
        (for rounding): ``(origin (2,), cell size, (rows, cols), starts, triangles)``, cell
        ``c`` listing ``triangles[starts[c]:starts[c + 1]]`` (ascending); built once."""
        got = getattr(self, "_grid", None)
        if got is not None and got[0] == tol:
            return got[1]
        margin = tol + 1e-9 * (1.0 + float(np.max(np.abs(self.tri)))) if len(self.tri) \
            else 1.0
        lo, hi = self.lo - margin, self.hi + margin
        if len(self.tri) == 0:
            lo, hi = np.zeros((1, 2)), np.ones((1, 2))
        g0 = lo.min(axis=0)
        cell = max(float(np.max(hi.max(axis=0) - g0)) / 64.0, 1e-9)
        c0 = np.floor((lo - g0) / cell).astype(np.int64)
        c1 = np.floor((hi - g0) / cell).astype(np.int64)
        shape = (int(c1[:, 0].max()) + 1, int(c1[:, 1].max()) + 1)
        ni, nj = c1[:, 0] - c0[:, 0] + 1, c1[:, 1] - c0[:, 1] + 1
        cnt = ni * nj if len(self.tri) else np.zeros(1, np.int64)
        tid = np.repeat(np.arange(len(cnt)), cnt)
        k = np.arange(len(tid)) - np.repeat(np.cumsum(cnt) - cnt, cnt)
        cid = (c0[tid, 0] + k // nj[tid]) * shape[1] + c0[tid, 1] + k % nj[tid]
        order = np.argsort(cid, kind="stable")
        starts = np.zeros(shape[0] * shape[1] + 1, dtype=np.int64)
        np.cumsum(np.bincount(cid, minlength=shape[0] * shape[1]), out=starts[1:])
        grid = (g0, cell, shape, starts, tid[order])
        self._grid = (tol, grid)
        return grid


@dataclass
class DummyGrid:
    """The room's footprint raster used for dummy planes and to keep luminaires inside.

    ``footprint[i, j]``: the vertical line through pixel (i, j) meets a floor-like face;
    ``ceiling_z[i, j]``: height of the ceiling-like face above it (-inf if none).
    """

    origin: np.ndarray
    pixel: float
    footprint: np.ndarray
    ceiling_z: np.ndarray
    floor_z: float
    floor_test: object = None     # FaceTest of the floor-like faces in (x, y)

    def clamp(self, p, margin=1e-3):
        """The point with its height clamped into the room, or None outside the footprint."""
        i = int(np.floor((p[0] - self.origin[0]) / self.pixel))
        j = int(np.floor((p[1] - self.origin[1]) / self.pixel))
        if not (0 <= i < self.footprint.shape[0] and 0 <= j < self.footprint.shape[1]):
            return None
        if not self.footprint[i, j] or self.ceiling_z[i, j] - margin <= self.floor_z + margin:
            return None
        if self.floor_test is not None and not self.floor_test.contains(
                np.asarray(p[:2], dtype=np.float64), i, j):
            return None
        z = min(max(p[2], self.floor_z + margin), self.ceiling_z[i, j] - margin)
        if z == p[2]:
            return p
        return np.array([p[0], p[1], z])

    def contains(self, p, margin=1e-3):
        """Whether the point (3,) lies inside the room (below its ceiling, above its floor)."""
        i = int(np.floor((p[0] - self.origin[0]) / self.pixel))
        j = int(np.floor((p[1] - self.origin[1]) / self.pixel))
        if not (0 <= i < self.footprint.shape[0] and 0 <= j < self.footprint.shape[1]):
            return False
        return bool(self.footprint[i, j] and self.floor_z + margin < p[2]
                    < self.ceiling_z[i, j] - margin)


@dataclass
class VoteCanvas:
    """All vote maps of one room and their flat layout.

    Attributes
    ----------
    maps : list of VoteMap
    size : int
        Length of the flat buffer (pixels, padded).
    """

    maps: list
    size: int
    pixel: float
    room: int
    dummy_heights: np.ndarray = field(default_factory=lambda: np.zeros(0))
    grid: DummyGrid = None

    def map_contains(self, map_index, p):
        """Whether point p (3,) lies on the faces of a surface map (on a valid pixel and,
        near the faces' border, inside a face)."""
        m = self.maps[map_index]
        d = np.asarray(p) - m.origin
        q = np.array([d @ m.u, d @ m.v])
        i = int(np.floor(q[0] / m.pixel))
        j = int(np.floor(q[1] / m.pixel))
        if not (0 <= i < m.shape[0] and 0 <= j < m.shape[1] and m.mask[i, j]):
            return False
        return m.face_test is None or m.face_test.contains(q, i, j)

    def map_contains_all(self, map_index, points):
        """(n,) bool: :meth:`map_contains` of each point (n, 3) at once (a luminaire's
        probes around it: one call instead of five, which were a sixth of a refinement's
        time)."""
        m = self.maps[map_index]
        d = np.asarray(points, dtype=np.float64).reshape(-1, 3) - m.origin
        # one dot per point, as map_contains takes it (a matrix product rounds otherwise)
        q = np.array([[r @ m.u, r @ m.v] for r in d]).reshape(-1, 2)
        ij = np.floor(q / m.pixel)
        ok = ((ij[:, 0] >= 0) & (ij[:, 0] < m.shape[0])
              & (ij[:, 1] >= 0) & (ij[:, 1] < m.shape[1]))
        i, j = ij[:, 0].astype(np.int64), ij[:, 1].astype(np.int64)
        ok[ok] = m.mask[i[ok], j[ok]]
        if m.face_test is not None and ok.any():
            ok[ok] = m.face_test.contains_all(q[ok], i[ok], j[ok])
        return ok

    def split(self, flat):
        """Flat buffer (size,) -> list of (nu, nv) arrays, one per map (views)."""
        out = []
        for m in self.maps:
            nu, nv = m.shape
            out.append(flat[m.start:m.start + nu * m.stride].reshape(nu, m.stride)[:, :nv])
        return out

    def mask_flat(self):
        flat = np.zeros(self.size, dtype=bool)
        for m, view in zip(self.maps, self.split(flat)):
            view[...] = m.mask
        return flat


def _surface_map(scene, plane, pixel):
    nu = max(1, int(np.ceil(plane.size[0] / pixel - 1e-9)))
    nv = max(1, int(np.ceil(plane.size[1] / pixel - 1e-9)))
    # centre the grid on the plane's extent
    extra = (np.array([nu, nv]) * pixel - plane.size) / 2
    origin = plane.origin - extra[0] * plane.u - extra[1] * plane.v
    i = (np.arange(nu) + 0.5) * pixel - extra[0]
    j = (np.arange(nv) + 0.5) * pixel - extra[1]
    I, J = np.meshgrid(i, j, indexing="ij")
    tri, _ = locate_points(plane_triangles_2d(scene, plane),
                           np.stack([I.reshape(-1), J.reshape(-1)], axis=1))
    mask = (tri >= 0).reshape(nu, nv)
    # triangles in this map's (u, v) frame (origin shifted by -extra from the plane's)
    tri2d = plane_triangles_2d(scene, plane) + extra
    return VoteMap(kind="surface", plane=plane.index, layer=-1, room=plane.room,
                   normal=plane.normal.copy(), offset=plane.offset, origin=origin,
                   u=plane.u.copy(), v=plane.v.copy(), shape=(nu, nv), pixel=pixel, mask=mask,
                   face_test=FaceTest(tri2d, mask, (0.0, 0.0), pixel))


def dummy_layer_heights(scene, room, spacing, count=None, lowest=None):
    """Heights (z, metres) of dummy layers from just below the ceiling downwards.

    Parameters
    ----------
    spacing : float
        Distance between layers (metres); the first layer is one spacing below the
        highest ceiling point.
    count : int, optional
        Number of layers; default: down to ``lowest``.
    lowest : float, optional
        Lowest layer height above the floor (default 1.5 m, the lowest a pendant usually
        hangs above a floor; tables are lower).
    """
    sel = (scene.face_room == room) & ~scene.face_virtual
    n = scene.face_normals[sel]
    tri = scene.triangles[sel]
    up, down = n[:, 2] > 0.3, n[:, 2] < -0.3
    if not up.any() or not down.any():
        return np.zeros(0)
    floor = float(tri[up][:, :, 2].min())
    ceiling = float(tri[down][:, :, 2].max())
    lowest = 1.5 if lowest is None else float(lowest)
    top = ceiling - spacing
    if count is None:
        bottom = floor + min(lowest, 0.5 * (ceiling - floor))
        count = int(np.floor((top - bottom) / spacing + 1e-9)) + 1
    heights = top - spacing * np.arange(max(0, int(count)))
    return heights[heights > floor + 0.1]


def _dummy_maps(scene, room, heights, pixel, two_sided, clearance):
    sel = np.flatnonzero((scene.face_room == room) & ~scene.face_virtual)
    n = scene.face_normals[sel]
    tri = scene.triangles[sel]
    up = tri[n[:, 2] > 0.3]
    down = tri[n[:, 2] < -0.3]
    lo = tri.reshape(-1, 3).min(0)
    hi = tri.reshape(-1, 3).max(0)
    nu = max(1, int(np.ceil((hi[0] - lo[0]) / pixel - 1e-9)))
    nv = max(1, int(np.ceil((hi[1] - lo[1]) / pixel - 1e-9)))
    extra = (np.array([nu, nv]) * pixel - (hi[:2] - lo[:2])) / 2
    x = lo[0] - extra[0] + (np.arange(nu) + 0.5) * pixel
    y = lo[1] - extra[1] + (np.arange(nv) + 0.5) * pixel
    X, Y = np.meshgrid(x, y, indexing="ij")
    xy = np.stack([X.reshape(-1), Y.reshape(-1)], axis=1)
    t_up, _ = locate_points(up[:, :, :2], xy)
    t_dn, b_dn = locate_points(down[:, :, :2], xy)
    ceil_z = np.full(len(xy), -np.inf)
    ok = t_dn >= 0
    ceil_z[ok] = np.einsum("kj,kj->k", b_dn[ok], down[t_dn[ok]][:, :, 2])
    footprint = t_up >= 0
    grid = DummyGrid(origin=np.array([lo[0] - extra[0], lo[1] - extra[1]]), pixel=pixel,
                     footprint=footprint.reshape(nu, nv), ceiling_z=ceil_z.reshape(nu, nv),
                     floor_z=float(up[:, :, 2].min()) if len(up) else float(lo[2]),
                     floor_test=FaceTest(up[:, :, :2], footprint.reshape(nu, nv),
                                         (lo[0] - extra[0], lo[1] - extra[1]), pixel)
                     if len(up) else None)
    maps = []
    sides = [np.array([0.0, 0.0, -1.0])] + ([np.array([0.0, 0.0, 1.0])] if two_sided else [])
    for k, z in enumerate(heights):
        mask = (footprint & (ceil_z > z + clearance)).reshape(nu, nv)
        for nrm in sides:
            u, v = plane_basis(nrm)
            # pixel (i, j) centre must be (x_i, y_j): choose u = +x, v = +y on both sides
            u = np.array([1.0, 0.0, 0.0])
            v = np.array([0.0, 1.0, 0.0])
            origin = np.array([lo[0] - extra[0], lo[1] - extra[1], z])
            maps.append(VoteMap(kind="dummy", plane=-1, layer=k, room=room, normal=nrm,
                                offset=float(-nrm @ origin), origin=origin, u=u, v=v,
                                shape=(nu, nv), pixel=pixel, mask=mask.copy(), height=float(z)))
    return maps, grid


#: Peak bytes per pixel while one vote map is built (pixel centres, point location).
MAP_BUILD_BYTES_PER_PIXEL = 320
#: Bytes per pixel for the room's whole canvas over the run (masks, votes, counts, the
#: smoothed copies of peak detection): measured on examples/office.ply, 71 B at 0.01 m and
#: >= 97 B at 0.005 m per pixel above the run's baseline.
CANVAS_BYTES_PER_PIXEL = 128


def _grid_shape(size_u, size_v, pixel):
    return (max(1, int(np.ceil(size_u / pixel - 1e-9))),
            max(1, int(np.ceil(size_v / pixel - 1e-9))))


def canvas_memory(scene, room, plane_ids, pixel, dummy_maps):
    """(estimated peak bytes, pixels) of a room's vote maps (see the constants above)."""
    sizes = [int(np.prod(_grid_shape(*scene.planes[pi].size, pixel))) for pi in plane_ids]
    sel = (scene.face_room == room) & ~scene.face_virtual
    if sel.any():
        pts = scene.triangles[sel].reshape(-1, 3)
        span = pts.max(0) - pts.min(0)
        footprint = int(np.prod(_grid_shape(span[0], span[1], pixel)))
        sizes += [footprint] * (int(dummy_maps) + 1)     # + the footprint grid
    total = float(np.sum(sizes, dtype=np.float64)) if sizes else 0.0
    peak = float(max(sizes)) if sizes else 0.0
    return total * CANVAS_BYTES_PER_PIXEL + peak * MAP_BUILD_BYTES_PER_PIXEL, total


def require_canvas_memory(scene, room, plane_ids, pixel, dummy_maps):
    """Refuse (:class:`~invrad_wb.core.model.memory.MemoryLimitError`) a room's vote maps
    whose pixels would not fit in the memory budget, before any is made."""
    from invrad_wb.core.model.memory import require
    nbytes, total = canvas_memory(scene, room, plane_ids, pixel, dummy_maps)
    require(nbytes,
            f"room {room}'s vote maps at {pixel:g} m per pixel ({total:.3g} pixels on"
            f" {len(plane_ids)} surface(s) and {int(dummy_maps)} dummy layer(s))",
            "use a coarser --resolution (vote-map metres per pixel) or fewer dummy layers")


def build_canvas(scene, room, pixel=0.1, dummy=True, dummy_spacing=0.15, dummy_count=None,
                 dummy_lowest=None, two_sided=False, planes=None):
    """Vote maps of one room.

    Parameters
    ----------
    scene : Scene
    room : int
    pixel : float
        Vote-map resolution in metres per pixel.
    dummy : bool
        Add dummy planes (the thesis' "midair vote").
    dummy_spacing, dummy_count, dummy_lowest :
        Layers from one spacing below the ceiling downwards (see :func:`dummy_layer_heights`).
    two_sided : bool
        Dummy layers also hold upward-facing luminaires.
    planes : iterable of int, optional
        Restrict surface maps to these planes (default: every real plane of the room).

    Returns
    -------
    VoteCanvas
    """
    pixel = float(pixel)
    if not np.isfinite(pixel) or pixel <= 0:
        raise SettingsError(f"vote-map resolution must be a positive number of metres, got"
                            f" {pixel!r}")
    maps = []
    plane_ids = [p.index for p in scene.planes if p.room == room and not p.is_virtual]
    if planes is not None:
        allowed = set(int(p) for p in planes)
        plane_ids = [p for p in plane_ids if p in allowed]
    heights = np.zeros(0)
    if dummy:
        if dummy_spacing <= 0:
            raise SettingsError(f"dummy plane spacing must be > 0 m, got {dummy_spacing!r}")
        heights = dummy_layer_heights(scene, room, dummy_spacing, dummy_count, dummy_lowest)
    require_canvas_memory(scene, room, plane_ids, pixel, len(heights) * (2 if two_sided else 1))
    for pi in plane_ids:
        m = _surface_map(scene, scene.planes[pi], pixel)
        if m.mask.any():
            maps.append(m)
    # the footprint grid is always built: it also keeps refined luminaires inside the room
    dmaps, grid = _dummy_maps(scene, room, heights, pixel, two_sided,
                              clearance=0.5 * dummy_spacing if dummy else 0.0)
    maps += dmaps
    start = 0
    for m in maps:
        m.stride = _align(m.shape[1])
        m.start = start
        start += m.shape[0] * m.stride
    return VoteCanvas(maps=maps, size=start, pixel=pixel, room=room, dummy_heights=heights,
                      grid=grid)
