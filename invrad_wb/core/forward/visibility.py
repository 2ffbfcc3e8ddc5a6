"""Visibility between radiosity patches: one segment per unordered pair of patches facing
each other, tested against the room's blocking faces (:func:`patch_visibility`); see
:mod:`invrad_wb.core.forward.radiosity`.
"""
import numpy as np

from invrad_wb import constants as C


def _segments_occluded(bvh, p, q, backend):
    """(k,) bool: is the segment p -> q blocked by the scene (see :mod:`.bvh`)?"""
    from invrad_wb.core.forward.occlusion import segments_occluded
    return segments_occluded(bvh, p, q, backend)


def patch_visibility(patches, bvh, backend="numpy"):
    """Patch-to-patch visibility by one segment between representative points.

    Each unordered pair of patches facing each other (both cosines > 0, at least one of
    them emitting) is tested once, between points next to the representative points
    (:attr:`PatchSet.ray_point`) moved ``RAY_EPS_M`` along their normals. Pairs not tested
    count as visible.

    Returns
    -------
    vis : (P, P) uint8, symmetric (1 visible, 0 occluded)
    n_rays : int
    """
    n = patches.n
    vis = np.ones((n, n), np.uint8)
    pts, nrm = patches.ray_point, patches.normal
    q = pts + C.RAY_EPS_M * nrm
    rows = max(1, C.RADIOSITY_NUMPY_CHUNK // max(1, n))
    pend_i, pend_j, pending = [], [], 0
    n_rays = 0

    def flush():
        nonlocal pend_i, pend_j, pending, n_rays
        if pending:
            i = np.concatenate(pend_i)
            j = np.concatenate(pend_j)
            occ = _segments_occluded(bvh, q[i], q[j], backend)
            vis[i[occ], j[occ]] = 0
            vis[j[occ], i[occ]] = 0
            n_rays += len(i)
        pend_i, pend_j, pending = [], [], 0

    for s in range(0, n, rows):
        i = np.arange(s, min(n, s + rows))
        d = pts[None, :, :] - pts[i, None, :]                      # (r, P, 3) i -> j
        dist = np.linalg.norm(d, axis=2)
        ci = np.einsum("rpk,rk->rp", d, nrm[i])
        cj = -np.einsum("rpk,pk->rp", d, nrm)
        tol = 1e-9 * np.maximum(dist, 1e-12)
        sel = ((np.arange(n)[None, :] > i[:, None]) & (ci > tol) & (cj > tol)
               & (patches.emits[i][:, None] | patches.emits[None, :]))
        a, b = np.nonzero(sel)
        if len(a):
            pend_i.append(i[a])
            pend_j.append(b)
            pending += len(a)
        if pending >= C.RADIOSITY_NUMPY_CHUNK:
            flush()
    flush()
    return vis, n_rays
