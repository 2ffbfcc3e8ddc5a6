"""Point location in 2-D triangle sets: which triangle contains each point, and where.

Used to put voting points on faces, to build the per-plane masks of vote maps (is a pixel
on a face of the plane?), to turn peak pixels back into positions on faces, and to raster
values for images. Vectorised with a uniform grid over the triangles' bounding boxes.
"""
import numpy as np


def barycentric_2d(tri, p):
    """Barycentric coordinates of points p (k, 2) in paired triangles tri (k, 3, 2)."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    v0, v1, v2 = b - a, c - a, p - a
    den = v0[:, 0] * v1[:, 1] - v1[:, 0] * v0[:, 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        l1 = (v2[:, 0] * v1[:, 1] - v1[:, 0] * v2[:, 1]) / den
        l2 = (v0[:, 0] * v2[:, 1] - v2[:, 0] * v0[:, 1]) / den
    return np.stack([1 - l1 - l2, l1, l2], axis=1)


def locate_points(tri2d, points, tol=1e-9):
    """Find the triangle containing each point.

    Parameters
    ----------
    tri2d : (t, 3, 2) float64
        Triangles in a common 2-D frame (e.g. a plane's (u, v) coordinates, metres).
    points : (k, 2) float64

    Returns
    -------
    tri_index : (k,) int64, -1 where no triangle contains the point
    bary : (k, 3) float64 barycentric coordinates in that triangle (NaN where none)
    """
    tri2d = np.asarray(tri2d, dtype=np.float64)
    points = np.asarray(points, dtype=np.float64)
    k = len(points)
    out_t = np.full(k, -1, dtype=np.int64)
    out_b = np.full((k, 3), np.nan)
    if len(tri2d) == 0 or k == 0:
        return out_t, out_b
    lo = tri2d.min(axis=1)
    hi = tri2d.max(axis=1)
    span = hi - lo
    cell = max(float(np.median(np.max(span, axis=1))), 1e-9)
    g0 = lo.min(axis=0)
    c0 = np.floor((lo - g0) / cell).astype(np.int64)
    c1 = np.floor((hi - g0) / cell).astype(np.int64)
    gw = int(c1[:, 0].max()) + 1
    gh = int(c1[:, 1].max()) + 1
    # (triangle, cell) pairs
    nx = c1[:, 0] - c0[:, 0] + 1
    ny = c1[:, 1] - c0[:, 1] + 1
    cnt = nx * ny
    tri_id = np.repeat(np.arange(len(tri2d)), cnt)
    start = np.repeat(np.cumsum(cnt) - cnt, cnt)
    j = np.arange(len(tri_id)) - start
    cx = c0[tri_id, 0] + j % nx[tri_id]
    cy = c0[tri_id, 1] + j // nx[tri_id]
    cell_id = cx * gh + cy
    order = np.argsort(cell_id, kind="stable")
    cell_sorted = cell_id[order]
    tri_sorted = tri_id[order]
    # points -> cell
    pc = np.floor((points - g0) / cell).astype(np.int64)
    inside_grid = (pc[:, 0] >= 0) & (pc[:, 0] < gw) & (pc[:, 1] >= 0) & (pc[:, 1] < gh)
    pid = np.flatnonzero(inside_grid)
    pcell = pc[pid, 0] * gh + pc[pid, 1]
    a = np.searchsorted(cell_sorted, pcell, side="left")
    b = np.searchsorted(cell_sorted, pcell, side="right")
    n = b - a
    if n.sum() == 0:
        return out_t, out_b
    pp = np.repeat(pid, n)
    off = np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)
    tt = tri_sorted[np.repeat(a, n) + off]
    bary = barycentric_2d(tri2d[tt], points[pp])
    ok = np.all(bary >= -tol, axis=1)
    pp, tt, bary = pp[ok], tt[ok], bary[ok]
    # first hit per point (points on shared edges belong to one triangle)
    first = np.unique(pp, return_index=True)[1]
    out_t[pp[first]] = tt[first]
    out_b[pp[first]] = np.clip(bary[first], 0.0, 1.0)
    out_b[pp[first]] /= out_b[pp[first]].sum(axis=1, keepdims=True)
    return out_t, out_b


def plane_triangles_2d(scene, plane):
    """The plane's faces in its (u, v) coordinates: (k, 3, 2) float64, metres."""
    tri = scene.vertices[scene.faces[plane.faces]]
    return plane.to_plane_coords(tri.reshape(-1, 3)).reshape(-1, 3, 2)
