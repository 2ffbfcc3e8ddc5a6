"""The thesis' vote model: deformed ellipses from the voting table, drawn into the maps.

For every (voting point, map) pair with a weight (thesis 4.2.3, listings 4.3-4.6):

1. declining tests and table lookup (:meth:`VotingTable.lookup`): the maximum of the form
   factor distribution, the ellipse parameters ``a, b, d, x_m, y_m`` at the point's level;
2. the ellipse is sampled at ``K`` points ``P(t) = C + b (cos t + d cos 2t) w + a sin t v``
   (``K`` grows with the ellipse's perimeter so consecutive samples are about half a pixel
   apart, 16 to 1024);
3. each sample is tested for lying on a face of the plane (the map's mask: faces rasterised
   at pixel resolution, equivalent to the thesis' barycentric test at that resolution) and,
   optionally, for occlusion between the point and the sample;
4. consecutive valid samples are joined by a line (DDA, the start pixel not drawn so no
   pixel is drawn twice) adding the weight to every pixel it crosses.

Votes are accumulated in fixed point (1/65536 of a weight unit) with integer atomics on the
device; the numpy twin :func:`cast_ellipse_numpy` does the same arithmetic in float64, so
the two agree except where a sample falls within float32 rounding of a pixel border.
Shade points forbid pixels as in the exact model (:func:`shade_forbidden`).
"""
import numpy as np

from invrad_wb import constants as C
from invrad_wb.core.geometry.bvh import segments_occluded_numpy
from invrad_wb.core.accel.buffers import device_buffer, float4, launch_chunked
from invrad_wb.core.accel.device import get_env
from invrad_wb.core.accel.registry import implementation, register
from invrad_wb.core.forward.occlusion import bvh_buffers
from invrad_wb.core.inverse.table import load_voting_table

FIXED_POINT = 65536.0
K_MIN, K_MAX = 16, 1024


def _frames(canvas, points, pairs_map, pairs_pt):
    """Per pair: h, alpha, foot point, in-plane axes w (minor) and v (major)."""
    normals = np.array([m.normal for m in canvas.maps])[pairs_map]
    offsets = np.array([m.offset for m in canvas.maps])[pairs_map]
    us = np.array([m.u for m in canvas.maps])[pairs_map]
    s = points.positions[pairs_pt]
    m = points.normals[pairs_pt]
    h = np.einsum("ij,ij->i", s, normals) + offsets
    cos_a = np.clip(np.einsum("ij,ij->i", m, normals), -1.0, 1.0)
    alpha = np.arccos(cos_a)
    w = m - cos_a[:, None] * normals
    wl = np.linalg.norm(w, axis=1)
    w = np.where(wl[:, None] > 1e-6, w / np.maximum(wl, 1e-300)[:, None], us)
    v = np.cross(normals, w)
    foot = s - h[:, None] * normals
    return h, alpha, foot, w, v, normals


def ellipse_votes_params(canvas, points, W, vote_lux, flux, table=None):
    """Look up the ellipse of every weighted (map, point) pair.

    Returns
    -------
    dict of arrays per valid pair: map, point, weight, centre (3,), w, v (3,), a, b, d, K
    """
    table = load_voting_table() if table is None else table
    mi, pi = np.nonzero(W > 0)
    h, alpha, foot, w, v, n = _frames(canvas, points, mi, pi)
    ok, x_max, rot, a, b, d, xm, ym = table.lookup(h, alpha, vote_lux[pi] / flux)
    ok &= (a > 0) & (b > 0)
    sel = np.flatnonzero(ok)
    centre = foot[sel] + (x_max[sel] + xm[sel])[:, None] * w[sel] + ym[sel][:, None] * v[sel]
    aa, bb = a[sel], b[sel]
    perimeter = 2 * np.pi * np.sqrt(0.5 * (aa * aa + bb * bb)) * (1 + np.abs(d[sel]))
    K = np.clip(np.ceil(perimeter / (0.5 * canvas.pixel)), K_MIN, K_MAX).astype(np.int64)
    return {"map": mi[sel], "point": pi[sel], "weight": W[mi[sel], pi[sel]].astype(np.float64),
            "centre": centre, "w": w[sel], "v": v[sel], "a": aa, "b": bb, "d": d[sel], "K": K}


def shade_forbidden(canvas, shade, limit_lux, flux, bvh=None, backend="numpy"):
    """(canvas.size,) bool: pixels whose luminaire would give a shade point > limit lux."""
    if shade is None or len(shade) == 0 or limit_lux is None:
        return np.zeros(canvas.size, dtype=bool)
    # the exact-vote machinery with a unit vote everywhere: forbidden pixels come back 0
    probe = _UnitProbe(canvas)
    fn = implementation("votes_exact", backend)
    out = fn(canvas, probe.points, probe.W, probe.lux, flux, bvh=bvh, shade=shade,
             shade_limit_lux=limit_lux, baseline=1.0)
    return canvas.mask_flat() & (out < 0.5)


class _UnitProbe:
    """No voting points: the exact kernel then returns its baseline except where forbidden."""

    def __init__(self, canvas):
        from invrad_wb.core.inverse.sampling import VotingPoints
        z = np.zeros((0, 3))
        self.points = VotingPoints(z, z, np.zeros(0, np.int64), np.zeros(0, np.int64),
                                   z, np.zeros(0), np.zeros(0), 1.0)
        self.W = np.zeros((len(canvas.maps), 0), np.float32)
        self.lux = np.zeros(0)


def cast_ellipse_numpy(canvas, points, W, vote_lux, flux, bvh=None, shade=None,
                       shade_limit_lux=None, table=None):
    """Deformed-ellipse votes, numpy twin of ``kernels/votes_ellipse.cl``.

    Same parameters and result as :func:`invrad_wb.core.inverse.votes.cast_exact_numpy`.
    """
    P = ellipse_votes_params(canvas, points, W, vote_lux, flux, table)
    acc = np.zeros(canvas.size, np.float64)
    n = len(P["K"])
    origins = np.array([m.origin for m in canvas.maps])
    mu = np.array([m.u for m in canvas.maps])
    mv = np.array([m.v for m in canvas.maps])
    shapes = np.array([m.shape for m in canvas.maps])
    starts = np.array([m.start for m in canvas.maps])
    strides = np.array([m.stride for m in canvas.maps])
    mask = canvas.mask_flat()
    pixel = canvas.pixel
    for c0 in range(0, n, 2000):
        sl = slice(c0, min(n, c0 + 2000))
        K = P["K"][sl]
        pair = np.repeat(np.arange(len(K)), K)
        k = np.arange(len(pair)) - np.repeat(np.cumsum(K) - K, K)
        t = 2 * np.pi * k / K[pair]
        a, b, d = P["a"][sl][pair], P["b"][sl][pair], P["d"][sl][pair]
        pos = (P["centre"][sl][pair]
               + (b * (np.cos(t) + d * np.cos(2 * t)))[:, None] * P["w"][sl][pair]
               + (a * np.sin(t))[:, None] * P["v"][sl][pair])
        mp = P["map"][sl][pair]
        rel = pos - origins[mp]
        fi = np.einsum("ij,ij->i", rel, mu[mp]) / pixel
        fj = np.einsum("ij,ij->i", rel, mv[mp]) / pixel
        ii, jj = np.floor(fi).astype(np.int64), np.floor(fj).astype(np.int64)
        inb = (ii >= 0) & (jj >= 0) & (ii < shapes[mp, 0]) & (jj < shapes[mp, 1])
        flat = np.where(inb, starts[mp] + ii * strides[mp] + jj, 0)
        valid = inb & mask[flat]
        if bvh is not None and bvh.n_triangles:
            idx = np.flatnonzero(valid)
            pt = P["point"][sl][pair[idx]]
            s = points.positions[pt] + points.normals[pt] * C.RAY_EPS_M
            q = pos[idx] + np.array([m.normal for m in canvas.maps])[mp[idx]] * C.RAY_EPS_M
            valid[idx[segments_occluded_numpy(bvh, s, q)]] = False
        # segments from sample k to k+1 (cyclic) when both ends are valid
        nxt = np.arange(len(pair)) + 1
        last = np.cumsum(K) - 1
        nxt[last] = last - K + 1
        seg = np.flatnonzero(valid & valid[nxt])
        i0, j0 = fi[seg], fj[seg]
        i1, j1 = fi[nxt[seg]], fj[nxt[seg]]
        pi0, pj0 = np.floor(i0), np.floor(j0)
        pi1, pj1 = np.floor(i1), np.floor(j1)
        steps = np.maximum(np.abs(pi1 - pi0), np.abs(pj1 - pj0)).astype(np.int64)
        has = steps > 0
        seg, steps = seg[has], steps[has]
        pi0, pj0, pi1, pj1 = pi0[has], pj0[has], pi1[has], pj1[has]
        rep = np.repeat(np.arange(len(seg)), steps)
        kk = (np.arange(len(rep)) - np.repeat(np.cumsum(steps) - steps, steps) + 1).astype(np.float64)
        frac = kk / steps[rep]
        li = np.floor(pi0[rep] + (pi1[rep] - pi0[rep]) * frac + 0.5).astype(np.int64)
        lj = np.floor(pj0[rep] + (pj1[rep] - pj0[rep]) * frac + 0.5).astype(np.int64)
        smap = mp[seg][rep]
        li = np.clip(li, 0, shapes[smap, 0] - 1)
        lj = np.clip(lj, 0, shapes[smap, 1] - 1)
        wq = np.round(P["weight"][sl][pair[seg]][rep] * FIXED_POINT) / FIXED_POINT
        np.add.at(acc, starts[smap] + li * strides[smap] + lj, wq)
    acc[~mask] = 0.0
    if shade is not None and len(shade) and shade_limit_lux is not None:
        acc[shade_forbidden(canvas, shade, shade_limit_lux, flux, bvh, "numpy")] = 0.0
    return acc.astype(np.float32)


def cast_ellipse_opencl(canvas, points, W, vote_lux, flux, bvh=None, shade=None,
                        shade_limit_lux=None, table=None):
    """Deformed-ellipse votes on the OpenCL device (``kernels/votes_ellipse.cl``)."""
    env = get_env()
    P = ellipse_votes_params(canvas, points, W, vote_lux, flux, table)
    n = len(P["K"])
    out = np.zeros(canvas.size, np.uint32)
    if n == 0 or canvas.size == 0:
        return out.astype(np.float32)
    occlusion = bvh is not None and bvh.n_triangles > 0
    knl = env.kernel("votes_ellipse", "ellipse_votes", [f"-D OCCLUSION={int(occlusion)}"])

    f4 = float4

    def buf(a):
        return device_buffer(env, a)

    maps = canvas.maps
    m_origin = f4(np.array([m.origin for m in maps]))
    m_u = f4(np.array([m.u for m in maps]))
    m_v = f4(np.array([m.v for m in maps]))
    m_n = f4(np.array([m.normal for m in maps]))
    m_info = np.array([[m.start, m.stride, m.shape[0], m.shape[1]] for m in maps], np.int32)
    mask = canvas.mask_flat().astype(np.uint8)
    ell_c = f4(P["centre"], P["weight"] * FIXED_POINT)
    ell_w = f4(P["w"], P["a"])
    ell_v = f4(P["v"], P["b"])
    ell_i = np.stack([P["map"], P["point"], P["K"], np.zeros(n, np.int64)], 1).astype(np.int32)
    ell_d = P["d"].astype(np.float32)
    bvh_bufs = bvh_buffers(env, bvh if occlusion else None)
    d_out = device_buffer(env, out, "readwrite")          # the kernel adds to zeros
    launch_chunked(env, knl, n,
                   (buf(ell_c), buf(ell_w), buf(ell_v), buf(ell_i), buf(ell_d), buf(m_origin),
                    buf(m_u), buf(m_v), buf(m_n), buf(m_info), buf(mask),
                    np.float32(canvas.pixel), buf(f4(points.positions)),
                    buf(f4(points.normals)), np.float32(C.RAY_EPS_M)), (*bvh_bufs, d_out),
                   C.CL_CHUNK_ELLIPSES, local=32)
    env.cl.enqueue_copy(env.queue, out, d_out)
    acc = out.astype(np.float64) / FIXED_POINT
    if shade is not None and len(shade) and shade_limit_lux is not None:
        acc[shade_forbidden(canvas, shade, shade_limit_lux, flux, bvh, "opencl")] = 0.0
    return acc.astype(np.float32)


def cast_ellipse(canvas, points, W, vote_lux, flux, bvh=None, shade=None,
                 shade_limit_lux=None, backend="opencl"):
    fn = implementation("votes_ellipse", backend)
    return fn(canvas, points, W, vote_lux, flux, bvh=bvh, shade=shade,
              shade_limit_lux=shade_limit_lux)


register("votes_ellipse", cast_ellipse_opencl, cast_ellipse_numpy,
         "the thesis' deformed-ellipse votes from the voting table"
         " (kernels/votes_ellipse.cl)")
