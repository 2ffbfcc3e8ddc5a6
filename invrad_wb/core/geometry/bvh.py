"""Bounding volume hierarchy over the scene's triangles, for occlusion (shadow) tests.

One BVH serves both backends. Leaves hold up to :data:`LEAF` triangles stored as structure
of arrays (``v0, v1, v2`` x/y/z, each a row of ``LEAF`` floats) so that the OpenCL kernel
tests a whole leaf with ``float16`` vector operations (PoCL does not vectorise scalar
kernels; see ENVIRONMENT.md). Padding triangles are degenerate and never hit.

A segment ``p -> q`` is occluded when a triangle crosses it strictly between its ends:
``t in (eps / |q - p|, 1 - eps / |q - p|)`` with ``eps = constants.RAY_EPS_M``, so the
surfaces the ends lie on never count. The ray-triangle test is watertight
(:func:`_tri_hits`): a segment through an edge or vertex that triangles share meets at
least one of them, in float32 (the kernels) as in float64 (here).

Functions here are the numpy side: :func:`segments_occluded_bruteforce` is the obviously
correct reference, :func:`segments_occluded_numpy` the fast numpy twin of the kernel in
``kernels/bvh.h`` (a vectorised breadth-first traversal over (segment, node) pairs). The
BVH on the device (its buffers, as bvh.h reads them) belongs to the kernel family that owns
the traversal: :func:`invrad_wb.core.forward.occlusion.bvh_buffers`.
"""
import numpy as np

from invrad_wb import constants as C

#: Triangles per leaf; must match the vector width used in kernels/bvh.h.
LEAF = 16


class BVH:
    """A flat BVH.

    Attributes
    ----------
    lo, hi : (N, 3) float64
        Node bounds.
    left, right : (N,) int64
        Children of internal nodes (-1 for leaves).
    leaf : (N,) int64
        Leaf block index of leaf nodes (-1 for internal nodes).
    tris : (L, 9, LEAF) float64
        Leaf triangles as SoA rows v0x v0y v0z v1x v1y v1z v2x v2y v2z (the vertices
        themselves, not edges: a shared vertex must be the same numbers in every triangle
        for the watertight test).
    tri_index : (L, LEAF) int64
        Scene face of each leaf slot (-1 for padding).
    """

    def __init__(self, triangles):
        tri = np.asarray(triangles, dtype=np.float64).reshape(-1, 3, 3)
        self.n_triangles = len(tri)
        self.triangles = tri
        cent = tri.mean(axis=1)
        tmin, tmax = tri.min(axis=1), tri.max(axis=1)
        lo, hi, left, right, leaf, blocks = [], [], [], [], [], []
        if len(tri) == 0:
            tmin = tmax = np.zeros((1, 3))
        # iterative build: (node id, index array)
        order = np.arange(len(tri))
        stack = [(self._new(lo, hi, left, right, leaf), order)]
        while stack:
            node, idx = stack.pop()
            if len(idx):
                lo[node] = tmin[idx].min(0)
                hi[node] = tmax[idx].max(0)
            else:
                lo[node] = hi[node] = np.zeros(3)
            if len(idx) <= LEAF:
                leaf[node] = len(blocks)
                blocks.append(idx)
                continue
            c = cent[idx]
            axis = int(np.argmax(c.max(0) - c.min(0)))
            # split at the median, rounded to a multiple of LEAF so leaves stay full
            half = max(LEAF, (len(idx) // 2 + LEAF - 1) // LEAF * LEAF)
            half = min(half, len(idx) - 1)
            part = np.argpartition(c[:, axis], half)
            l_id = self._new(lo, hi, left, right, leaf)
            r_id = self._new(lo, hi, left, right, leaf)
            left[node], right[node] = l_id, r_id
            stack.append((l_id, idx[part[:half]]))
            stack.append((r_id, idx[part[half:]]))
        self.lo = np.array(lo)
        self.hi = np.array(hi)
        self.left = np.array(left, dtype=np.int64)
        self.right = np.array(right, dtype=np.int64)
        self.leaf = np.array(leaf, dtype=np.int64)
        nb = len(blocks)
        self.tris = np.zeros((nb, 9, LEAF))
        self.tri_index = np.full((nb, LEAF), -1, dtype=np.int64)
        for b, idx in enumerate(blocks):
            t = tri[idx]
            k = len(idx)
            self.tris[b, 0:3, :k] = t[:, 0].T
            self.tris[b, 3:6, :k] = t[:, 1].T
            self.tris[b, 6:9, :k] = t[:, 2].T
            self.tri_index[b, :k] = idx

    @staticmethod
    def _new(lo, hi, left, right, leaf):
        lo.append(None)
        hi.append(None)
        left.append(-1)
        right.append(-1)
        leaf.append(-1)
        return len(lo) - 1

    @property
    def n_nodes(self):
        return len(self.lo)


#: metres: a point this close to a triangle's plane counts as on it when culling occluders
#: (:func:`cull_occluders`); float32 coordinates, which the kernels use, resolve about
#: 1e-6 m at 10 m from their origin, so no kernel result depends on a smaller offset
CULL_TOL_M = 1e-6


def _support_points(x):
    """Points of ``x`` (k, 3) whose convex hull is that of ``x`` (or contains it): the
    hull's vertices, the set itself when small, else the corners of its bounding box (a
    flat or straight set, where Qhull has no 3-d hull). Every linear function has its
    extremes over ``x`` at these points (or beyond them, for the box)."""
    x = np.unique(np.asarray(x, dtype=np.float64).reshape(-1, 3), axis=0)
    if len(x) <= 32:
        return x
    try:
        from scipy.spatial import ConvexHull
        return x[ConvexHull(x).vertices]
    except Exception:                       # QhullError: flat or straight input
        lo, hi = x.min(0), x.max(0)
        return np.array([[(lo, hi)[i][0], (lo, hi)[j][1], (lo, hi)[k][2]]
                         for i in (0, 1) for j in (0, 1) for k in (0, 1)])


def occluder_mask(triangles, sources, receivers, tol=CULL_TOL_M):
    """(m,) bool: triangles that can cross a segment from one of ``sources`` to one of
    ``receivers``.

    A triangle crosses a segment strictly between its ends only if its plane separates
    them: one end in front of the plane, the other behind. Per triangle, the sources'
    and the receivers' extreme signed distances to its plane (over their hulls'
    vertices, :func:`_support_points`) say whether any pair is separated; a triangle that
    separates no pair can shadow none of them. In a convex room lit from inside, every
    point lies in front of (or on) every face: nothing is left to test.

    Parameters
    ----------
    triangles : (m, 3, 3) float64, metres
    sources, receivers : (k, 3) float64, metres (segment ends)
    tol : float, metres: ends closer to a plane count as on it (:data:`CULL_TOL_M`)
    """
    tri = np.asarray(triangles, dtype=np.float64).reshape(-1, 3, 3)
    out = np.zeros(len(tri), dtype=bool)
    if not len(tri) or not len(sources) or not len(receivers):
        return out
    s, r = _support_points(sources), _support_points(receivers)
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(n, axis=1)
    real = length > 1e-20                  # degenerate triangles are never hit
    n = n / np.where(real, length, 1.0)[:, None]
    off = np.einsum("ij,ij->i", n, tri[:, 0])
    step = max(1, 4_000_000 // (len(s) + len(r)))
    for a in range(0, len(tri), step):
        b = a + step
        ds = s @ n[a:b].T - off[a:b]       # (|s|, chunk)
        dr = r @ n[a:b].T - off[a:b]
        out[a:b] = real[a:b] & (((ds.max(0) > tol) & (dr.min(0) < -tol))
                                | ((ds.min(0) < -tol) & (dr.max(0) > tol)))
    return out


def cull_occluders(bvh, sources, receivers):
    """The part of ``bvh`` that can shadow a segment from ``sources`` to ``receivers``
    (:func:`occluder_mask`): ``bvh`` itself when most of it can, a BVH of those triangles,
    or None when none can (no shadow test is needed: a convex room). Every segment gets
    the same answer from the result as from ``bvh``.

    Measured (bench/bench_render.py, 10,000 luminaires in a 6 x 4 x 3 m box): the
    luminaires x points shadow rays were 59 of the render's 69 s; the box leaves none."""
    if bvh is None or bvh.n_triangles == 0:
        return None
    mask = occluder_mask(bvh.triangles, sources, receivers)
    k = int(mask.sum())
    if k == 0:
        return None
    if k > bvh.n_triangles // 2:
        return bvh
    return BVH(bvh.triangles[mask])


def _segment_params(p, q, eps):
    d = q - p
    length = np.linalg.norm(d, axis=1)
    safe = np.maximum(length, 1e-30)
    tmin = eps / safe
    tmax = 1.0 - eps / safe
    return d, tmin, tmax


def _tri_hits(o, d, tmin, tmax, v0, v1, v2):
    """Watertight ray-triangle test for paired rays/triangles (all (k, 3)); True where the
    ray ``o + t d`` meets the triangle (edges included) at ``tmin < t < tmax``.

    Woop, Benthin and Wald, "Watertight ray/triangle intersection" (JCGT 2013), as in
    ``kernels/bvh.h``: the vertices are moved into the ray's frame (origin ``o``, the ray's
    largest axis as z, sheared so the ray is that axis) and the 2-d edge functions are
    computed from those images alone, so an edge two triangles share has exactly opposite
    functions in the two: a ray through it meets at least one. Moller-Trumbore (used
    before) let such rays through both (l_room, 0.1 m mesh: 16 % of the rays from one
    light to the vertices behind a wall corner crossed the wall on a mesh edge)."""
    k = len(o)
    ax_ = np.abs(d)
    kz = np.where((ax_[:, 0] >= ax_[:, 1]) & (ax_[:, 0] >= ax_[:, 2]), 0,
                  np.where(ax_[:, 1] >= ax_[:, 2], 1, 2))
    kx = np.where(kz == 2, 0, kz + 1)
    ky = np.where(kx == 2, 0, kx + 1)
    rows = np.arange(k)
    with np.errstate(divide="ignore", invalid="ignore"):
        sz = 1.0 / d[rows, kz]
        sx, sy = d[rows, kx] * sz, d[rows, ky] * sz
        ox, oy, oz = o[rows, kx], o[rows, ky], o[rows, kz]

        def image(v):
            z = v[rows, kz] - oz
            return (v[rows, kx] - ox) - sx * z, (v[rows, ky] - oy) - sy * z, z

        ax, ay, az = image(v0)
        bx, by, bz = image(v1)
        cx, cy, cz = image(v2)
        u = cx * by - cy * bx
        v = ax * cy - ay * cx
        w = bx * ay - by * ax
        det = u + v + w
        t = (u * az + v * bz + w * cz) * sz / det
        inside = (((u >= 0) & (v >= 0) & (w >= 0)) | ((u <= 0) & (v <= 0) & (w <= 0)))
        return inside & (det != 0) & (t > tmin) & (t < tmax)


def segments_occluded_bruteforce(triangles, p, q, eps=C.RAY_EPS_M):
    """Reference: test every segment against every triangle. (k,) bool.

    Parameters
    ----------
    triangles : (m, 3, 3) float64
    p, q : (k, 3) float64, segment ends (metres)
    """
    tri = np.asarray(triangles, dtype=np.float64)
    p = np.asarray(p, dtype=np.float64)
    q = np.asarray(q, dtype=np.float64)
    d, tmin, tmax = _segment_params(p, q, eps)
    out = np.zeros(len(p), dtype=bool)
    v0, v1, v2 = tri[:, 0], tri[:, 1], tri[:, 2]
    for i in range(len(p)):
        k = len(tri)
        out[i] = _tri_hits(np.broadcast_to(p[i], (k, 3)), np.broadcast_to(d[i], (k, 3)),
                           tmin[i], tmax[i], v0, v1, v2).any()
    return out


def segments_occluded_numpy(bvh, p, q, eps=C.RAY_EPS_M, chunk=200_000):
    """Numpy twin of the OpenCL occlusion test: breadth-first BVH traversal. (k,) bool."""
    p = np.asarray(p, dtype=np.float64)
    q = np.asarray(q, dtype=np.float64)
    out = np.zeros(len(p), dtype=bool)
    if bvh.n_triangles == 0 or len(p) == 0:
        return out
    for s in range(0, len(p), chunk):
        out[s:s + chunk] = _occluded_chunk(bvh, p[s:s + chunk], q[s:s + chunk], eps)
    return out


def _occluded_chunk(bvh, p, q, eps):
    d, tmin, tmax = _segment_params(p, q, eps)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / d
    occluded = np.zeros(len(p), dtype=bool)
    ray = np.arange(len(p))
    node = np.zeros(len(p), dtype=np.int64)
    while len(ray):
        # slab test of (ray, node) pairs
        with np.errstate(invalid="ignore"):
            t0 = (bvh.lo[node] - p[ray]) * inv[ray]
            t1 = (bvh.hi[node] - p[ray]) * inv[ray]
        tn = np.fmin(t0, t1)
        tf = np.fmax(t0, t1)
        # axis-parallel rays: inside the slab -> (-inf, inf), outside -> empty
        par = d[ray] == 0
        inside = (p[ray] >= bvh.lo[node]) & (p[ray] <= bvh.hi[node])
        tn = np.where(par, np.where(inside, -np.inf, np.inf), tn)
        tf = np.where(par, np.where(inside, np.inf, -np.inf), tf)
        enter = np.max(tn, axis=1)
        leave = np.min(tf, axis=1)
        hit = (enter <= leave) & (leave >= tmin[ray]) & (enter <= tmax[ray])
        ray, node = ray[hit], node[hit]
        is_leaf = bvh.leaf[node] >= 0
        # leaves: test their triangles
        lr, ln = ray[is_leaf], bvh.leaf[node[is_leaf]]
        if len(lr):
            blk = bvh.tris[ln]  # (k, 9, LEAF)
            k = len(lr)
            o = np.repeat(p[lr], LEAF, axis=0)
            dd = np.repeat(d[lr], LEAF, axis=0)
            v0 = blk[:, 0:3].transpose(0, 2, 1).reshape(-1, 3)
            v1 = blk[:, 3:6].transpose(0, 2, 1).reshape(-1, 3)
            v2 = blk[:, 6:9].transpose(0, 2, 1).reshape(-1, 3)
            h = _tri_hits(o, dd, np.repeat(tmin[lr], LEAF), np.repeat(tmax[lr], LEAF),
                          v0, v1, v2).reshape(k, LEAF).any(axis=1)
            occluded[lr[h]] = True
        # internal nodes: descend into both children, unless the ray is already occluded
        ir, inode = ray[~is_leaf], node[~is_leaf]
        keep = ~occluded[ir]
        ir, inode = ir[keep], inode[keep]
        ray = np.concatenate([ir, ir])
        node = np.concatenate([bvh.left[inode], bvh.right[inode]])
    return occluded
