"""A room as the designer sees it: floor outline, its own axes, ceiling, work plane, grid.

:class:`DesignRoom` is built from the room's faces of a :class:`~invrad_wb.core.model.scene.Scene`.
It finds the room's axes (the orientation of the smallest rectangle around the floor, so
that rows and columns of luminaires run along the walls), answers "is this plan point in
the room, how far from its walls", "where is the ceiling above it", and lays the EN 12464-1
calculation grid on the work plane. Coordinates: metres, Z up; *plan* coordinates ``(s, t)``
run along the room's axes from the corner of its bounding rectangle.
"""
import numpy as np

from invrad_wb.errors import SceneError
from invrad_wb.core.design import en12464
from invrad_wb.core.geometry.outline import inside_outline
from invrad_wb.core.geometry.polygon import edge_loops, edges_3d, polygon_edges
from invrad_wb.core.geometry.raster import locate_points
from invrad_wb.core.model.targets import (WORK_PLANE_HEADROOM_M, boundary_edges,
                                          distance_to_segments)

#: faces whose normal has a Z component above this are floor, below its negative ceiling
_UP = 0.99
_DOWN = -0.3


def _lines(seg, tol):
    """The lines 2-D segments (k, 2, 2) lie on: yields (indices of the segments on one
    line, its unit direction (2,) with angle in [0, pi), its point nearest the origin)."""
    d = seg[:, 1] - seg[:, 0]
    ang = np.mod(np.arctan2(d[:, 1], d[:, 0]), np.pi)
    ang = np.where(ang > np.pi - 1e-9, 0.0, ang)
    u = np.stack([np.cos(ang), np.sin(ang)], axis=1)
    off = seg[:, 0, 0] * -u[:, 1] + seg[:, 0, 1] * u[:, 0]
    key = np.stack([np.round(ang / 1e-7), np.round(off / tol)], axis=1)
    for k in np.unique(key, axis=0):
        sel = np.flatnonzero(np.all(key == k, axis=1))
        uu = u[sel[0]]
        yield sel, uu, seg[sel[0], 0] - (seg[sel[0], 0] @ uu) * uu


def merge_collinear(segments, tol=1e-6):
    """Merge 2-D segments (k, 2, 2) that lie on one line and touch or overlap: a floor
    outline from a fine mesh (hundreds of boundary edges) becomes its few walls."""
    seg = np.asarray(segments, dtype=np.float64).reshape(-1, 2, 2)
    if len(seg) == 0:
        return seg
    out = []
    for sel, uu, base in _lines(seg, tol):
        t = np.sort(np.stack([seg[sel, 0] @ uu, seg[sel, 1] @ uu], axis=1), axis=1)
        t = t[np.argsort(t[:, 0])]
        start, end = t[0]
        for a, b in t[1:]:
            if a <= end + tol:
                end = max(end, b)
            else:
                out.append([base + start * uu, base + end * uu])
                start, end = a, b
        out.append([base + start * uu, base + end * uu])
    return np.array(out)


def cancel_opposite(segments, tol=1e-6):
    """Oriented 2-D boundary segments (k, 2, 2) less the stretches that two faces share
    with opposite directions: a mesh whose neighbouring floor cells do not meet vertex to
    vertex (a T-junction, cells of different sizes) leaves both sides of their common edge
    as "boundary"; they run opposite ways (each face's winding) and cancel. Returns the
    merged, oriented segments of what is left (the true outline)."""
    seg = np.asarray(segments, dtype=np.float64).reshape(-1, 2, 2)
    if len(seg) == 0:
        return seg
    out = []
    for sel, uu, base in _lines(seg, tol):
        a, b = seg[sel, 0] @ uu, seg[sel, 1] @ uu
        sign = np.where(b >= a, 1, -1)
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        cuts = np.unique(np.round(np.r_[lo, hi] / tol) * tol)
        net = [int(np.sum(sign[(lo <= c0 + tol) & (hi >= c1 - tol)]))
               for c0, c1 in zip(cuts[:-1], cuts[1:])]
        run = None
        for (c0, c1), n in zip(zip(cuts[:-1], cuts[1:]), net + [0]):
            if run is not None and (n != run[2] or c0 > run[1] + tol):
                s0, s1 = (run[0], run[1]) if run[2] > 0 else (run[1], run[0])
                out.append([base + s0 * uu, base + s1 * uu])
                run = None
            if n != 0 and run is None:
                run = [c0, c1, n]
            elif n != 0:
                run[1] = c1
        if run is not None:
            s0, s1 = (run[0], run[1]) if run[2] > 0 else (run[1], run[0])
            out.append([base + s0 * uu, base + s1 * uu])
    return np.array(out).reshape(-1, 2, 2)


def in_polygon(polygon, xy):
    """(k,) bool: plan points ``xy`` (k, 2) inside a plan polygon (c, 2) (even-odd)."""
    return inside_outline(polygon_edges(polygon), np.asarray(xy, dtype=np.float64).reshape(-1, 2))


class DesignRoom:
    """Plan geometry of one room.

    Attributes
    ----------
    room : int
    floor_z : float, metres (lowest floor)
    origin : (2,) float64, plan origin (x, y) of the bounding rectangle's corner
    axes : (2, 2) float64, unit row vectors (along ``s``, along ``t``) in the XY plane
    size : (2,) float64, the bounding rectangle's sides (metres)
    floor_area : float, m^2
    rectangular : bool, the floor fills its bounding rectangle
    """

    def __init__(self, scene, room, name=None):
        self.room = int(room)
        self.name = name if name is not None else f"room {room}"
        sel = (scene.face_room == room) & ~scene.face_virtual
        if not sel.any():
            raise SceneError(f"{self.name}: no faces with this room id", scene.source)
        nz = scene.face_normals[:, 2]
        floor = np.flatnonzero(sel & (nz > _UP))
        if len(floor) == 0:
            raise SceneError(f"{self.name}: the room has no floor (no upward-facing face)",
                             scene.source)
        self.floor_tri = scene.vertices[scene.faces[floor]]
        self.floor_faces = floor
        self.floor_z = float(self.floor_tri[..., 2].min())
        self.ceiling_tri = scene.vertices[scene.faces[np.flatnonzero(sel & (nz < _DOWN))]]
        self.top_z = float(scene.vertices[np.unique(scene.faces[sel])][:, 2].max())
        self.floor_area = float(scene.face_areas[floor].sum())
        # the floor's outline; stretches between cells that do not meet vertex to vertex
        # are shared (opposite windings), not walls
        self._edges = merge_collinear(cancel_opposite(boundary_edges(
            scene.vertices, scene.faces[floor])[..., :2]))
        c = self.ceiling_tri
        self._flat_ceiling = (len(c) > 0 and np.ptp(c[..., 2]) < 1e-6)
        #: the room's :class:`~invrad_wb.core.model.scene.NoMountZone` s
        self.no_mount = [z for z in getattr(scene, "no_mount", ()) if z.room == self.room]
        self._frame()

    # ------------------------------------------------------------------ frame
    def _frame(self):
        """Axes of the smallest-area rectangle around the floor, from its edge directions."""
        pts = self.floor_tri[..., :2].reshape(-1, 2)
        best = None
        d = self._edges[:, 1] - self._edges[:, 0]
        angles = np.unique(np.round(np.mod(np.arctan2(d[:, 1], d[:, 0]), np.pi / 2), 6))
        for a in angles if len(angles) else [0.0]:
            ax = np.array([[np.cos(a), np.sin(a)], [-np.sin(a), np.cos(a)]])
            st = pts @ ax.T
            lo, hi = st.min(axis=0), st.max(axis=0)
            area = float(np.prod(hi - lo))
            if best is None or area < best[0] - 1e-9:
                best = (area, ax, lo, hi)
        area, ax, lo, hi = best
        # prefer the longer side along s: rows run along the room's length
        if hi[1] - lo[1] > hi[0] - lo[0] + 1e-9:
            ax = np.array([ax[1], -ax[0]])
            st = pts @ ax.T
            lo, hi = st.min(axis=0), st.max(axis=0)
        self.axes = ax
        self.origin = lo[0] * ax[0] + lo[1] * ax[1]
        self.size = hi - lo
        self.rectangular = self.floor_area >= 0.995 * area

    def to_plan(self, xy):
        """World XY (k, 2) -> plan (s, t) (k, 2)."""
        return (np.asarray(xy, dtype=np.float64) - self.origin) @ self.axes.T

    def to_world(self, st):
        """Plan (s, t) (k, 2) -> world XY (k, 2)."""
        return self.origin + np.asarray(st, dtype=np.float64) @ self.axes

    # ------------------------------------------------------------------ queries
    def inside(self, xy):
        """(k,) bool: plan points (world XY) inside the floor outline (even-odd rule)."""
        return inside_outline(self._edges, np.asarray(xy, dtype=np.float64).reshape(-1, 2))

    def wall_distance(self, xy):
        """(k,) distance of plan points (world XY) to the floor's outline; negative outside."""
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        d = distance_to_segments(np.c_[xy, np.zeros(len(xy))], edges_3d(self._edges))
        return np.where(self.inside(xy), d, -d)

    def outline(self):
        """(k, 2, 2) the floor's outline as plan segments (world XY): its walls and the
        sides of its columns' holes, unordered."""
        return self._edges.copy()

    def outer_outline(self):
        """(k, 2, 2) the floor's outer outline (world XY): :meth:`outline` less the loops
        that lie inside another loop (a column's hole in the floor)."""
        loops = edge_loops(self._edges)
        keep = []
        for i, li in enumerate(loops):
            mid = self._edges[li[0]].mean(axis=0)[None]
            depth = sum(bool(inside_outline(self._edges[lj], mid)[0])
                        for j, lj in enumerate(loops) if j != i)
            if depth % 2 == 0:
                keep.append(li)
        return self._edges[np.sort(np.concatenate(keep))] if keep else self._edges.copy()

    def no_mount_at(self, xy, clearance_m=0.0):
        """Where plan points (world XY, (k, 2)) fall in the room's no-mount zones:
        ``(blocked, void)`` (k,) bool, inside a zone where nothing may be mounted (a
        stair; or within ``clearance_m`` of it: a luminaire's body kept off it) and
        inside one where only a pendant may hang (a slab opening above)."""
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        blocked = np.zeros(len(xy), dtype=bool)
        void = np.zeros(len(xy), dtype=bool)
        for z in self.no_mount:
            inside = in_polygon(z.polygon, xy)
            if z.pendants:
                void |= inside
            else:
                if clearance_m > 0 and len(xy):
                    d = distance_to_segments(np.c_[xy, np.zeros(len(xy))],
                                             edges_3d(polygon_edges(z.polygon)))
                    inside = inside | (d < clearance_m)
                blocked |= inside
        return blocked, void & ~blocked

    def ceiling_at(self, xy):
        """Height of the ceiling above plan points: (k,) z (NaN: none) and (k, 3) normals."""
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        z = np.full(len(xy), np.nan)
        nrm = np.tile([0.0, 0.0, -1.0], (len(xy), 1))
        if len(self.ceiling_tri) == 0:
            return z, nrm
        if self._flat_ceiling:   # the usual case: no point location needed
            z[self.inside(xy)] = self.ceiling_tri[0, 0, 2]
            return z, nrm
        idx, bary = locate_points(self.ceiling_tri[..., :2], xy)
        ok = idx >= 0
        tri = self.ceiling_tri[idx[ok]]
        z[ok] = np.einsum("ij,ij->i", bary[ok], tri[..., 2])
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        nrm[ok] = np.where(n[:, 2:3] > 0, -n, n)
        return z, nrm

    def grid(self, height_m, margin_m):
        """EN 12464-1 calculation points of the work plane (cell centres).

        The task area is the floor lifted by ``height_m`` less a border zone of
        ``margin_m`` and less where the ceiling leaves under ``WORK_PLANE_HEADROOM_M``
        above it (as the work-plane targets do); the grid spacing is at most ``p = 0.2 * 5^log10(d)`` with ``d`` the
        longer side of the area. Returns (k, 3) points (metres) and the spacing (s, t).
        """
        inner = self.size - 2.0 * margin_m
        if np.any(inner <= 0):
            raise SceneError(f"{self.name}: a border zone of {margin_m} m leaves no work"
                             f" plane in a {self.size[0]:.2f} x {self.size[1]:.2f} m room")
        ns, nt = en12464.grid_counts(inner[0], inner[1])
        s = margin_m + (np.arange(ns) + 0.5) * inner[0] / ns
        t = margin_m + (np.arange(nt) + 0.5) * inner[1] / nt
        st = np.stack(np.meshgrid(s, t, indexing="ij"), axis=-1).reshape(-1, 2)
        xy = self.to_world(st)
        keep = self.wall_distance(xy) >= margin_m - 1e-9
        # a work place needs head room (under a low sloped roof the work plane stops)
        zc, _ = self.ceiling_at(xy)
        keep &= np.nan_to_num(zc, nan=np.inf) >= self.floor_z + height_m + WORK_PLANE_HEADROOM_M
        if not keep.any():
            raise SceneError(f"{self.name}: a border zone of {margin_m} m and"
                             f" {WORK_PLANE_HEADROOM_M} m of head room leave no work plane")
        z = np.full(int(keep.sum()), self.floor_z + height_m)
        return np.c_[xy[keep], z], (inner[0] / ns, inner[1] / nt)
