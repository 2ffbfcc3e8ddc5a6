"""Planar polygons to triangles (ear clipping), refusing non-planar or self-crossing ones
with a message naming the face.

Our own ear clipping, not mapbox-earcut's: mapbox-earcut 2.1.0 splits polygons with a
corner on the line between its neighbours up to rounding into sliver triangles, e.g. the
pentagon (0.8, 2.2), (0.2, 0.9), (0.6, 0.7), (1.0, 0.5), (2.2, 0.5) (its corner (0.6, 0.7)
halves the segment between its neighbours) gets a triangle of 2.8e-17 m^2 that the Scene
then refuses as degenerate; so do 58 of 2812 random simple polygons with such corners.
Ours takes corners within ``1e-9 * size**2`` of straight as straight (the test
``test_corner_straight_up_to_rounding``). earcut also triangulates self-crossing polygons
(bow tie, pentagram) without a word, so the checks here are needed either way.
"""

import numpy as np

from invrad_wb import constants as C
from invrad_wb.errors import SceneError
from invrad_wb.core.model.scene import plane_basis


class PlyList:
    """A ragged list (a PLY list property, polygons of several sizes) in compressed form:
    ``counts (n,)`` and ``values (sum(counts),)``.

    Row ``i`` is ``values[starts[i]:starts[i] + counts[i]]``.
    """

    def __init__(self, counts, values):
        self.counts = np.asarray(counts, dtype=np.int64)
        self.values = values
        self.starts = np.concatenate([[0], np.cumsum(self.counts)[:-1]]).astype(np.int64)

    def __len__(self):
        return len(self.counts)

    def row(self, i):
        return self.values[self.starts[i]:self.starts[i] + self.counts[i]]


def triangulate_polygons(vertices, polygons, source=None, tol=C.PLANE_OFFSET_TOL_M):
    """Split planar polygons into triangles with the polygons' winding.

    Convex polygons are split as a fan from their first corner, concave ones by ear
    clipping; triangles keep the order of their polygons.

    Parameters
    ----------
    vertices : (n, 3) float64, metres
    polygons : PlyList or sequence of sequences of int
        Corner indices of each polygon.
    source : str, optional
        File name for error messages.
    tol : float
        Largest distance (metres) of a corner from its polygon's plane.

    Returns
    -------
    faces : (m, 3) int64
    face_source : (m,) int64
        Index of the polygon each triangle comes from.
    n_split : int
        How many polygons had more than three corners.

    Raises
    ------
    SceneError
        For a polygon with fewer than 3 corners, an index out of range, a non-planar,
        zero-area or self-intersecting polygon (naming the polygon and the value).
    """
    if not isinstance(polygons, PlyList):
        rows = [np.asarray(p, dtype=np.int64).reshape(-1) for p in polygons]
        polygons = PlyList([len(p) for p in rows],
                           np.concatenate(rows) if rows else np.empty(0, np.int64))
    counts, idx = polygons.counts, np.asarray(polygons.values)
    nv = len(vertices)
    if idx.dtype.kind == "f":
        bad = ~np.isfinite(idx) | (idx != np.round(idx))
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            i = int(np.searchsorted(polygons.starts, k, side="right") - 1)
            raise SceneError(f"face {i} refers to vertex {idx[k]!r}: vertex indices must be"
                             " integers", source)
    idx = idx.astype(np.int64)
    small = counts < 3
    if small.any():
        i = int(np.flatnonzero(small)[0])
        raise SceneError(f"face {i} has {counts[i]} vertices (a face needs at least 3);"
                         f" {int(small.sum())} such face(s)", source)
    bad = (idx < 0) | (idx >= nv)
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        i = int(np.searchsorted(polygons.starts, k, side="right") - 1)
        raise SceneError(f"face {i} refers to vertex {idx[k]} but there are only {nv}"
                         f" vertices (indices 0..{nv - 1})", source)
    tris, owner = [], []
    for k in np.unique(counts):
        sel = np.flatnonzero(counts == k)
        corners = idx[polygons.starts[sel, None] + np.arange(k)]
        if k == 3:
            tris.append(corners)
            owner.append(sel)
            continue
        t, o = _triangulate_group(vertices, corners, sel, tol, source)
        tris.append(t)
        owner.append(o)
    if not tris:
        return np.empty((0, 3), np.int64), np.empty(0, np.int64), 0
    faces = np.concatenate(tris).astype(np.int64)
    face_source = np.concatenate(owner).astype(np.int64)
    order = np.argsort(face_source, kind="stable")
    return faces[order], face_source[order], int(np.sum(counts > 3))


def _triangulate_group(vertices, corners, sel, tol, source):
    """Triangulate polygons with the same number k > 3 of corners (g, k)."""
    g, k = corners.shape
    pts = vertices[corners]
    centre = pts.mean(axis=1, keepdims=True)
    d = pts - centre
    newell = np.cross(d, np.roll(d, -1, axis=1)).sum(axis=1)
    area2 = np.linalg.norm(newell, axis=1)
    size = np.max(np.linalg.norm(d, axis=2), axis=1)
    flat = area2 <= 1e-12 * np.maximum(size, 1e-300) ** 2
    if flat.any():
        i = int(np.flatnonzero(flat)[0])
        raise SceneError(f"face {sel[i]} (vertices {corners[i].tolist()}) has zero area",
                         source)
    normal = newell / area2[:, None]
    off_plane = np.abs(np.einsum("gkc,gc->gk", d, normal))
    worst = off_plane.max(axis=1)
    bad = worst > tol
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        j = int(np.argmax(off_plane[i]))
        raise SceneError(f"face {sel[i]} is not planar: its vertex {corners[i, j]} lies"
                         f" {worst[i]:.3g} m off the polygon's plane (tolerance {tol:g} m);"
                         f" {int(bad.sum())} such face(s). Non-planar polygons cannot be"
                         " triangulated faithfully: triangulate them in the modeller", source)
    # turn at each corner, in the polygon's own plane (positive = convex)
    e_in = pts - np.roll(pts, 1, axis=1)
    e_out = np.roll(pts, -1, axis=1) - pts
    turn = np.einsum("gkc,gc->gk", np.cross(e_in, e_out), normal)
    # convex: every corner turns left and the turns add up to one revolution (a star
    # polygon such as a pentagram turns left everywhere but twice around)
    total = np.arctan2(turn, np.einsum("gkc,gkc->gk", e_in, e_out)).sum(axis=1)
    convex = (np.all(turn > 1e-9 * size[:, None] ** 2, axis=1)
              & (np.abs(total - 2 * np.pi) < 1e-6))
    fan = np.stack([np.zeros(k - 2, np.int64), np.arange(1, k - 1), np.arange(2, k)], axis=1)
    tris = [corners[convex][:, fan].reshape(-1, 3)]
    owner = [np.repeat(sel[convex], k - 2)]
    for i in np.flatnonzero(~convex):
        u, v = plane_basis(normal[i])
        q = np.stack([d[i] @ u, d[i] @ v], axis=1)
        eps = 1e-9 * size[i] ** 2
        local = None if _edges_cross(q, eps) else _ear_clip(q, eps)
        if local is None:
            raise SceneError(f"face {sel[i]} (vertices {corners[i].tolist()}) cannot be"
                             " triangulated: it intersects itself or is degenerate", source)
        tris.append(corners[i][local])
        owner.append(np.full(len(local), sel[i]))
    return np.concatenate(tris), np.concatenate(owner)


def _edges_cross(q, eps):
    """True if two non-adjacent edges of the closed 2-D polygon q (k, 2) touch or cross."""
    k = len(q)
    i, j = np.triu_indices(k, 2)
    keep = ~((i == 0) & (j == k - 1))
    i, j = i[keep], j[keep]
    a, b = q, np.roll(q, -1, axis=0)

    def side(p, r, x):
        o = (r[:, 0] - p[:, 0]) * (x[:, 1] - p[:, 1]) - (r[:, 1] - p[:, 1]) * (x[:, 0] - p[:, 0])
        return np.where(np.abs(o) <= eps, 0, np.sign(o))

    def on(p, r, x):  # x within the bounding box of segment p-r
        tol = np.sqrt(eps)
        return np.all((np.minimum(p, r) - tol <= x) & (x <= np.maximum(p, r) + tol), axis=1)

    s1, s2 = side(a[i], b[i], a[j]), side(a[i], b[i], b[j])
    s3, s4 = side(a[j], b[j], a[i]), side(a[j], b[j], b[i])
    cross = (s1 * s2 < 0) & (s3 * s4 < 0)
    touch = (((s1 == 0) & on(a[i], b[i], a[j])) | ((s2 == 0) & on(a[i], b[i], b[j]))
             | ((s3 == 0) & on(a[j], b[j], a[i])) | ((s4 == 0) & on(a[j], b[j], b[i])))
    return bool(np.any(cross | touch))


def _ear_clip(q, eps):
    """Triangulate a simple counter-clockwise 2-D polygon q (k, 2); None if impossible."""
    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    ring = list(range(len(q)))
    out = []
    while len(ring) > 3:
        n = len(ring)
        for s in range(n):
            a, b, c = ring[s - 1], ring[s], ring[(s + 1) % n]
            if cross(q[a], q[b], q[c]) <= eps:
                continue  # reflex or straight corner: not an ear
            blocked = False
            for j in ring:
                if j in (a, b, c):
                    continue
                p = q[j]
                if (cross(q[a], q[b], p) >= -eps and cross(q[b], q[c], p) >= -eps
                        and cross(q[c], q[a], p) >= -eps):
                    blocked = True  # a corner inside or on the ear
                    break
            if not blocked:
                out.append((a, b, c))
                ring.pop(s)
                break
        else:
            return None
    a, b, c = ring
    if cross(q[a], q[b], q[c]) <= eps:
        return None
    out.append((a, b, c))
    return np.array(out, dtype=np.int64)
