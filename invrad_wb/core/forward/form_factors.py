"""Point-to-patch and patch-to-patch form factors: the ``kernels/radiosity.cl`` family.

One module owns the kernels' source, their device buffers (:func:`patch_buffers`), their
launches, their float64 numpy twins and their registration (``form_factors``,
``patch_form_factors`` in :mod:`invrad_wb.core.accel.registry`). The exact
differential-area-to-triangle formula (:func:`point_triangle_form_factor`) is the near
field; beyond the blend radius the point approximation is used, blended linearly in r^2
(:mod:`invrad_wb.core.forward.radiosity` describes the method).
"""
import threading
import weakref

import numpy as np

from invrad_wb import constants as C
from invrad_wb.core.accel.buffers import device_buffer, float4, round_up
from invrad_wb.core.accel.device import get_env
from invrad_wb.core.accel.registry import implementation, register

#: Patches per OpenCL work-item (float16 lanes) and triangles per near-field vector.
PATCH_LANES = 16
TRI_LANES = 8


def _edge_terms(a, b, m):
    """``gamma (m . unit(a x b))`` per row for contour edges a -> b, (k, 3) each -> (k,)."""
    cr = np.cross(a, b)
    s2 = np.einsum("ij,ij->i", cr, cr)
    la2 = np.einsum("ij,ij->i", a, a)
    lb2 = np.einsum("ij,ij->i", b, b)
    s = np.sqrt(s2)
    g = np.arctan2(s, np.einsum("ij,ij->i", a, b))
    ok = s2 > 1e-24 * la2 * lb2
    return np.where(ok, np.einsum("ij,ij->i", m, cr) * g / np.where(ok, s, 1.0), 0.0)


def point_triangle_form_factor(points, normals, triangles):
    """Exact form factor from differential areas to triangles, clipped at their horizon.

    ``F = -1/(2 pi) sum_edges gamma_e m . unit(R_e x R_e+1)`` over the part of each triangle
    in front of the receiver's tangent plane (the Lambert / Nusselt contour integral).

    Parameters
    ----------
    points : (k, 3) float64, metres
        Receiver points; none may lie on a triangle's contour.
    normals : (k, 3) float64
        Unit receiver normals.
    triangles : (k, 3, 3) float64, metres
        One triangle per receiver, counter-clockwise seen from the side it emits to. A
        receiver behind a triangle gets a negative value: callers skip back-facing pairs.

    Returns
    -------
    (k,) float64, dimensionless: the fraction of the receiver's hemisphere-projected view
    covered by the triangle.
    """
    p = np.asarray(points, dtype=np.float64)
    m = np.asarray(normals, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.float64)
    r = [tri[:, 0] - p, tri[:, 1] - p, tri[:, 2] - p]
    h = [np.einsum("ij,ij->i", m, x) for x in r]
    inside = [x > 0 for x in h]
    total = np.zeros(len(p))
    leave = np.zeros_like(p)
    enter = np.zeros_like(p)
    for e in range(3):
        ra, rb = r[e], r[(e + 1) % 3]
        ha, hb = h[e], h[(e + 1) % 3]
        ia, ib = inside[e], inside[(e + 1) % 3]
        cut = ia != ib
        t = ha / np.where(cut, ha - hb, 1.0)
        x = ra + t[:, None] * (rb - ra)
        start = np.where(ia[:, None], ra, x)
        end = np.where(ib[:, None], rb, x)
        total += np.where(ia | ib, _edge_terms(start, end, m), 0.0)
        leave = np.where((ia & ~ib)[:, None], x, leave)
        enter = np.where((~ia & ib)[:, None], x, enter)
    cut = (inside[0] | inside[1] | inside[2]) & ~(inside[0] & inside[1] & inside[2])
    total += np.where(cut, _edge_terms(leave, enter, m), 0.0)
    return -total / (2.0 * np.pi)


def form_factor_matrix(points, normals, point_plane, patches, point_patch=None,
                       visibility=None, backend="numpy", centre=None):
    """Point-to-patch form factors ``F(p_i -> j) * V(point_patch_i, j)``.

    Parameters
    ----------
    points : (k, 3) float64, metres
    normals : (k, 3) float64, unit receiver normals
    point_plane : (k,) int
        Plane id of each receiver (patches of the same plane give 0).
    patches : PatchSet
    point_patch : (k,) int, optional
        Row of ``visibility`` for each receiver (required with ``visibility``).
    visibility : (P, P) uint8, optional
        Patch-to-patch visibility (1 visible, 0 occluded); None = all visible.
    backend : {'numpy', 'opencl'}
    centre : (3,) float64, optional
        Origin for the float32 coordinates on the device (default: mean patch centroid).

    Returns
    -------
    (k, P) float64 (numpy) or float32 (opencl), dimensionless.
    """
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    normals = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    point_plane = np.asarray(point_plane, dtype=np.int64).reshape(-1)
    if visibility is not None:
        if point_patch is None:
            raise ValueError("visibility needs point_patch")
        point_patch = np.asarray(point_patch, dtype=np.int64).reshape(-1)
    fn = implementation("form_factors", backend)
    return fn(points, normals, point_plane, patches, point_patch, visibility, centre)


def _near_field_numpy(p, m, ps, pj):
    """Exact form factors for (receiver, patch) pairs: p, m (k, 3), pj (k,) -> (k,)."""
    eps = C.RAY_EPS_M
    c, nrm = ps.centroid[pj], ps.normal[pj]
    h = np.einsum("ij,ij->i", p - c, nrm)
    front = h > -eps
    p = p + np.maximum(eps - h, 0.0)[:, None] * nrm
    counts = np.where(front, np.diff(ps.tri_start)[pj], 0)
    out = np.zeros(len(pj))
    ends = np.cumsum(counts)
    budget = C.RADIOSITY_NUMPY_CHUNK
    s = 0
    while s < len(pj):
        # pairs s..e-1 with at most `budget` triangles in all (at least one pair)
        base = ends[s - 1] if s else 0
        e = max(s + 1, int(np.searchsorted(ends, base + budget, side="right")))
        cnt = counts[s:e]
        pair = np.repeat(np.arange(s, e), cnt)
        if len(pair):
            rank = np.arange(len(pair)) - np.repeat(np.cumsum(cnt) - cnt, cnt)
            tri = ps.triangles[ps.tri_start[pj[pair]] + rank]
            val = point_triangle_form_factor(p[pair], m[pair], tri)
            out[s:e] = np.bincount(pair - s, weights=val, minlength=e - s)
        s = e
    return out


def _inner_ratio():
    """(near radius / blend radius)^2."""
    return (C.RADIOSITY_NEAR_FACTOR / (C.RADIOSITY_NEAR_FACTOR + C.RADIOSITY_NEAR_BLEND)) ** 2


def _form_factors_numpy(points, normals, point_plane, ps, point_patch, vis, centre=None):
    """Numpy twin of ``kernels/radiosity.cl`` (float64); see :func:`form_factor_matrix`."""
    k, n = len(points), ps.n
    out = np.zeros((k, n))
    if k == 0 or n == 0:
        return out
    area = np.where(ps.emits, ps.area, 0.0)
    blend_r2 = ps.blend_r2
    inner = _inner_ratio()
    rows = max(1, C.RADIOSITY_NUMPY_CHUNK // max(1, 4 * n))
    for s in range(0, k, rows):
        p, m = points[s:s + rows], normals[s:s + rows]
        d = ps.centroid[None, :, :] - p[:, None, :]
        d2 = np.maximum(np.einsum("kpi,kpi->kp", d, d), 1e-24)
        ci = np.einsum("kpi,ki->kp", d, m)
        cj = -np.einsum("kpi,pi->kp", d, ps.normal)
        f = area * np.maximum(ci, 0.0) * np.maximum(cj, 0.0) / (np.pi * d2 * d2)
        same = ps.plane[None, :] == point_plane[s:s + rows, None]
        near = (d2 < blend_r2) & ~same
        ri, pj = np.nonzero(near)
        if len(ri):
            exact = _near_field_numpy(p[ri], m[ri], ps, pj)
            b2 = blend_r2[pj]
            t = np.clip((d2[ri, pj] - inner * b2) / ((1.0 - inner) * b2), 0.0, 1.0)
            f[ri, pj] = exact + t * (f[ri, pj] - exact)
        f[same] = 0.0
        if vis is not None:
            f *= vis[point_patch[s:s + rows]]
        out[s:s + rows] = f
    return out


def _pair_form_factors_numpy(p, m, ps, pj):
    """The form factors of :func:`_form_factors_numpy` (no plane, no visibility) for
    (receiver, patch) pairs only: p, m (k, 3), pj (k,) -> (k,). What a few near patches
    of many receivers need, without the (receivers, P) array and the exact near field of
    every other near patch of theirs."""
    p = np.asarray(p, dtype=np.float64).reshape(-1, 3)
    m = np.asarray(m, dtype=np.float64).reshape(-1, 3)
    pj = np.asarray(pj, dtype=np.int64).reshape(-1)
    if not len(pj):
        return np.zeros(0)
    d = ps.centroid[pj] - p
    d2 = np.maximum(np.einsum("ij,ij->i", d, d), 1e-24)
    ci = np.einsum("ij,ij->i", d, m)
    cj = -np.einsum("ij,ij->i", d, ps.normal[pj])
    area = np.where(ps.emits[pj], ps.area[pj], 0.0)
    f = area * np.maximum(ci, 0.0) * np.maximum(cj, 0.0) / (np.pi * d2 * d2)
    b2 = ps.blend_r2[pj]
    near = np.flatnonzero(d2 < b2)
    if len(near):
        exact = _near_field_numpy(p[near], m[near], ps, pj[near])
        inner = _inner_ratio()
        t = np.clip((d2[near] - inner * b2[near]) / ((1.0 - inner) * b2[near]), 0.0, 1.0)
        f[near] = exact + t * (f[near] - exact)
    return f


def _patch_launch(env, ps, vis, centre, kernel):
    """What both radiosity.cl form-factor kernels take: the centre (float32 coordinates are
    relative to it), patch blocks of ``PATCH_LANES`` (count and padded length), the patch
    set's device buffers, the kernel built with ``-D VIS`` and the padded visibility buffer
    (a dummy when ``vis`` is None)."""
    n = ps.n
    if centre is None:
        centre = ps.centroid.mean(axis=0)
    centre = np.asarray(centre, dtype=np.float64)
    nblk = -(-n // PATCH_LANES)
    ppad = nblk * PATCH_LANES
    bufs = patch_buffers(env, ps, centre)
    knl = env.kernel("radiosity", kernel, [f"-D VIS={0 if vis is None else 1}"])
    if vis is None:
        d_vis = device_buffer(env, np.zeros(16, np.uint8))     # not read with VIS=0
    else:
        vpad = np.zeros((n, ppad), np.uint8)
        vpad[:, :n] = vis
        d_vis = device_buffer(env, vpad)
    return centre, nblk, ppad, bufs, knl, d_vis


def _output_rows(env, count, ppad):
    """Rows of receivers per launch (at most ``RADIOSITY_CL_CHUNK_MB`` of output), the
    host array and the device buffer each launch's rows are read back through."""
    rows = max(1, min(count, (C.RADIOSITY_CL_CHUNK_MB << 20) // (4 * ppad)))
    host = np.empty((rows, ppad), np.float32)
    return rows, host, device_buffer(env, host, "write")


def padded_patches(n):
    """Columns of the form-factor kernel's output for ``n`` patches (whole
    ``PATCH_LANES`` blocks)."""
    return -(-int(n) // PATCH_LANES) * PATCH_LANES


def _form_factors_opencl(points, normals, point_plane, ps, point_patch, vis, centre=None):
    """Form factors with ``kernels/radiosity.cl`` (float32); see :func:`form_factor_matrix`."""
    k, n = len(points), ps.n
    if k == 0 or n == 0:
        return np.zeros((k, n), np.float32)
    rows = min(k, max(1, (C.RADIOSITY_CL_CHUNK_MB << 20) // (4 * padded_patches(n))))
    out = np.empty((k, n), np.float32)
    host = np.empty((rows, padded_patches(n)), np.float32)
    for s in range(0, k, rows):
        e = min(k, s + rows)
        form_factor_rows_opencl(points[s:e], normals[s:e], point_plane[s:e], ps,
                                None if point_patch is None else point_patch[s:e], vis,
                                centre, host[:e - s])
        out[s:e] = host[:e - s, :n]
    return out


def form_factor_rows_opencl(points, normals, point_plane, ps, point_patch, vis, centre,
                            out):
    """The form factors of :func:`_form_factors_opencl` written into ``out``, a C-contiguous
    ``(k, padded_patches(P))`` float32 array, as the kernel leaves them: the first ``P``
    columns of each row are the patches' (the rest is padding). Each launch's rows are
    read back straight into ``out`` (no second (k, P) array: for the 11,326 vertices x
    1180 patches of the office example's final refit, a 53 MB matrix, the copies and the
    first touch of two more such arrays were about half of the gather's time)."""
    env = get_env()
    k, n = len(points), ps.n
    if k == 0 or n == 0:
        return out
    centre, nblk, ppad, (pblk, pplane, tstart, tris), knl, d_vis = _patch_launch(
        env, ps, vis, centre, "form_factors")
    if out.shape != (k, ppad) or out.dtype != np.float32 or not out.flags.c_contiguous:
        raise ValueError(f"out must be a C-contiguous ({k}, {ppad}) float32 array")
    info = np.zeros((k, 2), np.int32)
    info[:, 0] = point_plane
    if point_patch is not None:
        info[:, 1] = point_patch
    rows = max(1, min(k, (C.RADIOSITY_CL_CHUNK_MB << 20) // (4 * ppad)))
    d_out = device_buffer(env, out[:rows], "write")
    for s in range(0, k, rows):
        e = min(k, s + rows)
        c = e - s
        d_pts = device_buffer(env, float4(points[s:e] - centre))
        d_nrm = device_buffer(env, float4(normals[s:e]))
        d_inf = device_buffer(env, info[s:e])
        knl(env.queue, (round_up(c, 8), nblk), None, np.int32(c), np.int32(ppad),
            d_pts, d_nrm, d_inf, pblk, pplane, tstart, tris, d_vis,
            np.float32(C.RAY_EPS_M), np.float32(_inner_ratio()), d_out)
        env.cl.enqueue_copy(env.queue, out[s:e], d_out)
    return out


def patch_form_factors(points, normals, ps, parent, weight, vis, backend="numpy",
                       centre=None):
    """Patch-to-patch form factors: each row the weighted sum over its samples.

    ``F[i, j] = sum_{s: parent_s = i} weight_s F(s -> j) V(i, j)``, with the point-to-patch
    form factor of :func:`form_factor_matrix` (receivers on their parent's plane).

    Parameters
    ----------
    points : (S, 3) float64, metres
        Sub-patch sample points, sorted by ``parent``.
    normals : (S, 3) float64, unit
    ps : PatchSet
    parent : (S,) int, non-decreasing
        The patch each sample belongs to (its row).
    weight : (S,) float64
        Sample area / parent patch area.
    vis : (P, P) uint8 or None
    backend : {'numpy', 'opencl', 'auto'}
    centre : (3,) float64, optional
        Origin of the device's float32 coordinates.

    Returns
    -------
    (P, P) float64, dimensionless (rows without samples are 0).
    """
    parent = np.asarray(parent, dtype=np.int64).reshape(-1)
    if len(parent) > 1 and np.any(np.diff(parent) < 0):
        raise ValueError("patch_form_factors: samples must be sorted by parent")
    fn = implementation("patch_form_factors", backend)
    return fn(np.asarray(points, dtype=np.float64).reshape(-1, 3),
              np.asarray(normals, dtype=np.float64).reshape(-1, 3), ps, parent,
              np.asarray(weight, dtype=np.float64).reshape(-1), vis, centre)


def _patch_form_factors_numpy(points, normals, ps, parent, weight, vis, centre=None):
    """Numpy twin of ``patch_form_factors`` in ``kernels/radiosity.cl`` (float64): the
    samples' rows of :func:`_form_factors_numpy`, weighted and summed per parent."""
    n = ps.n
    F = np.zeros((n, n))
    if n == 0 or len(parent) == 0:
        return F
    step = max(1, (C.RADIOSITY_CL_CHUNK_MB << 20) // (8 * n))
    for s in range(0, len(parent), step):
        p = parent[s:s + step]
        fs = _form_factors_numpy(points[s:s + step], normals[s:s + step], ps.plane[p], ps,
                                 p, vis, centre)
        fs *= weight[s:s + step, None]
        # samples are sorted by parent: one segment per parent in this chunk
        starts = np.flatnonzero(np.r_[True, p[1:] != p[:-1]])
        F[p[starts]] += np.add.reduceat(fs, starts, axis=0)
    return F


def _patch_form_factors_opencl(points, normals, ps, parent, weight, vis, centre=None):
    """``patch_form_factors`` of ``kernels/radiosity.cl`` (float32 on the device, the sum
    over a row's samples included); see :func:`patch_form_factors`."""
    n = ps.n
    F = np.zeros((n, n))
    if n == 0 or len(parent) == 0:
        return F
    env = get_env()
    centre, nblk, ppad, (pblk, pplane, tstart, tris), knl, d_vis = _patch_launch(
        env, ps, vis, centre, "patch_form_factors")
    info = np.stack([ps.plane[parent], parent], axis=1).astype(np.int32)
    # sstart[r] = first sample of row r (rows without samples: empty ranges)
    sstart = np.searchsorted(parent, np.arange(n + 1)).astype(np.int32)
    d_pts = device_buffer(env, float4(points - centre))
    d_nrm = device_buffer(env, float4(normals))
    d_inf = device_buffer(env, info)
    d_w = device_buffer(env, weight.astype(np.float32))
    rows, host, d_out = _output_rows(env, n, ppad)
    for r0 in range(0, n, rows):
        r1 = min(n, r0 + rows)
        c = r1 - r0
        d_st = device_buffer(env, sstart[r0:r1 + 1])
        knl(env.queue, (round_up(c, 8), nblk), None, np.int32(c), np.int32(ppad),
            d_pts, d_nrm, d_inf, d_w, d_st, pblk, pplane, tstart, tris, d_vis,
            np.float32(C.RAY_EPS_M), np.float32(_inner_ratio()), d_out)
        env.cl.enqueue_copy(env.queue, host[:c], d_out)
        F[r0:r1] = host[:c, :n]
    return F


#: PatchSet -> ((OpenCL context, centre), its device buffers): this family's, kept here (a
#: patch set that goes away takes them with it; the patch set itself holds no device state)
_PATCH_BUFFERS = weakref.WeakKeyDictionary()
_LOCK = threading.Lock()


def patch_buffers(env, ps, centre):
    """The patch set's device buffers (pblk, pplane, tstart, tris), coordinates relative to
    ``centre``; kept for the patch set's next launch with the same context and centre."""
    key = (env.ctx, tuple(np.round(centre, 12)))
    with _LOCK:
        hit = _PATCH_BUFFERS.get(ps)
    if hit is not None and hit[0] == key:
        return hit[1]
    n = ps.n
    nblk = max(1, -(-n // PATCH_LANES))
    ppad = nblk * PATCH_LANES
    rows = np.zeros((8, ppad), np.float64)
    rows[0:3] = 1e4  # padding patches far away, area 0
    rows[0:3, :n] = (ps.centroid - centre).T
    rows[3:6, :n] = ps.normal.T
    rows[6, :n] = np.where(ps.emits, ps.area, 0.0)
    rows[7, :n] = ps.blend_r2
    pblk = np.ascontiguousarray(
        rows.reshape(8, nblk, PATCH_LANES).transpose(1, 0, 2).astype(np.float32))
    pplane = np.full(ppad, -2, np.int32)
    pplane[:n] = ps.plane
    # triangles of each emitting patch, padded to blocks of TRI_LANES
    counts = np.diff(ps.tri_start)
    nb = np.where(ps.emits, -(-counts // TRI_LANES), 0)
    tstart = np.concatenate([[0], np.cumsum(nb)]).astype(np.int32)
    total = max(1, int(tstart[-1]))
    slot_patch = np.repeat(np.arange(n), nb * TRI_LANES)
    slot_rank = np.arange(len(slot_patch)) - np.repeat(tstart[:-1] * TRI_LANES,
                                                        nb * TRI_LANES)
    real = slot_rank < counts[slot_patch]
    src = np.where(real, ps.tri_start[slot_patch] + slot_rank,
                   ps.tri_start[slot_patch])
    t = ps.triangles[src] - centre
    t[~real] = t[~real][:, :1, :]  # degenerate padding: three equal corners
    tris = np.zeros((total, 9, TRI_LANES), np.float32)
    if len(slot_patch):
        tris[:len(slot_patch) // TRI_LANES] = (
            t.reshape(-1, TRI_LANES, 9).transpose(0, 2, 1))
    bufs = tuple(device_buffer(env, a) for a in (pblk, pplane, tstart, tris))
    with _LOCK:
        _PATCH_BUFFERS[ps] = (key, bufs)
    return bufs


register("form_factors", _form_factors_opencl, _form_factors_numpy,
         "point-to-patch form factors, exact near and point far (kernels/radiosity.cl)")
register("patch_form_factors", _patch_form_factors_opencl, _patch_form_factors_numpy,
         "patch-to-patch form factors summed over sub-patch samples (kernels/radiosity.cl)")
