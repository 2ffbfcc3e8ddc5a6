"""Radiosity patches: each plane's triangles clustered on a grid in the plane's (u, v)
basis, with their area, centroid, representative point, radius and reflectance
(:class:`PatchSet`), and the default patch size of a room. The method is described in
:mod:`invrad_wb.core.forward.radiosity`; the device upload of a patch set belongs to its
kernels (:func:`invrad_wb.core.forward.form_factors.patch_buffers`).
"""
import math

import numpy as np

from invrad_wb import constants as C


#: :func:`_cluster_stats`: triangles per block of its per-triangle temporaries (the corner
#: distances' (T, 3, 3) arrays held whole took about 250 bytes a triangle above the
#: triangles themselves: +1.2 GB building the radiosity patches of a 1.75 million-face room)
CLUSTER_STATS_BLOCK = 1 << 18


def _cluster_stats(tri, tri_cluster, n, block=CLUSTER_STATS_BLOCK):
    """Area, area centroid, representative point and radius of clusters of triangles.

    Parameters
    ----------
    tri : (T, 3, 3) float64
    tri_cluster : (T,) int64 in [0, n)
    block : per-triangle values are computed ``block`` triangles at a time (bounded
        temporaries; each value is the same, element by element, as computed whole)

    Returns
    -------
    area (n,), centroid (n, 3), point (n, 3), radius (n,), rep (n,) int64 (the triangle
    whose centroid is the representative point).
    """
    T = len(tri)
    block = max(1, int(block))
    a = np.empty(T)
    cen = np.empty((T, 3))
    for s in range(0, T, block):
        t = tri[s:s + block]
        a[s:s + block] = 0.5 * np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]),
                                              axis=1)
        cen[s:s + block] = t.mean(axis=1)
    area = np.bincount(tri_cluster, weights=a, minlength=n)
    centroid = np.stack([np.bincount(tri_cluster, weights=a * cen[:, k], minlength=n)
                         for k in range(3)], axis=1) / np.maximum(area, 1e-300)[:, None]
    dist = np.empty(T)
    corner = np.empty(T)
    for s in range(0, T, block):
        c = centroid[tri_cluster[s:s + block]]
        dist[s:s + block] = np.linalg.norm(cen[s:s + block] - c, axis=1)
        corner[s:s + block] = np.linalg.norm(tri[s:s + block] - c[:, None, :],
                                             axis=2).max(axis=1)
    order = np.lexsort((dist, tri_cluster))
    first = np.ones(len(order), dtype=bool)
    first[1:] = tri_cluster[order[1:]] != tri_cluster[order[:-1]]
    rep = np.zeros(n, dtype=np.int64)
    rep[tri_cluster[order[first]]] = order[first]
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
