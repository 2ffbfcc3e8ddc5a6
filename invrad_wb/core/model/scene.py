"""The room scene: triangles in metres (Z up), planes, rooms, reflectance and target illuminance.

A :class:`Scene` is what every part of invrad works on. It is built from arrays (see
:mod:`invrad_wb.core.io.sceneio` for files) and checked on construction, so that later stages
can trust it:

* ``vertices (n, 3) float64`` metres, ``faces (m, 3) int64``, counter-clockwise seen from
  the room side, so that face normals point into the room;
* target illuminance in lux per vertex (``vertex_lux``), per face (``face_lux``) or as a
  UV-mapped texture (``face_uv`` + ``lux_texture``). NaN means "no target" (don't care);
  0 means "must stay dark" (shade);
* ``face_room (m,) int`` room id per face and ``face_reflectance (m,)`` in [0, 1);
* ``face_virtual (m,) bool``: virtual receiver faces such as a work plane at 0.75 m. They
  carry targets and receive light, but are transparent (never occlude), do not reflect and
  are never a mounting plane for luminaires;
* ``no_mount``: :class:`NoMountZone` s, parts of a room's plan where its ceiling cannot
  carry a luminaire (a slab opening above: no ceiling there; a stair standing in the
  room); the layouts of :mod:`invrad_wb.core.design` honour them.

Coplanar faces of one room are grouped into :class:`Plane` objects (the thesis' planes that
votes are cast onto). A vertex shared by faces of different planes (a room corner) receives
different light on each plane, so such vertices are split: after construction every vertex
belongs to exactly one plane (``vertex_plane``), and ``vertex_source`` maps it back to the
vertex index of the input arrays.
"""
from dataclasses import dataclass
import functools

import numpy as np

from invrad_wb import constants as C
from invrad_wb.errors import SceneError


@dataclass
class Plane:
    """A set of coplanar faces of one room.

    Attributes
    ----------
    index : int
        Position in ``Scene.planes``.
    room : int
        Room id of its faces.
    normal : (3,) float64
        Unit normal, facing into the room.
    offset : float
        Plane equation ``normal . x + offset = 0``; the signed distance of a point ``x``
        in front of the plane is ``normal . x + offset`` (metres, positive in the room).
    origin : (3,) float64
        A point of the plane: the corner (u_min, v_min) of its faces' bounding rectangle.
    u, v : (3,) float64
        Orthonormal in-plane basis, ``u x v = normal``.
    size : (2,) float64
        Extent of the faces along u and v (metres).
    faces : (k,) int64
        Indices of the faces on this plane.
    area : float
        Total face area (m^2).
    """

    index: int
    room: int
    normal: np.ndarray
    offset: float
    origin: np.ndarray
    u: np.ndarray
    v: np.ndarray
    size: np.ndarray
    faces: np.ndarray
    area: float
    is_dummy: bool = False
    is_virtual: bool = False

    def to_plane_coords(self, points):
        """Points (n, 3) -> in-plane coordinates (n, 2) in metres from ``origin``."""
        d = np.asarray(points, dtype=np.float64) - self.origin
        return np.stack([d @ self.u, d @ self.v], axis=-1)

    def to_world(self, uv):
        """In-plane coordinates (n, 2) -> points (n, 3) on the plane."""
        uv = np.asarray(uv, dtype=np.float64)
        return self.origin + uv[..., :1] * self.u + uv[..., 1:2] * self.v

    def signed_distance(self, points):
        """Signed distance (n,) of points in front of the plane (metres)."""
        return np.asarray(points, dtype=np.float64) @ self.normal + self.offset


def plane_basis(normal):
    """Orthonormal (u, v) with ``u x v = normal``; u is horizontal unless the plane is.

    Parameters
    ----------
    normal : (3,) float64, unit
    """
    n = np.asarray(normal, dtype=np.float64)
    ref = np.array([0.0, 0.0, 1.0]) if abs(n[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    # u horizontal for walls (so vote maps are not rotated), x-aligned for floors/ceilings
    u = np.cross(ref, n) if abs(n[2]) < 0.9 else ref - n * (ref @ n)
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    return u, v


def _as_array(name, value, shape_tail, dtype, source):
    try:
        arr = np.asarray(value, dtype=dtype)
    except (TypeError, ValueError) as exc:
        raise SceneError(f"{name} cannot be read as {np.dtype(dtype).name}: {exc}", source)
    if arr.ndim != 1 + len(shape_tail) or tuple(arr.shape[1:]) != tuple(shape_tail):
        raise SceneError(f"{name} must have shape (n, {', '.join(map(str, shape_tail))})"
                         f" but has shape {arr.shape}", source)
    return arr


def _check_lux(name, values, what, source):
    """Target illuminance: finite >= 0 or NaN (no target). Inf or negative is an error."""
    bad = np.isinf(values)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise SceneError(f"{name} of {what} {i} is {values[i]} lx: illuminance must be finite"
                         f" (NaN = no target); {int(bad.sum())} such value(s)", source)
    neg = values < 0
    if neg.any():
        i = int(np.flatnonzero(neg)[0])
        raise SceneError(f"{name} of {what} {i} is {values[i]} lx: illuminance cannot be"
                         f" negative (0 = must stay dark, NaN = no target);"
                         f" {int(neg.sum())} such value(s)", source)


def _checked_mesh(vertices, faces, source):
    """Vertices (n, 3) float64 and faces (m, 3) int64, refused with a clear SceneError
    when not finite, not triangles, not integer indices, empty or out of range."""
    v = _as_array("vertices", vertices, (3,), np.float64, source)
    try:
        f = np.asarray(faces)
    except (TypeError, ValueError) as exc:
        raise SceneError(f"faces cannot be read: {exc}", source)
    if f.ndim != 2 or f.shape[1] != 3:
        raise SceneError(f"faces must be triangles, shape (m, 3), but have shape {f.shape};"
                         " triangulate polygons first (the PLY reader does this)", source)
    if f.size and not np.issubdtype(f.dtype, np.integer):
        if not np.all(np.isfinite(f)) or np.any(f != np.round(f)):
            raise SceneError("face vertex indices must be integers", source)
    f = f.astype(np.int64)
    if len(f) == 0:
        raise SceneError("scene has no faces", source)
    if not np.all(np.isfinite(v)):
        i = int(np.flatnonzero(~np.all(np.isfinite(v), axis=1))[0])
        raise SceneError(f"vertex {i} has a non-finite coordinate {v[i].tolist()}", source)
    if f.min() < 0 or f.max() >= len(v):
        i = int(np.flatnonzero((f < 0).any(1) | (f >= len(v)).any(1))[0])
        raise SceneError(f"face {i} refers to vertex {f[i].tolist()} but there are only"
                         f" {len(v)} vertices", source)
    return v, f


def _checked_targets(vertex_lux, face_lux, n, m, source):
    """Target illuminance per vertex (n,) or per face (m,), lux, or None; not both."""
    if vertex_lux is not None and face_lux is not None:
        raise SceneError("give target illuminance per vertex or per face, not both", source)
    if vertex_lux is not None:
        vertex_lux = np.asarray(vertex_lux, dtype=np.float64).reshape(-1)
        if len(vertex_lux) != n:
            raise SceneError(f"{len(vertex_lux)} vertex lux values for {n} vertices",
                             source)
        _check_lux("target illuminance", vertex_lux, "vertex", source)
    if face_lux is not None:
        face_lux = np.asarray(face_lux, dtype=np.float64).reshape(-1)
        if len(face_lux) != m:
            raise SceneError(f"{len(face_lux)} face lux values for {m} faces", source)
        _check_lux("target illuminance", face_lux, "face", source)
    return vertex_lux, face_lux


def _checked_rooms(face_room, m, source):
    """Room id per face, (m,) int64 >= 0 (default all 0)."""
    if face_room is None:
        return np.zeros(m, dtype=np.int64)
    fr = np.asarray(face_room, dtype=np.float64).reshape(-1)
    if len(fr) != m:
        raise SceneError(f"{len(fr)} room ids for {m} faces", source)
    if not np.all(np.isfinite(fr)) or np.any(fr != np.round(fr)) or np.any(fr < 0):
        i = int(np.flatnonzero(~np.isfinite(fr) | (fr != np.round(fr)) | (fr < 0))[0])
        raise SceneError(f"room id of face {i} is {fr[i]}: must be an integer >= 0",
                         source)
    return fr.astype(np.int64)


def _checked_reflectance(face_reflectance, m, source):
    """Diffuse reflectance per face, (m,) float64 in [0, 1) (default from constants)."""
    if face_reflectance is None:
        return np.full(m, C.DEFAULT_REFLECTANCE)
    rho = np.asarray(face_reflectance, dtype=np.float64).reshape(-1)
    if len(rho) != m:
        raise SceneError(f"{len(rho)} reflectance values for {m} faces", source)
    bad = ~np.isfinite(rho) | (rho < 0) | (rho >= 1)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise SceneError(f"reflectance of face {i} is {rho[i]}: must be in [0, 1)"
                         f" (a fraction, not a percentage); {int(bad.sum())} such"
                         " face(s)", source)
    return rho


def _checked_virtual(face_virtual, m, source):
    """Virtual (work plane) flag per face, (m,) bool (default all False)."""
    if face_virtual is None:
        return np.zeros(m, dtype=bool)
    face_virtual = np.asarray(face_virtual, dtype=bool).reshape(-1)
    if len(face_virtual) != m:
        raise SceneError(f"{len(face_virtual)} virtual flags for {m} faces", source)
    return face_virtual


@dataclass
class NoMountZone:
    """A part of a room's plan (world XY, metres) where no luminaire may be mounted on
    the ceiling.

    Attributes
    ----------
    room : int, room id
    polygon : (k, 2) float64, its plan outline (k >= 3 corners), metres
    reason : str, in words ('slab opening above', 'stair Wendeltreppe')
    pendants : bool, a pendant may hang there from the structure above (a slab opening:
        a double-height void); False where nothing may be (inside a stair)
    """
    room: int
    polygon: np.ndarray
    reason: str = "no ceiling"
    pendants: bool = False


def _checked_no_mount(zones, source):
    """A list of :class:`NoMountZone` with (k, 2) float64 polygons (default none)."""
    out = []
    for z in zones or ():
        if not isinstance(z, NoMountZone):
            raise SceneError(f"no_mount: expected NoMountZone, got {type(z).__name__}",
                             source)
        poly = np.asarray(z.polygon, dtype=np.float64)
        if poly.ndim != 2 or poly.shape[1] != 2 or len(poly) < 3:
            raise SceneError(f"no-mount zone {z.reason!r} of room {z.room}: a polygon of at"
                             f" least 3 plan points (k, 2) is needed, got {poly.shape}",
                             source)
        if not np.all(np.isfinite(poly)):
            raise SceneError(f"no-mount zone {z.reason!r} of room {z.room}: NaN/inf"
                             " coordinates", source)
        out.append(NoMountZone(int(z.room), poly, str(z.reason), bool(z.pendants)))
    return out


def _checked_texture(face_uv, lux_texture, m, source):
    """Texture coordinates (m, 3, 2) and lux texture (h, w), lux: both or neither."""
    if (face_uv is None) != (lux_texture is None):
        raise SceneError("a lux texture needs texture coordinates and vice versa", source)
    if face_uv is None:
        return None, None
    face_uv = np.asarray(face_uv, dtype=np.float64)
    if face_uv.shape != (m, 3, 2):
        raise SceneError(f"face_uv must have shape ({m}, 3, 2), has {face_uv.shape}",
                         source)
    if not np.all(np.isfinite(face_uv)):
        raise SceneError("texture coordinates contain NaN/inf", source)
    lux_texture = np.asarray(lux_texture, dtype=np.float64)
    if lux_texture.ndim != 2 or min(lux_texture.shape) < 1:
        raise SceneError(f"lux texture must be a 2-D image, has shape"
                         f" {lux_texture.shape}", source)
    _check_lux("lux texture", lux_texture.reshape(-1), "pixel", source)
    return face_uv, lux_texture


class Scene:
    """A checked room scene. See the module docstring for the conventions.

    Parameters
    ----------
    vertices : (n, 3) float64, metres
    faces : (m, 3) int
        Triangles, counter-clockwise seen from the room side.
    vertex_lux : (n,) float64, lux, optional
        Target illuminance per vertex; NaN = no target.
    face_lux : (m,) float64, lux, optional
        Target illuminance per face (alternative to ``vertex_lux``).
    face_room : (m,) int, optional
        Room id per face (default 0).
    face_reflectance : (m,) float64, optional
        Diffuse reflectance per face in [0, 1) (default ``constants.DEFAULT_REFLECTANCE``).
    face_uv : (m, 3, 2) float64, optional
        Texture coordinates of each face corner for ``lux_texture``.
    lux_texture : (h, w) float64, lux, optional
        UV-mapped target illuminance; row 0 is v = 1 (image convention).
    face_virtual : (m,) bool, optional
        Virtual receiver faces (work planes): transparent, non-reflecting.
    source : str, optional
        File or object name used in error messages.
    no_mount : list of :class:`NoMountZone`, optional
        Parts of rooms' ceilings where no luminaire may be mounted.
    check_winding : bool
        Refuse inconsistent winding and rooms whose normals face outward.
    """

    def __init__(self, vertices, faces, vertex_lux=None, face_lux=None, face_room=None,
                 face_reflectance=None, face_uv=None, lux_texture=None, face_virtual=None,
                 source=None, check_winding=True, _split=True, no_mount=None):
        self.source = source
        v, f = _checked_mesh(vertices, faces, source)
        m = len(f)
        vertex_lux, face_lux = _checked_targets(vertex_lux, face_lux, len(v), m, source)
        face_room = _checked_rooms(face_room, m, source)
        face_reflectance = _checked_reflectance(face_reflectance, m, source)
        face_virtual = _checked_virtual(face_virtual, m, source)
        face_uv, lux_texture = _checked_texture(face_uv, lux_texture, m, source)

        self.vertices = v
        self.faces = f
        self.vertex_lux = vertex_lux
        self.face_lux = face_lux
        self.face_room = face_room
        self.face_reflectance = face_reflectance
        self.face_uv = face_uv
        self.face_virtual = face_virtual
        self.lux_texture = lux_texture
        self.vertex_source = np.arange(len(v))
        self.no_mount = _checked_no_mount(no_mount, source)

        self._check_geometry()
        if check_winding:
            self.check_winding()
        if _split:
            self._split_vertices()

    # ------------------------------------------------------------------ geometry
    def _check_geometry(self):
        lo, hi = self.vertices.min(0), self.vertices.max(0)
        extent = float(np.max(hi - lo))
        if extent > C.MAX_PLAUSIBLE_EXTENT_M:
            raise SceneError(f"scene is {extent:.0f} m across: coordinates look like"
                             " millimetres; invrad works in metres (CLI: --unit mm)",
                             self.source)
        if extent < C.MIN_PLAUSIBLE_EXTENT_M:
            raise SceneError(f"scene is only {extent * 1000:.3g} mm across, smaller than a"
                             " luminaire: check the length unit (CLI: --unit m for a file"
                             " in metres)", self.source)
        areas = self.face_areas
        tiny = areas < C.MIN_FACE_AREA_M2 * max(1.0, extent ** 2)
        if tiny.any():
            i = int(np.flatnonzero(tiny)[0])
            raise SceneError(f"face {i} (vertices {self.faces[i].tolist()}) is degenerate:"
                             f" area {areas[i]:.3g} m^2; {int(tiny.sum())} degenerate face(s)."
                             " Remove zero-area triangles", self.source)

    @functools.cached_property
    def _cross(self):
        t = self.vertices[self.faces]
        return np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])

    @functools.cached_property
    def face_areas(self):
        """(m,) float64, m^2."""
        return 0.5 * np.linalg.norm(self._cross, axis=1)

    @functools.cached_property
    def face_normals(self):
        """(m, 3) float64 unit normals facing into the room (from the winding)."""
        n = self._cross
        return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)

    @functools.cached_property
    def face_centroids(self):
        """(m, 3) float64, metres."""
        return self.vertices[self.faces].mean(axis=1)

    @property
    def triangles(self):
        """(m, 3, 3) float64 vertex positions of each face."""
        return self.vertices[self.faces]

    @property
    def bounds(self):
        """(2, 3) float64: min and max corner of the scene (metres)."""
        return np.stack([self.vertices.min(0), self.vertices.max(0)])

    @property
    def rooms(self):
        """Sorted room ids present in the scene."""
        return np.unique(self.face_room)

    @property
    def occluder_faces(self):
        """Indices of the faces that cast shadows and reflect (all but virtual ones)."""
        return np.flatnonzero(~self.face_virtual)

    @property
    def has_targets(self):
        return (self.vertex_lux is not None or self.face_lux is not None
                or self.lux_texture is not None)

    # ------------------------------------------------------------------ planes
    @functools.cached_property
    def _plane_data(self):
        n = self.face_normals
        off = -np.einsum("ij,ij->i", n, self.face_centroids)
        # group by (room, normal, offset) on a fine grid, then merge keys that lie within
        # tolerance across grid boundaries (so rounding can never split a plane)
        key = np.concatenate([self.face_room[:, None].astype(np.float64),
                              self.face_virtual[:, None].astype(np.float64),
                              np.round(n * 1e4), np.round(off[:, None] / C.PLANE_OFFSET_TOL_M)],
                             axis=1)
        ukeys, inverse = unique_rows(key)
        k = len(ukeys)
        # representative normal/offset per key: area weighted
        a = self.face_areas
        rep_n = np.zeros((k, 3))
        np.add.at(rep_n, inverse, n * a[:, None])
        rep_n /= np.linalg.norm(rep_n, axis=1, keepdims=True)
        rep_o = np.bincount(inverse, weights=off * a, minlength=k) / np.bincount(
            inverse, weights=a, minlength=k)
        rep_room = ukeys[:, 0] * 2 + ukeys[:, 1]
        parent = np.arange(k)

        def find(i):
            while parent[i] != i:
                parent[i] = parent[parent[i]]
                i = parent[i]
            return i

        if k < 4000:
            same = ((rep_room[:, None] == rep_room[None, :])
                    & (rep_n @ rep_n.T > 1.0 - 2e-4)
                    & (np.abs(rep_o[:, None] - rep_o[None, :]) < 2 * C.PLANE_OFFSET_TOL_M))
            for i, j in zip(*np.nonzero(np.triu(same, 1))):
                ri, rj = find(i), find(j)
                if ri != rj:
                    parent[max(ri, rj)] = min(ri, rj)
        roots = np.array([find(i) for i in range(k)])
        _, plane_of_key = np.unique(roots, return_inverse=True)
        face_plane = plane_of_key.reshape(-1)[inverse]
        return face_plane

    @functools.cached_property
    def face_plane(self):
        """(m,) int64 index into :attr:`planes` of each face."""
        return self._plane_data

    @functools.cached_property
    def planes(self):
        """List of :class:`Plane`, one per group of coplanar faces of a room."""
        fp = self.face_plane
        out = []
        a = self.face_areas
        order = np.argsort(fp, kind="stable")
        splits = np.flatnonzero(np.diff(fp[order])) + 1
        for idx, faces in enumerate(np.split(order, splits)):
            w = a[faces]
            nrm = (self.face_normals[faces] * w[:, None]).sum(0)
            nrm /= np.linalg.norm(nrm)
            pts = self.vertices[self.faces[faces]].reshape(-1, 3)
            off = -float(np.average(self.face_centroids[faces] @ nrm, weights=w))
            u, v = plane_basis(nrm)
            uv = np.stack([pts @ u, pts @ v], axis=1)
            lo, hi = uv.min(0), uv.max(0)
            origin = lo[0] * u + lo[1] * v - off * nrm
            out.append(Plane(index=idx, room=int(self.face_room[faces[0]]), normal=nrm,
                             offset=off, origin=origin, u=u, v=v, size=hi - lo,
                             faces=faces, area=float(w.sum()),
                             is_virtual=bool(self.face_virtual[faces[0]])))
        return out

    @functools.cached_property
    def vertex_plane(self):
        """(n,) int64 plane of each vertex (vertices are split per plane on construction)."""
        vp = np.full(len(self.vertices), -1, dtype=np.int64)
        vp[self.faces.reshape(-1)] = np.repeat(self.face_plane, 3)
        return vp

    @functools.cached_property
    def vertex_normals(self):
        """(n, 3) float64: the normal of each vertex's plane (zeros for unused vertices)."""
        out = np.zeros((len(self.vertices), 3))
        vp = self.vertex_plane
        used = vp >= 0
        normals = np.array([p.normal for p in self.planes])
        out[used] = normals[vp[used]]
        return out

    def _split_vertices(self):
        """Duplicate vertices shared by faces of different planes (room corners)."""
        fp = np.repeat(self.face_plane, 3)
        corners = self.faces.reshape(-1)
        pairs = np.stack([corners, fp], axis=1)
        upairs, new_index = unique_rows(pairs)
        if len(upairs) == len(self.vertices) and np.array_equal(upairs[:, 0],
                                                                np.arange(len(self.vertices))):
            return
        src = upairs[:, 0]
        self.vertices = self.vertices[src]
        self.faces = new_index.reshape(-1, 3)
        if self.vertex_lux is not None:
            self.vertex_lux = self.vertex_lux[src]
        self.vertex_source = self.vertex_source[src]
        for name in ("vertex_plane", "vertex_normals"):
            self.__dict__.pop(name, None)

    # ------------------------------------------------------------------ winding
    def check_winding(self):
        """Refuse inconsistent winding and closed rooms whose normals face outward.

        Two faces sharing an edge (after welding coincident vertices) must traverse it in
        opposite directions. For each room whose surface is closed, points just in front
        of its faces must lie inside the room (generalised winding number -1 with the
        counter-clockwise-outward convention); if they lie outside, the room's faces are
        wound clockwise seen from the room.

        Raises
        ------
        SceneError
            Naming the faces or room at fault.
        """
        tol = 1e-6 * max(1.0, float(np.max(self.bounds[1] - self.bounds[0])))
        q = np.round(self.vertices / tol).astype(np.int64)
        _, weld = unique_rows(q)
        real = ~self.face_virtual
        f = weld[self.faces]
        f_idx = np.flatnonzero(real)
        f = f[real]
        a = f.reshape(-1)
        b = f[:, [1, 2, 0]].reshape(-1)
        face_of = np.repeat(f_idx, 3)
        room = self.face_room[face_of]
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        room_ids, room_i = np.unique(room, return_inverse=True)
        if len(a) and int(hi.max()) < 1 << 26 and len(room_ids) < 1 << 11:
            # (room, lo, hi) packed into one int64: a 1-D unique (three (edges, 3) int64
            # copies and a lexsort of them peaked at 650 bytes a face, 2.6 GB for a 1.8
            # million vertex room)
            key = (room_i.astype(np.int64) << 52) | (lo.astype(np.int64) << 26) | hi
            ukey, inv = np.unique(key, return_inverse=True)
        else:
            ukey, inv = unique_rows(np.stack([room, lo, hi], axis=1))
        counts = np.bincount(inv, minlength=len(ukey))
        forward = (a < b).astype(np.int64)
        n_forward = np.bincount(inv, weights=forward, minlength=len(ukey))
        bad_edges = (counts == 2) & (n_forward != 1)
        if bad_edges.any():
            e = np.flatnonzero(bad_edges)
            faces_bad = np.unique(face_of[np.isin(inv, e)])
            raise SceneError(
                f"inconsistent winding: faces {faces_bad[:6].tolist()}"
                f"{' ...' if len(faces_bad) > 6 else ''} share an edge in the same direction"
                f" ({len(e)} such edge(s)); faces must be counter-clockwise seen from the room",
                self.source)
        for r in self.rooms:
            sel = np.flatnonzero((self.face_room == r) & real)
            if len(sel) == 0:
                continue
            used = self.vertices[np.unique(self.faces[sel])]
            size = float(np.max(used.max(0) - used.min(0)))
            probe = sel[np.argsort(self.face_areas[sel])[::-1][:5]]
            delta = 1e-3 * size
            c = self.face_centroids[probe]
            n = self.face_normals[probe]
            # the solid angles summed over chunks of the room's faces: bounded memory (a
            # 1.8 million vertex room, 3.7 million faces, held (faces, 3, 3) corners and
            # twenty (faces,) temporaries per probe at once: several GB); the points in
            # front only where those behind lie inside (a room wound right has them
            # outside: half of the check)
            def winding(points, _sel=sel):
                w = np.zeros(len(points))
                for k in range(0, len(_sel), WINDING_CHUNK_FACES):
                    w += winding_number(self.vertices[self.faces[_sel[k:k + WINDING_CHUNK_FACES]]],
                                        points)
                return w
            if np.median(winding(c - delta * n)) > 0.9 and np.median(
                    np.abs(winding(c + delta * n))) < 0.1:
                raise SceneError(
                    f"room {int(r)}: face normals point out of the room (faces are clockwise"
                    " seen from inside); flip the winding of its faces", self.source)

    # ------------------------------------------------------------------ targets
    def target_lux(self, face_index, bary):
        """Target illuminance at points given by face and barycentric coordinates.

        Parameters
        ----------
        face_index : (k,) int
        bary : (k, 3) float64
            Barycentric weights of the face's three corners.

        Returns
        -------
        (k,) float64, lux; NaN where there is no target.
        """
        face_index = np.asarray(face_index, dtype=np.int64)
        bary = np.asarray(bary, dtype=np.float64)
        if self.lux_texture is not None:
            uv = np.einsum("kj,kjc->kc", bary, self.face_uv[face_index])
            return sample_texture(self.lux_texture, uv)
        if self.vertex_lux is not None:
            lux = self.vertex_lux[self.faces[face_index]]
            return np.einsum("kj,kj->k", bary, lux)
        if self.face_lux is not None:
            return self.face_lux[face_index].copy()
        return np.full(len(face_index), np.nan)

    def vertex_targets(self):
        """(n,) float64 target lux at each vertex (mean of its faces for per-face targets)."""
        if self.vertex_lux is not None:
            return self.vertex_lux.copy()
        n = len(self.vertices)
        out = np.full(n, np.nan)
        if self.face_lux is None and self.lux_texture is None:
            return out
        m = len(self.faces)
        corners = self.faces.reshape(-1)
        bary = np.tile(np.eye(3), (m, 1))
        vals = self.target_lux(np.repeat(np.arange(m), 3), bary)
        s = np.bincount(corners, weights=np.nan_to_num(vals), minlength=n)
        c = np.bincount(corners, weights=np.isfinite(vals).astype(float), minlength=n)
        ok = c > 0
        out[ok] = s[ok] / c[ok]
        return out

    # ------------------------------------------------------------------ subsets
    #: per-process caches (radiosity models hold OpenCL objects): not pickled, rebuilt
    _PROCESS_CACHES = ("_radiosity",)

    def __getstate__(self):
        return {k: v for k, v in self.__dict__.items() if k not in self._PROCESS_CACHES}

    def room_subset(self, room):
        """The faces of one room as a new Scene; ``face_source`` maps back to this scene."""
        sel = np.flatnonzero(self.face_room == room)
        if len(sel) == 0:
            raise SceneError(f"no faces with room id {room}", self.source)
        return self.face_subset(sel)

    def face_subset(self, sel):
        sel = np.asarray(sel, dtype=np.int64)
        used, inv = np.unique(self.faces[sel].reshape(-1), return_inverse=True)
        sub = Scene(self.vertices[used], inv.reshape(-1, 3),
                    vertex_lux=None if self.vertex_lux is None else self.vertex_lux[used],
                    face_lux=None if self.face_lux is None else self.face_lux[sel],
                    face_room=self.face_room[sel], face_reflectance=self.face_reflectance[sel],
                    face_uv=None if self.face_uv is None else self.face_uv[sel],
                    lux_texture=self.lux_texture, face_virtual=self.face_virtual[sel],
                    source=self.source, check_winding=False,
                    no_mount=[z for z in self.no_mount
                              if z.room in set(self.face_room[sel].tolist())])
        sub.vertex_source = self.vertex_source[used][sub.vertex_source]
        sub.face_source = sel
        return sub

    def with_vertex_lux(self, lux):
        """A copy of this scene whose targets are ``lux (n,)`` per vertex."""
        s = Scene(self.vertices, self.faces, vertex_lux=lux, face_room=self.face_room,
                  face_reflectance=self.face_reflectance, face_virtual=self.face_virtual,
                  source=self.source,
                  check_winding=False, _split=False, no_mount=self.no_mount)
        s.vertex_source = self.vertex_source.copy()
        return s

    def __repr__(self):
        return (f"Scene({len(self.vertices)} vertices, {len(self.faces)} faces,"
                f" {len(self.planes)} planes, rooms {self.rooms.tolist()})")


def unique_rows(a):
    """``np.unique(a, axis=0, return_inverse=True)`` by lexsort (much faster for big arrays).

    Returns
    -------
    unique : (u, c) rows in lexicographic order (last column slowest)
    inverse : (n,) int64 with ``unique[inverse] == a``
    """
    a = np.asarray(a)
    if len(a) == 0:
        return a.copy(), np.zeros(0, dtype=np.int64)
    order = np.lexsort(a.T[::-1])
    b = a[order]
    new = np.ones(len(b), dtype=bool)
    new[1:] = np.any(b[1:] != b[:-1], axis=1)
    group = np.cumsum(new) - 1
    inverse = np.empty(len(a), dtype=np.int64)
    inverse[order] = group
    return b[new], inverse


def sample_texture(image, uv):
    """Bilinear lookup of a (h, w) image at texture coordinates uv (k, 2), wrapping.

    Row 0 of the image is v = 1 (images are stored top row first). NaN pixels propagate.
    """
    h, w = image.shape
    x = np.mod(uv[:, 0], 1.0) * w - 0.5
    y = (1.0 - np.mod(uv[:, 1], 1.0)) * h - 0.5
    x0 = np.floor(x).astype(np.int64)
    y0 = np.floor(y).astype(np.int64)
    fx, fy = x - x0, y - y0
    x0c, x1c = np.clip(x0, 0, w - 1), np.clip(x0 + 1, 0, w - 1)
    y0c, y1c = np.clip(y0, 0, h - 1), np.clip(y0 + 1, 0, h - 1)
    return ((image[y0c, x0c] * (1 - fx) + image[y0c, x1c] * fx) * (1 - fy)
            + (image[y1c, x0c] * (1 - fx) + image[y1c, x1c] * fx) * fy)


#: :meth:`Scene.check_winding`: faces per chunk of the winding numbers' sums
WINDING_CHUNK_FACES = 200_000


def winding_number(triangles, points):
    """Generalised winding number of points w.r.t. a triangle soup (Van Oosterom solid angle).

    Parameters
    ----------
    triangles : (m, 3, 3) float64
    points : (k, 3) float64

    Returns
    -------
    (k,) float64: +1 inside a closed surface with outward (counter-clockwise) faces,
    -1 inside one with inward faces, 0 outside; fractional for open surfaces.
    """
    t = np.asarray(triangles, dtype=np.float64).reshape(-1, 3, 3)
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    # each corner coordinate as one contiguous (m,) column: a point's pass then works on
    # arrays that stay in the cache, not on (m, 3, 3) temporaries (3.4x faster per point
    # on a 21,600-face room, the same values to 3e-16)
    (a0, a1, a2), (b0, b1, b2), (c0, c1, c2) = [
        [np.ascontiguousarray(t[:, k, j]) for j in range(3)] for k in range(3)]
    out = np.empty(len(pts))
    for i, (px, py, pz) in enumerate(pts):
        ax, ay, az = a0 - px, a1 - py, a2 - pz
        bx, by, bz = b0 - px, b1 - py, b2 - pz
        cx, cy, cz = c0 - px, c1 - py, c2 - pz
        la = np.sqrt(ax * ax + ay * ay + az * az)
        lb = np.sqrt(bx * bx + by * by + bz * bz)
        lc = np.sqrt(cx * cx + cy * cy + cz * cz)
        det = ax * (by * cz - bz * cy) + ay * (bz * cx - bx * cz) + az * (bx * cy - by * cx)
        den = (la * lb * lc + (ax * bx + ay * by + az * bz) * lc
               + (bx * cx + by * cy + bz * cz) * la + (cx * ax + cy * ay + cz * az) * lb)
        out[i] = np.sum(2.0 * np.arctan2(det, den)) / (4.0 * np.pi)
    return out
