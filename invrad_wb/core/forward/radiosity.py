"""Interreflected light: a radiosity solve per room on patches, gathered at any receiver.

Method
------
* **Rooms are independent**: patches only exchange light with patches of the same room id.
* **Patches**: each plane's triangles are clustered by a grid in the plane's (u, v) basis
  (triangle centroids, :meth:`Plane.to_plane_coords`), cell about ``patch_size`` metres
  (default per room: about ``constants.RADIOSITY_TARGET_PATCHES`` patches, never smaller
  than ``RADIOSITY_MIN_PATCH_M`` nor than the mesh's triangles). The cell count per plane is
  rounded so the cells tile the plane evenly. A patch has its area, its plane's normal, an
  area-weighted reflectance, an area centroid, a representative point *on* the surface (the
  centroid of its triangle nearest to the area centroid) and a radius (centroid to its
  farthest triangle corner). Virtual faces (work planes) become patches that receive but
  never reflect (reflectance 0, so they emit nothing and their form factors are skipped).
* **Point-to-patch form factor** ``F(p -> j)`` for a receiver point ``p`` with normal ``m``:
  near a patch (``|p - c_j| < RADIOSITY_NEAR_FACTOR * radius_j``) the exact
  differential-area-to-polygon formula (Lambert / Nusselt contour integral)
  ``F = -1/(2 pi) sum_edges gamma_e m . unit(R_e x R_e+1)`` summed over the patch's
  triangles (counter-clockwise seen from their front, hence the sign), each clipped at the
  receiver's tangent plane; beyond ``(RADIOSITY_NEAR_FACTOR + RADIOSITY_NEAR_BLEND) *
  radius_j`` the point approximation ``A_j cos_i cos_j / (pi r^2)`` to the patch centroid;
  in between the two are blended linearly in ``r^2``, so the form factor is continuous in
  the receiver position (no seams in the light; float32 and float64 agree everywhere).
  Patches on the receiver's own plane give 0, and so do patches whose plane the receiver
  lies behind. A receiver within ``RAY_EPS_M`` of a patch's plane (a point on a room edge,
  which would lie on the polygon's contour) is moved ``RAY_EPS_M`` in front of it for that
  patch; scene vertices are first stepped ``2 RAY_EPS_M`` into their own faces
  (:meth:`RadiosityModel.vertex_receivers`), so that room corners get the limit from inside.
* **Visibility** ``V(i, j)`` between patches: one segment per unordered pair of patches
  facing each other (both cosines > 0), between points next to their representative points
  (:attr:`PatchSet.ray_point`), each moved ``RAY_EPS_M`` off its surface; other pairs count
  as visible (their form factor is 0 or a near-field sliver). Rays are tested against the
  faces that can block anything in the room (:meth:`RadiosityModel._blocker_faces`:
  pillars, partitions, re-entrant walls; none in a convex room), which gives the scene
  BVH's answer at a fraction of the cost. Receivers inherit their patch's row,
  ``V(point_patch, j)``: gathering casts no new rays.
* **Patch-to-patch form factors** ``F_ij``: the area-weighted mean of ``F(s -> j) V(i, j)``
  over ``q x q`` sub-patch sample points ``s`` of patch ``i`` (``q =
  RADIOSITY_RECEIVER_SUBDIV``; each sample is the representative point of a sub-cell of the
  patch's grid cell). With ``q = 1`` this is the form factor from the representative point.
  With OpenCL the samples' sum is taken on the device (:func:`patch_form_factors`): the host
  receives the P x P matrix, not q^2 P rows.
* **Solve** ``B = rho (E + F B)`` per room (``B`` patch exitance, lm/m^2; ``E`` mean direct
  illuminance on the patch, lux) by Jacobi iteration to a relative change below
  ``RADIOSITY_TOL`` (at most ``RADIOSITY_MAX_ITER`` sweeps), for one or many right-hand
  sides at once.
* **Gather**: the interreflected illuminance at receivers is
  ``E_ind(p) = sum_j F(p -> j) V(patch(p), j) B_j``, with the same near/far form factor.

Costs and reuse
---------------
Everything that depends on geometry only is computed once per model (and
:meth:`RadiosityModel.for_scene` caches models on the scene): patches (O(m log m)),
visibility (at most P^2/2 rays per room, only facing pairs, none in convex rooms), the
patch matrix (``q^2 P`` receivers x ``P`` patches; memory ``P^2`` float64) and, on first use
of :meth:`RadiosityModel.indirect_at_vertices`, the vertex gather matrix (``n_room x
P_room`` float32 per room, ``4 n P`` bytes; above ``RADIOSITY_GATHER_MAX_MB`` it is not
stored and the form factors are recomputed at each application instead). After that,
:meth:`solve` costs O(P^2) per Jacobi sweep (about ``log(tol) / log(rho_max)`` sweeps) and a
gather one (k x P) matrix product: cheap enough to call many times (joint refinement).

Measured on the 2-core PoCL machine, a 6 x 4 x 3 m room meshed at 8 cm (17658 vertices,
1180 patches): model 0.25-0.5 s (OpenCL) / 1-1.4 s (numpy), vertex gather matrix 0.25 s /
3.5 s, then solve ~10-20 ms (16 sweeps at rho = 0.5) and gather ~5 ms per call. With a
floor-to-ceiling pillar (594k rays against 1.5k blocker triangles): model 0.4-0.55 s /
2.6 s.

Backends: ``opencl`` computes the form factors with ``kernels/radiosity.cl`` (float32,
``float16``/``float8`` vectors) and the visibility with ``kernels/occlusion.cl``; ``numpy``
is the float64 twin (vectorised, chunked to bounded memory) and needs no OpenCL.
"""
import math
import time
import warnings

import numpy as np

from invrad_wb import constants as C
from invrad_wb.errors import SettingsError
from invrad_wb.core.geometry.bvh import BVH
from invrad_wb.core.accel.buffers import device_buffer, float4, round_up
from invrad_wb.core.accel.device import check_backend, get_env
from invrad_wb.core.accel.registry import implementation, register

#: Patches per OpenCL work-item (float16 lanes) and triangles per near-field vector.
PATCH_LANES = 16
TRI_LANES = 8


# ---------------------------------------------------------------------------- exact formula
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


# ---------------------------------------------------------------------------- patches
def _cluster_stats(tri, tri_cluster, n):
    """Area, area centroid, representative point and radius of clusters of triangles.

    Parameters
    ----------
    tri : (T, 3, 3) float64
    tri_cluster : (T,) int64 in [0, n)

    Returns
    -------
    area (n,), centroid (n, 3), point (n, 3), radius (n,), rep (n,) int64 (the triangle
    whose centroid is the representative point).
    """
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    a = 0.5 * np.linalg.norm(cross, axis=1)
    cen = tri.mean(axis=1)
    area = np.bincount(tri_cluster, weights=a, minlength=n)
    centroid = np.stack([np.bincount(tri_cluster, weights=a * cen[:, k], minlength=n)
                         for k in range(3)], axis=1) / np.maximum(area, 1e-300)[:, None]
    dist = np.linalg.norm(cen - centroid[tri_cluster], axis=1)
    order = np.lexsort((dist, tri_cluster))
    first = np.ones(len(order), dtype=bool)
    first[1:] = tri_cluster[order[1:]] != tri_cluster[order[:-1]]
    rep = np.zeros(n, dtype=np.int64)
    rep[tri_cluster[order[first]]] = order[first]
    corner = np.linalg.norm(tri - centroid[tri_cluster][:, None, :], axis=2).max(axis=1)
    radius = np.zeros(n)
    np.maximum.at(radius, tri_cluster, corner)
    return area, centroid, cen[rep], radius, rep


class PatchSet:
    """Patches of one room: the emitter side of the point-to-patch form factors.

    Parameters
    ----------
    triangles : (T, 3, 3) float64, metres
        Counter-clockwise seen from the front (the side the patch emits to).
    tri_patch : (T,) int
        Patch of each triangle; every patch must have at least one triangle.
    plane : (P,) int
        Plane id of each patch (form factors between patches of one plane are 0).
    normal : (P, 3) float64
        Unit normal of each patch (its plane's).
    reflectance : (P,) float64, optional
        Diffuse reflectance (default 0.5).
    emits : (P,) bool, optional
        False for patches that never emit (virtual receivers): their form factors are 0.

    Attributes
    ----------
    n : int
        Number of patches P.
    area : (P,) float64, m^2
    centroid : (P, 3) float64, metres (area centroid; may lie off a non-convex patch)
    point : (P, 3) float64, metres (representative point, on the surface)
    radius : (P,) float64, metres
    triangles : (T, 3, 3) float64 sorted by patch; ``tri_start (P + 1,)`` delimits them.
    tri_index : (T,) int64, position of each sorted triangle in the input.
    """

    def __init__(self, triangles, tri_patch, plane, normal, reflectance=None, emits=None):
        tri = np.asarray(triangles, dtype=np.float64).reshape(-1, 3, 3)
        tri_patch = np.asarray(tri_patch, dtype=np.int64).reshape(-1)
        self.plane = np.asarray(plane, dtype=np.int64).reshape(-1)
        n = len(self.plane)
        self.n = n
        self.normal = np.asarray(normal, dtype=np.float64).reshape(n, 3)
        self.reflectance = (np.full(n, 0.5) if reflectance is None
                            else np.asarray(reflectance, dtype=np.float64).reshape(n))
        self.emits = (np.ones(n, dtype=bool) if emits is None
                      else np.asarray(emits, dtype=bool).reshape(n))
        order = np.argsort(tri_patch, kind="stable")
        self.tri_index = order
        self.triangles = tri[order]
        counts = np.bincount(tri_patch, minlength=n)
        if np.any(counts == 0):
            raise ValueError("every patch needs at least one triangle")
        self.tri_start = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        (self.area, self.centroid, self.point, self.radius,
         self.rep_triangle) = _cluster_stats(self.triangles, tri_patch[order], n)
        self._cl = None

    @property
    def ray_point(self):
        """(P, 3) visibility ray ends: inside the representative triangle, near its centroid.

        The barycentric weights are perturbed by up to +-0.05 (a fixed low-discrepancy
        sequence over the patch index), so that the rays of symmetric geometry (grid meshes
        of rectangular rooms) do not pass exactly through occluder edges, where the float32
        and float64 ray tests may disagree.
        """
        k = np.arange(self.n)
        d1 = 0.1 * (np.mod(k * 0.6180339887498949 + 0.31, 1.0) - 0.5)
        d2 = 0.1 * (np.mod(k * 0.7548776662466927 + 0.17, 1.0) - 0.5)
        w = np.stack([1.0 / 3 + d1, 1.0 / 3 + d2, 1.0 / 3 - d1 - d2], axis=1)
        return np.einsum("pk,pkj->pj", w, self.triangles[self.rep_triangle])

    @property
    def near_r2(self):
        """(P,) squared distance (m^2) within which the exact form factor is used."""
        r = C.RADIOSITY_NEAR_FACTOR * self.radius
        return np.where(self.emits, r * r, 0.0)

    @property
    def blend_r2(self):
        """(P,) squared distance (m^2) beyond which the far field is used alone.

        Between ``near_r2`` and ``blend_r2`` the exact and the far-field values are blended
        linearly in r^2. 0 for patches that do not emit.
        """
        r = (C.RADIOSITY_NEAR_FACTOR + C.RADIOSITY_NEAR_BLEND) * self.radius
        return np.where(self.emits, r * r, 0.0)

    # ------------------------------------------------------------------ OpenCL upload
    def cl_buffers(self, env, centre):
        """Device buffers (pblk, pplane, tstart, tris), coordinates relative to ``centre``."""
        key = (env.ctx, tuple(np.round(centre, 12)))
        if self._cl is not None and self._cl[0] == key:
            return self._cl[1]
        n = self.n
        nblk = max(1, -(-n // PATCH_LANES))
        ppad = nblk * PATCH_LANES
        rows = np.zeros((8, ppad), np.float64)
        rows[0:3] = 1e4  # padding patches far away, area 0
        rows[0:3, :n] = (self.centroid - centre).T
        rows[3:6, :n] = self.normal.T
        rows[6, :n] = np.where(self.emits, self.area, 0.0)
        rows[7, :n] = self.blend_r2
        pblk = np.ascontiguousarray(
            rows.reshape(8, nblk, PATCH_LANES).transpose(1, 0, 2).astype(np.float32))
        pplane = np.full(ppad, -2, np.int32)
        pplane[:n] = self.plane
        # triangles of each emitting patch, padded to blocks of TRI_LANES
        counts = np.diff(self.tri_start)
        nb = np.where(self.emits, -(-counts // TRI_LANES), 0)
        tstart = np.concatenate([[0], np.cumsum(nb)]).astype(np.int32)
        total = max(1, int(tstart[-1]))
        slot_patch = np.repeat(np.arange(n), nb * TRI_LANES)
        slot_rank = np.arange(len(slot_patch)) - np.repeat(tstart[:-1] * TRI_LANES,
                                                            nb * TRI_LANES)
        real = slot_rank < counts[slot_patch]
        src = np.where(real, self.tri_start[slot_patch] + slot_rank,
                       self.tri_start[slot_patch])
        t = self.triangles[src] - centre
        t[~real] = t[~real][:, :1, :]  # degenerate padding: three equal corners
        tris = np.zeros((total, 9, TRI_LANES), np.float32)
        if len(slot_patch):
            tris[:len(slot_patch) // TRI_LANES] = (
                t.reshape(-1, TRI_LANES, 9).transpose(0, 2, 1))
        bufs = tuple(device_buffer(env, a) for a in (pblk, pplane, tstart, tris))
        self._cl = (key, bufs)
        return bufs


def _grid_cells(plane, centroids, cell, subdiv):
    """Grid cell of triangle centroids on a plane: (patch key, sub-cell key)."""
    uv = plane.to_plane_coords(centroids)
    keys, subkeys = [], []
    counts = []
    for axis in range(2):
        size = float(plane.size[axis])
        k = max(1, int(round(size / cell)))
        step = size / k if size > 0 else 1.0
        i_sub = np.clip(np.floor(uv[:, axis] / (step / subdiv)).astype(np.int64), 0,
                        k * subdiv - 1)
        keys.append(i_sub // subdiv)
        subkeys.append(i_sub)
        counts.append(k)
    key = keys[0] * counts[1] + keys[1]
    subkey = subkeys[0] * (counts[1] * subdiv) + subkeys[1]
    return key, subkey


def default_patch_size(scene, faces):
    """Patch edge (metres) for a room: about RADIOSITY_TARGET_PATCHES patches.

    Never smaller than ``RADIOSITY_MIN_PATCH_M`` nor than the typical triangle
    (``sqrt(2 * median face area)``).
    """
    a = scene.face_areas[faces]
    real = ~scene.face_virtual[faces]
    total = float(a[real].sum()) if real.any() else float(a.sum())
    size = math.sqrt(total / C.RADIOSITY_TARGET_PATCHES)
    return max(size, C.RADIOSITY_MIN_PATCH_M, math.sqrt(2.0 * float(np.median(a))))


# ---------------------------------------------------------------------------- form factors
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


#: luminaires whose near-field pairs are found together (a (block, P) distance array)
NEAR_FIELD_BLOCK = 256


def _near_field_correction(ps, p, n, lums, bvh, occlusion):
    """(P,) lux: for every (luminaire, patch) pair closer than the patch's blend radius,
    the patch's exact mean (flux x the gather's form factor / area) less the point sample,
    both scaled by the luminaire's direct light at the sample over a Lambertian point's.

    Luminaires go in blocks of :data:`NEAR_FIELD_BLOCK`: their pairs, the gather's form
    factors (one (block, P) call) and, for Lambertian point luminaires, the direct light's
    ratio to the point's, which is the pair's visibility (one occlusion test for all pairs
    of the block). Disk luminaires and those with an intensity distribution get their
    direct light one by one as before. One luminaire at a time took 18 ms each (10,000
    luminaires near a ceiling: minutes)."""
    from invrad_wb.core.forward.direct import direct_illuminance
    from invrad_wb.core.geometry.bvh import segments_occluded_numpy
    out = np.zeros(ps.n)
    lums = list(lums)
    for b0 in range(0, len(lums), NEAR_FIELD_BLOCK):
        block = lums[b0:b0 + NEAR_FIELD_BLOCK]
        c = np.array([L.position for L in block], dtype=np.float64).reshape(-1, 3)
        m = np.array([L.normal for L in block], dtype=np.float64).reshape(-1, 3)
        flux = np.array([L.flux_lm for L in block], dtype=np.float64)
        dc = ps.centroid[None, :, :] - c[:, None, :]
        d2c = np.einsum("lpi,lpi->lp", dc, dc)
        li, pj = np.nonzero((d2c < ps.blend_r2[None, :]) & ps.emits[None, :])
        if not len(li):
            continue
        # the Lambertian point emitter's light at the samples
        d = p[pj] - c[li]
        r2 = np.maximum(np.einsum("ij,ij->i", d, d), 1e-24)
        lam = flux[li] * np.maximum(np.einsum("ij,ij->i", d, m[li]), 0.0) * np.maximum(
            -np.einsum("ij,ij->i", d, n[pj]), 0.0) / (np.pi * r2 * r2)
        keep = lam > 0
        li, pj, lam = li[keep], pj[keep], lam[keep]
        if not len(li):
            continue
        ratio = np.ones(len(li))
        simple = np.array([getattr(L, "radius_m", 0.0) <= 0
                           and getattr(L, "photometry", None) is None for L in block])
        pt = simple[li]
        if occlusion and bvh is not None and pt.any():
            idx = np.flatnonzero(pt)
            ratio[idx[segments_occluded_numpy(bvh, c[li[idx]], p[pj[idx]])]] = 0.0
        for k in np.unique(li[~pt]):
            sel = np.flatnonzero(li == k)
            real = direct_illuminance(p[pj[sel]], n[pj[sel]], [block[k]], bvh=bvh,
                                      occlusion=occlusion, backend="numpy")
            ratio[sel] = real / lam[sel]
        # the luminaires as receivers of the gather (reciprocity): exact near, blended
        rows = np.unique(li)
        F = _form_factors_numpy(c[rows], m[rows], np.full(len(rows), -1), ps, None, None)
        f = F[np.searchsorted(rows, li), pj]
        out += np.bincount(pj, weights=ratio * (flux[li] * f / ps.area[pj] - lam),
                           minlength=ps.n)
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
    bufs = ps.cl_buffers(env, centre)
    knl = env.kernel("radiosity", kernel, [f"-D VIS={0 if vis is None else 1}"])
    if vis is None:
        d_vis = device_buffer(env, np.zeros(16, np.uint8))     # not read with VIS=0
    else:
        vpad = np.zeros((n, ppad), np.uint8)
        vpad[:, :n] = vis
        d_vis = device_buffer(env, vpad)
    return centre, nblk, ppad, bufs, knl, d_vis


def _form_factors_opencl(points, normals, point_plane, ps, point_patch, vis, centre=None):
    """Form factors with ``kernels/radiosity.cl`` (float32); see :func:`form_factor_matrix`."""
    env = get_env()
    k, n = len(points), ps.n
    out = np.zeros((k, n), np.float32)
    if k == 0 or n == 0:
        return out
    centre, nblk, ppad, (pblk, pplane, tstart, tris), knl, d_vis = _patch_launch(
        env, ps, vis, centre, "form_factors")
    info = np.zeros((k, 2), np.int32)
    info[:, 0] = point_plane
    if point_patch is not None:
        info[:, 1] = point_patch
    rows = max(1, min(k, (C.RADIOSITY_CL_CHUNK_MB << 20) // (4 * ppad)))
    host = np.empty((rows, ppad), np.float32)
    d_out = device_buffer(env, host, "write")
    for s in range(0, k, rows):
        e = min(k, s + rows)
        c = e - s
        d_pts = device_buffer(env, float4(points[s:e] - centre))
        d_nrm = device_buffer(env, float4(normals[s:e]))
        d_inf = device_buffer(env, info[s:e])
        knl(env.queue, (round_up(c, 8), nblk), None, np.int32(c), np.int32(ppad),
            d_pts, d_nrm, d_inf, pblk, pplane, tstart, tris, d_vis,
            np.float32(C.RAY_EPS_M), np.float32(_inner_ratio()), d_out)
        env.cl.enqueue_copy(env.queue, host[:c], d_out)
        out[s:e] = host[:c, :n]
    return out


register("form_factors", _form_factors_opencl, _form_factors_numpy,
         "point-to-patch form factors, exact near and point far (kernels/radiosity.cl)")


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
    rows = max(1, min(n, (C.RADIOSITY_CL_CHUNK_MB << 20) // (4 * ppad)))
    host = np.empty((rows, ppad), np.float32)
    d_out = device_buffer(env, host, "write")
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


register("patch_form_factors", _patch_form_factors_opencl, _patch_form_factors_numpy,
         "patch-to-patch form factors summed over sub-patch samples (kernels/radiosity.cl)")


# ---------------------------------------------------------------------------- visibility
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


# ---------------------------------------------------------------------------- the model
class _Room:
    """Geometry-only data of one room (patch slice, patches, visibility, patch matrix)."""

    def __init__(self, room, sl, patches, cell):
        self.room = room
        self.sl = sl
        self.patches = patches
        self.cell = cell
        self.centre = patches.centroid.mean(axis=0) if patches.n else np.zeros(3)
        self.vis = None
        self.F = None
        self.blockers = np.zeros(0, dtype=np.int64)


class GatherOperator:
    """Interreflected illuminance at fixed receivers for any patch exitance.

    ``op(B)`` with ``B (P,)`` or ``(P, L)`` (lm/m^2, all patches of the model) returns
    ``(k,)`` or ``(k, L)`` float64 lux: ``E_ind = sum_j F(p -> j) V(patch(p), j) B_j``.
    The per-room blocks of the (k x P) matrix are stored as float32 unless one exceeds
    ``constants.RADIOSITY_GATHER_MAX_MB``; then that block is recomputed in row chunks at
    each call (bounded memory, slower).

    Attributes
    ----------
    n_points : int
    n_patches : int
    """

    def __init__(self, model, points, normals, point_patch):
        self.model = model
        self.n_points = len(points)
        self.n_patches = model.n_patches
        self._blocks = []
        pr = np.where(point_patch >= 0, model.patch_room[np.maximum(point_patch, 0)], -1)
        for room in model.rooms:
            rows = np.flatnonzero((point_patch >= 0) & (pr == room.room))
            if len(rows) == 0:
                continue
            args = (points[rows], normals[rows], point_patch[rows] - room.sl.start)
            nbytes = 4 * len(rows) * room.patches.n
            if nbytes <= C.RADIOSITY_GATHER_MAX_MB << 20:
                mat = np.empty((len(rows), room.patches.n), np.float32)
                for s, blk in self._chunks(room, args):
                    mat[s:s + len(blk)] = blk
                self._blocks.append((rows, room, mat, None))
            else:
                self._blocks.append((rows, room, None, args))

    def _chunks(self, room, args):
        """Yield (first row, form-factor rows) of a block in chunks of bounded memory."""
        pts, nrm, pp = args
        step = max(1, (C.RADIOSITY_CL_CHUNK_MB << 20) // (8 * max(1, room.patches.n)))
        for s in range(0, len(pts), step):
            yield s, self.model._form_factors(room, pts[s:s + step], nrm[s:s + step],
                                              pp[s:s + step])

    def __call__(self, exitance):
        b = np.asarray(exitance, dtype=np.float64)
        if b.shape[0] != self.n_patches:
            raise ValueError(f"exitance has {b.shape[0]} rows for {self.n_patches} patches")
        out = np.zeros((self.n_points,) + b.shape[1:])
        for rows, room, mat, args in self._blocks:
            br = b[room.sl]
            if mat is not None:
                out[rows] = mat @ br.astype(np.float32)
                continue
            for s, blk in self._chunks(room, args):
                out[rows[s:s + len(blk)]] = blk @ br
        return out

    def matrix(self):
        """The dense (k, P) float64 gather matrix (zero between rooms)."""
        out = np.zeros((self.n_points, self.n_patches))
        for rows, room, mat, args in self._blocks:
            if mat is None:
                mat = self.model._form_factors(room, *args)
            out[np.ix_(rows, np.arange(room.sl.start, room.sl.stop))] = mat
        return out


class RadiosityModel:
    """Luminaire-independent radiosity model of a scene (see the module docstring).

    Parameters
    ----------
    scene : Scene
    backend : {'opencl', 'numpy', 'auto'}
    patch_size : float, optional
        Patch edge in metres for all rooms (default: chosen per room).
    occlusion : bool
        Test patch-to-patch visibility through the scene; False: everything visible.

    Attributes
    ----------
    n_patches : int
        P, all rooms together (patches of a room are contiguous).
    face_patch : (m,) int64
        Patch of each face.
    vertex_patch : (n,) int64
        Patch of each vertex (-1 for vertices of no face).
    patch_room, patch_plane : (P,) int64
    patch_area : (P,) float64, m^2
    patch_normal, patch_point, patch_centroid : (P, 3) float64
    patch_reflectance : (P,) float64 (0 for virtual patches)
    room_patch_size : dict room id -> patch edge used (metres)
    timings : dict of seconds: 'patches', 'visibility', 'form_factors', 'vertex_gather'
    n_rays : int
        Visibility segments tested.
    """

    def __init__(self, scene, backend="opencl", patch_size=None, occlusion=True):
        self.backend = check_backend(backend)
        self.scene = scene
        self.occlusion = bool(occlusion)
        if patch_size is not None:
            try:
                patch_size = float(patch_size)
            except (TypeError, ValueError):
                raise SettingsError(f"patch_size must be a number of metres, got"
                                    f" {patch_size!r}")
            if not np.isfinite(patch_size) or patch_size <= 0:
                raise SettingsError(f"patch_size is {patch_size} m: must be > 0")
        self.patch_size = patch_size
        self.timings = {}
        t0 = time.perf_counter()
        self._build_patches(patch_size)
        t1 = time.perf_counter()
        self.timings["patches"] = t1 - t0
        self.n_rays = 0
        if self.occlusion:
            for room in self.rooms:
                room.blockers = self._blocker_faces(room)
                if len(room.blockers) == 0:
                    continue  # a convex room: no segment inside it can be blocked, V = 1
                bvh = BVH(scene.triangles[room.blockers])
                room.vis, nr = patch_visibility(room.patches, bvh, self.backend)
                self.n_rays += nr
        t2 = time.perf_counter()
        self.timings["visibility"] = t2 - t1
        for room in self.rooms:
            room.F = self._patch_matrix(room)
        self.timings["form_factors"] = time.perf_counter() - t2
        self._vertex_op = None

    @classmethod
    def for_scene(cls, scene, backend="opencl", patch_size=None, occlusion=True):
        """The model of ``scene`` for these settings, built once and cached on the scene."""
        backend = check_backend(backend)
        cache = scene.__dict__.setdefault("_radiosity", {})
        try:
            size_key = None if patch_size is None else float(patch_size)
        except (TypeError, ValueError):
            size_key = repr(patch_size)  # refused by the constructor below
        key = (backend, size_key, bool(occlusion))
        model = cache.get(key)
        if model is None:
            model = cls(scene, backend=backend, patch_size=patch_size, occlusion=occlusion)
            cache[key] = model
        return model

    # ------------------------------------------------------------------ construction
    def _build_patches(self, patch_size):
        sc = self.scene
        m = len(sc.faces)
        q = max(1, int(C.RADIOSITY_RECEIVER_SUBDIV))
        face_patch = np.full(m, -1, dtype=np.int64)
        face_sub = np.full(m, -1, dtype=np.int64)
        planes = sc.planes
        cent = sc.face_centroids
        self.rooms = []
        self.room_patch_size = {}
        p_plane, p_normal = [], []
        n_total, s_total = 0, 0
        for r in sc.rooms:
            r = int(r)
            faces = np.flatnonzero(sc.face_room == r)
            cell = patch_size if patch_size is not None else default_patch_size(sc, faces)
            self.room_patch_size[r] = cell
            start = n_total
            for pl in planes:
                if pl.room != r:
                    continue
                key, subkey = _grid_cells(pl, cent[pl.faces], cell, q)
                uk, inv = np.unique(key, return_inverse=True)
                us, sinv = np.unique(subkey, return_inverse=True)
                face_patch[pl.faces] = n_total + inv.reshape(-1)
                face_sub[pl.faces] = s_total + sinv.reshape(-1)
                p_plane.append(np.full(len(uk), pl.index))
                p_normal.append(np.repeat(pl.normal[None], len(uk), 0))
                n_total += len(uk)
                s_total += len(us)
            self.rooms.append((r, slice(start, n_total), faces, cell))
        self.n_patches = n_total
        self.face_patch = face_patch
        self.patch_plane = np.concatenate(p_plane) if p_plane else np.zeros(0, np.int64)
        self.patch_normal = np.concatenate(p_normal) if p_normal else np.zeros((0, 3))
        a = sc.face_areas
        virt = sc.face_virtual
        self.patch_area = np.bincount(face_patch, weights=a, minlength=n_total)
        rho = np.where(virt, 0.0, sc.face_reflectance)
        self.patch_reflectance = (np.bincount(face_patch, weights=a * rho, minlength=n_total)
                                  / np.maximum(self.patch_area, 1e-300))
        self.patch_virtual = np.bincount(face_patch, weights=(~virt).astype(float),
                                         minlength=n_total) == 0
        self.patch_reflectance[self.patch_virtual] = 0.0
        self.patch_room = np.zeros(n_total, dtype=np.int64)
        self.patch_point = np.zeros((n_total, 3))
        self.patch_centroid = np.zeros((n_total, 3))
        tri = sc.triangles
        rooms = []
        for r, sl, faces, cell in self.rooms:
            self.patch_room[sl] = r
            fp = face_patch[faces] - sl.start
            ps = PatchSet(tri[faces], fp, self.patch_plane[sl], self.patch_normal[sl],
                          reflectance=self.patch_reflectance[sl],
                          emits=~self.patch_virtual[sl])
            self.patch_point[sl] = ps.point
            self.patch_centroid[sl] = ps.centroid
            room = _Room(r, sl, ps, cell)
            # receiver samples of the patch matrix: representative points of sub-cells
            fs = face_sub[faces]
            us, sinv = np.unique(fs, return_inverse=True)
            sinv = sinv.reshape(-1)
            s_area, _, s_point, _, s_rep = _cluster_stats(tri[faces], sinv, len(us))
            s_parent = fp[s_rep]
            order = np.argsort(s_parent, kind="stable")
            room.sample_point = s_point[order]
            room.sample_parent = s_parent[order]
            room.sample_weight = (s_area / ps.area[s_parent])[order]
            rooms.append(room)
        self.rooms = rooms
        vp = np.full(len(sc.vertices), -1, dtype=np.int64)
        vp[sc.faces.reshape(-1)] = np.repeat(face_patch, 3)
        self.vertex_patch = vp

    def _blocker_faces(self, room):
        """Faces that can block a segment between two points of the room: (k,) int64.

        The room's *hull planes* are its planes with all its (reflecting) vertices in
        front; the room lies in the convex region H they bound, and so does any segment
        between two of its points. A face can only cross such a segment if it reaches into
        H, i.e. if no hull plane has all its corners behind or on it. That excludes the
        room's own faces on hull planes (walls, floor and ceiling of a box) and the faces
        of rooms beyond them, and keeps pillars, partitions, re-entrant walls and anything
        else inside. A convex room has no blockers at all: its rays need no test. Testing
        against these faces only gives the same answer as the whole scene (rooms must not
        overlap), at a fraction of the cost. Virtual faces never block.
        """
        sc = self.scene
        real = ~sc.face_virtual
        own = (sc.face_room == room.room) & real
        if not own.any():
            return np.zeros(0, dtype=np.int64)
        pts = sc.vertices[np.unique(sc.faces[own])]
        tol = 2.0 * C.PLANE_OFFSET_TOL_M
        cand = np.flatnonzero(real)
        tri = sc.vertices[sc.faces[cand]]
        keep = np.ones(len(cand), dtype=bool)
        for pl in sc.planes:
            if pl.room != room.room or pl.is_virtual:
                continue
            if np.min(pl.signed_distance(pts)) < -tol:
                continue  # not a hull plane: the room reaches behind it
            keep &= np.max(tri @ pl.normal + pl.offset, axis=1) > tol
        return cand[keep]

    def vertex_receivers(self):
        """Receiver points for the scene's vertices: each moved 2 RAY_EPS_M into its faces.

        A vertex at a room corner lies on two other planes at once; stepping it into the
        fan of its faces (towards the mean of their centroids, within its own plane) makes
        its form factors the limit from inside the room.

        Returns
        -------
        points (n, 3) float64 metres, normals (n, 3) float64
        """
        sc = self.scene
        n = len(sc.vertices)
        csum = np.zeros((n, 3))
        corners = sc.faces.reshape(-1)
        cen = np.repeat(sc.face_centroids, 3, axis=0)
        for k in range(3):
            csum[:, k] = np.bincount(corners, weights=cen[:, k], minlength=n)
        cnt = np.bincount(corners, minlength=n)
        d = csum / np.maximum(cnt, 1)[:, None] - sc.vertices
        nrm = sc.vertex_normals
        d -= np.einsum("ij,ij->i", d, nrm)[:, None] * nrm
        length = np.linalg.norm(d, axis=1)
        step = np.where(length > 1e-12, 2.0 * C.RAY_EPS_M / np.maximum(length, 1e-300), 0.0)
        return sc.vertices + step[:, None] * d, nrm

    def _form_factors(self, room, points, normals, local_patch):
        """(k, P_room) form factors x visibility for receivers of one room."""
        ps = room.patches
        return form_factor_matrix(points, normals, ps.plane[local_patch], ps,
                                  point_patch=local_patch, visibility=room.vis,
                                  backend=self.backend, centre=room.centre)

    def _patch_matrix(self, room):
        """(P_room, P_room) float64 patch-to-patch form factors (sub-sample mean)."""
        ps = room.patches
        if ps.n == 0:
            return np.zeros((0, 0))
        par = room.sample_parent
        F = patch_form_factors(room.sample_point, ps.normal[par], ps, par,
                               room.sample_weight, room.vis, self.backend, room.centre)
        F[:, ~ps.emits] = 0.0
        return F

    # ------------------------------------------------------------------ light
    def patch_direct_from_vertices(self, vertex_lux):
        """Area-weighted mean direct illuminance of each patch.

        Parameters
        ----------
        vertex_lux : (n,) or (n, L) float64, lux at the scene's vertices (linear over faces)

        Returns
        -------
        (P,) or (P, L) float64, lux
        """
        v = np.asarray(vertex_lux, dtype=np.float64)
        n = len(self.scene.vertices)
        if v.shape[0] != n:
            raise ValueError(f"{v.shape[0]} vertex values for {n} vertices")
        face_val = v[self.scene.faces].mean(axis=1)
        w = self.scene.face_areas
        inv_area = 1.0 / np.maximum(self.patch_area, 1e-300)
        if face_val.ndim == 1:
            return np.bincount(self.face_patch, weights=w * face_val,
                               minlength=self.n_patches) * inv_area
        return np.stack([np.bincount(self.face_patch, weights=w * face_val[:, c],
                                     minlength=self.n_patches) * inv_area
                         for c in range(face_val.shape[1])], axis=1)

    def patch_direct(self, luminaires, bvh=None, occlusion=True, backend=None):
        """Mean direct illuminance of each patch (P,) lux, from the luminaires themselves.

        Each patch's light is sampled at its representative point, except near a
        luminaire, where the light falls off as 1/r^2 within the patch: there the patch
        gets the luminaire's flux times the exact point-to-polygon form factor (the one the
        gather uses near a patch, blended to the point rule as there) over its area, scaled
        by what the sample says of the luminaire's distribution, emitter and shadow at the
        point (its direct light there over a Lambertian point emitter's). Measured for a
        2000 lm downlight 0.1 m from a wall of a 5 x 4 x 2.5 m box: patch means of vertex
        values put 1515 lm on the surfaces, representative points alone 2543 lm, this 2000.

        A luminaire with a ``room`` lights only the patches of that room (as the direct
        light of :func:`~invrad_wb.core.forward.render.render`).
        """
        from invrad_wb.core.forward.direct import direct_illuminance
        backend = self.backend if backend is None else backend
        occlusion = bool(occlusion) and bvh is not None
        pts, nrm = self.patch_points()
        out = np.zeros(self.n_patches)
        for room in self.rooms:
            lums = [L for L in luminaires if L.room is None or int(L.room) == room.room]
            sl, ps = room.sl, room.patches
            if not lums or ps.n == 0:
                continue
            p, n = pts[sl] + nrm[sl] * 1e-4, nrm[sl]
            out[sl] = direct_illuminance(p, n, lums, bvh=bvh, occlusion=occlusion,
                                         backend=backend)
            out[sl] += _near_field_correction(ps, p, n, lums, bvh, occlusion)
        return out

    def patch_points(self):
        """Representative point (on the surface) and normal of every patch: (P, 3) each."""
        if getattr(self, "_patch_points", None) is None:
            pts = np.zeros((self.n_patches, 3))
            nrm = np.zeros((self.n_patches, 3))
            for room in self.rooms:
                pts[room.sl] = room.patches.point
                nrm[room.sl] = room.patches.normal
            self._patch_points = (pts, nrm)
        return self._patch_points

    def solve(self, patch_direct):
        """Patch exitance from reflection: ``B = rho (E + F B)`` per room (Jacobi).

        Parameters
        ----------
        patch_direct : (P,) or (P, L) float64, lux
            Mean direct illuminance per patch (L independent right-hand sides).

        Returns
        -------
        (P,) or (P, L) float64, lm/m^2. Cost: O(P_room^2 L) per sweep; the number of sweeps
        is kept in ``self.last_iterations``.
        """
        e = np.asarray(patch_direct, dtype=np.float64)
        if e.shape[0] != self.n_patches:
            raise ValueError(f"{e.shape[0]} patch values for {self.n_patches} patches")
        out = np.zeros_like(e)
        self.last_iterations = 0
        for room in self.rooms:
            er = e[room.sl]
            rho = self.patch_reflectance[room.sl]
            if e.ndim == 2:
                rho = rho[:, None]
            b = rho * er
            if not np.any(b):
                continue
            for it in range(1, C.RADIOSITY_MAX_ITER + 1):
                bn = rho * (er + room.F @ b)
                change = float(np.max(np.abs(bn - b)))
                b = bn
                if change <= C.RADIOSITY_TOL * float(np.max(np.abs(b))):
                    break
            else:
                warnings.warn(f"radiosity of room {room.room} did not converge in"
                              f" {C.RADIOSITY_MAX_ITER} iterations (relative change"
                              f" {change / max(float(np.max(np.abs(b))), 1e-300):.2g})",
                              RuntimeWarning)
            self.last_iterations = max(self.last_iterations, it)
            out[room.sl] = b
        return out

    def gather(self, points, normals, point_patch):
        """Operator giving the interreflected illuminance at receivers for any exitance.

        Parameters
        ----------
        points : (k, 3) float64, metres
        normals : (k, 3) float64, unit receiver normals
        point_patch : (k,) int
            Patch each receiver lies on (its room, plane and visibility row); -1: none
            (receives 0).

        Returns
        -------
        GatherOperator
            ``op(B)`` -> (k,) lux for ``B (P,)``; ``op.matrix()`` -> dense (k, P). Building
            it computes the form factors once (k x P_room per room).
        """
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        normals = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
        point_patch = np.asarray(point_patch, dtype=np.int64).reshape(-1)
        if not len(points) == len(normals) == len(point_patch):
            raise ValueError("points, normals and point_patch must have the same length")
        if np.any(point_patch >= self.n_patches):
            raise ValueError(f"point_patch refers to patch {int(point_patch.max())} of"
                             f" {self.n_patches}")
        return GatherOperator(self, points, normals, point_patch)

    def vertex_gather(self):
        """The :class:`GatherOperator` of the scene's vertices (built once)."""
        if self._vertex_op is None:
            t = time.perf_counter()
            pts, nrm = self.vertex_receivers()
            self._vertex_op = self.gather(pts, nrm, self.vertex_patch)
            self.timings["vertex_gather"] = time.perf_counter() - t
        return self._vertex_op

    def indirect_at_vertices(self, vertex_direct):
        """Interreflected illuminance at the scene's vertices.

        Parameters
        ----------
        vertex_direct : (n,) or (n, L) float64, lux (direct illuminance at the vertices)

        Returns
        -------
        (n,) or (n, L) float64, lux
        """
        b = self.solve(self.patch_direct_from_vertices(vertex_direct))
        return self.vertex_gather()(b)

    def __repr__(self):
        return (f"RadiosityModel({self.n_patches} patches in {len(self.rooms)} room(s),"
                f" backend={self.backend!r}, occlusion={self.occlusion})")
