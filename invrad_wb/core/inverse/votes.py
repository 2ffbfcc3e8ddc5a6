"""Vote casting: voting points vote for the luminaire positions that explain their light.

A point ``s`` with normal ``m`` and vote illuminance ``E`` votes, on every map (plane or
dummy plane, luminaire normal ``n``), for the contour of candidate positions ``c`` where a
lambertian luminaire of flux ``F`` gives exactly ``E`` (thesis 3.2.5). Two vote models:

* ``exact``: the true iso-illuminance contour evaluated per pixel (``kernels/votes_exact.cl``
  and :func:`cast_exact_numpy`); no ellipse-fit error, any plane orientation.
* ``ellipse``: the thesis' deformed ellipse from the precomputed voting table, sampled and
  rasterised (:mod:`invrad_wb.core.inverse.votes_ellipse`).

Weights per (map, point), :func:`vote_weights`: the declining tests of thesis 4.2.3 (no
vote to the point's own plane, to planes it lies behind, from points with no light), the
weighting option (``illumination``: E / E_max; ``distance``: the normalised form factor,
i.e. the maximum a luminaire on that map can give the point relative to the best map;
``both``; ``none``) and the vote strength.
"""
import numpy as np

from invrad_wb import constants as C
from invrad_wb.errors import SettingsError
from invrad_wb.core.geometry.bvh import segments_occluded_numpy
from invrad_wb.core.accel.buffers import device_buffer, float4, launch_chunked
from invrad_wb.core.accel.device import get_env
from invrad_wb.core.accel.registry import implementation, register
from invrad_wb.core.forward.occlusion import bvh_buffers
from invrad_wb.core.inverse.formfactor import _g1, _x_max_unit

WEIGHTINGS = ("illumination", "distance", "both", "none")


def emax_per_lumen(h, cos_alpha):
    """Maximum illuminance per lumen a luminaire on a plane can give a point (closed form).

    The point lies ``h`` metres in front of the plane and its normal makes the angle alpha
    with the luminaire normal (see :func:`invrad_wb.core.inverse.formfactor.maximum_closed_form`).

    Returns
    -------
    e_max : array, lux per lumen
    x_max : array, metres from the foot point towards where the receiver faces
    """
    alpha = np.arccos(np.clip(np.asarray(cos_alpha, dtype=np.float64), -1.0, 1.0))
    h = np.maximum(np.asarray(h, dtype=np.float64), 1e-300)
    with np.errstate(divide="ignore", invalid="ignore"):
        X = np.where(alpha > 1e-9, _x_max_unit(np.maximum(alpha, 1e-9)), 0.0)
        e = np.maximum(_g1(np.cos(alpha), np.sin(alpha), X, 0.0), 0.0)
    e = np.where(np.isfinite(e), e, 0.0)
    return e / (h * h), np.where(np.isfinite(X), X, 0.0) * h


def vote_weights(canvas, points, vote_lux, weighting="illumination", strength=1.0):
    """Per (map, point) vote weights, 0 where a vote is declined.

    Parameters
    ----------
    canvas : VoteCanvas
    points : VotingPoints
    vote_lux : (k,) float64
        Illuminance each point votes with (its target minus the ambient estimate), lux.
    weighting : {'illumination', 'distance', 'both', 'none'}
    strength : float
        Basic weight of each vote.

    Returns
    -------
    (n_maps, k) float32
    """
    if weighting not in WEIGHTINGS:
        raise SettingsError(f"weighting must be one of {WEIGHTINGS}, got {weighting!r}")
    if not np.isfinite(strength) or strength <= 0:
        raise SettingsError(f"vote strength must be > 0, got {strength!r}")
    nm, k = len(canvas.maps), len(points)
    W = np.zeros((nm, k))
    if nm == 0 or k == 0:
        return W.astype(np.float32)
    normals = np.array([m.normal for m in canvas.maps])
    offsets = np.array([m.offset for m in canvas.maps])
    h = normals @ points.positions.T + offsets[:, None]          # (maps, k) metres in front
    cos_a = normals @ points.normals.T                            # (maps, k)
    emax, _ = emax_per_lumen(np.maximum(h, 1e-9), cos_a)
    ok = (h > 1e-3) & (cos_a < 1.0 - 1e-6) & (emax > 0)
    ok &= (vote_lux > 0)[None, :]
    own = np.array([m.plane for m in canvas.maps])[:, None] == points.plane[None, :]
    ok &= ~own
    W[ok] = strength
    if weighting in ("illumination", "both"):
        W *= (vote_lux / max(float(np.max(vote_lux)), 1e-12))[None, :]
    if weighting in ("distance", "both"):
        em = np.where(ok, emax, 0.0)
        best = em.max(axis=0, keepdims=True)
        W *= np.where(best > 0, em / np.maximum(best, 1e-300), 0.0)
    return W.astype(np.float32)


#: the vote profile's table: gamma = 0, 0.25, ... 180 degrees (the photometry's 1 degree
#: intensities interpolated linearly: ln p and its slope are steep near a cut-off)
PROFILE_STEP_DEG = 0.25
#: below this share of its peak a distribution counts as dark there (no contour, no vote)
PROFILE_DARK = 1e-4


def vote_profile(photometry):
    """The distribution votes use, (721, 2) float32: per gamma (0..180 degrees,
    :data:`PROFILE_STEP_DEG` apart) ``ln p`` and ``w``, or None for lambertian.

    ``p(gamma)``, cd/lm, is the intensity averaged over the C planes: at vote time a
    candidate's rotation about its normal is not known (the refinement uses the full
    I(C, gamma)). A luminaire of flux F at c gives a point s ``F p(gamma) cos(beta) / r^2``
    (``cos gamma = A / r``), so ``ln e = ln p + ln B - 3 ln r`` and
    ``grad ln e = w (n / r + A d / r^3) + m / B - 3 d / r^2`` with
    ``w = (d ln p / d gamma) / sin gamma`` (lambertian: ``w = -1 / cos gamma``, which gives
    the lambertian gradient). Where ``p`` is below :data:`PROFILE_DARK` of its peak,
    ``ln p`` is -1e30: no vote.
    """
    if photometry is None:
        return None
    p1 = np.asarray(photometry.table, dtype=np.float64)[:-1].mean(axis=0)    # C 0..359
    deg = np.arange(0.0, 180.0 + 1e-9, PROFILE_STEP_DEG)
    p = np.interp(deg, np.arange(len(p1)) * 180.0 / (len(p1) - 1), p1)
    g = np.radians(deg)
    dark = p < PROFILE_DARK * p.max()
    lnp = np.log(np.maximum(p, 1e-300))
    q = np.gradient(lnp, g)
    with np.errstate(divide="ignore", invalid="ignore"):
        w = q / np.sin(g)
    w[0] = w[1]
    w[-1] = w[-2]
    w = np.where(dark | ~np.isfinite(w), 0.0, w)
    lnp = np.where(dark, -1e30, lnp)
    return np.stack([lnp, w], axis=1).astype(np.float32)


def _profile_at(profile, cos_g):
    """(ln p, w) at cos gamma, linear in gamma between the table's degrees."""
    f = np.degrees(np.arccos(np.clip(cos_g, -1.0, 1.0))) / PROFILE_STEP_DEG
    i = np.minimum(f.astype(np.int64), len(profile) - 2)
    t = f - i
    lo, hi = profile[i].astype(np.float64), profile[i + 1].astype(np.float64)
    return lo[..., 0] + t * (hi[..., 0] - lo[..., 0]), lo[..., 1] + t * (hi[..., 1] - lo[..., 1])


def _tent_numpy(c, n, s, m, lnE, w, pixel, profile=None):
    """Exact-vote tent weights for candidates c (p, 3) and points s (k, 3): (p, k)."""
    d = c[:, None, :] - s[None, :, :]
    A = -(d @ n)
    B = np.einsum("pkc,kc->pk", d, m)
    r2 = np.einsum("pkc,pkc->pk", d, d)
    ok = (A > 1e-6) & (B > 1e-6)
    Ac = np.where(ok, A, 1.0)
    Bc = np.where(ok, B, 1.0)
    if profile is None:
        lne = np.log(Ac * Bc / (r2 * r2)) - np.log(np.pi)
        g = (-n[None, None, :] / Ac[..., None] + m[None, :, :] / Bc[..., None]
             - 4.0 * d / r2[..., None])
    else:
        r = np.sqrt(r2)
        lnp, wp = _profile_at(profile, Ac / r)
        ok &= lnp > -1e29
        lne = lnp + np.log(Bc) - 1.5 * np.log(r2)
        g = (wp[..., None] * (n[None, None, :] / r[..., None] + Ac[..., None] * d
                              / (r2 * r)[..., None])
             + m[None, :, :] / Bc[..., None] - 3.0 * d / r2[..., None])
    L = lne - lnE[None, :]
    g = g - (g @ n)[..., None] * n
    gt = np.linalg.norm(g, axis=2)
    delta = np.abs(L) / np.maximum(gt, 1e-12)
    tent = np.maximum(1.0 - delta / pixel, 0.0) * w[None, :]
    return np.where(ok, tent, 0.0), np.where(ok, lne, -np.inf)


def cast_exact_numpy(canvas, points, W, vote_lux, flux, bvh=None, shade=None,
                     shade_limit_lux=None, baseline=0.0, chunk_pairs=2_000_000, profile=None):
    """Exact votes, numpy twin of ``kernels/votes_exact.cl``.

    Parameters
    ----------
    canvas : VoteCanvas
    points : VotingPoints
    W : (n_maps, k) float32 weights from :func:`vote_weights`
    vote_lux : (k,) float64, lux
    flux : float, lumens of the luminaire searched for
    bvh : BVH, optional
        Occluders; votes whose segment is blocked are dropped.
    shade : VotingPoints, optional
        Points that must stay dark; pixels whose luminaire would give any of them more than
        ``shade_limit_lux`` (unoccluded) get no votes.
    baseline : float
        Added to every pixel before shade forbids it (1 gives the allowed-pixel mask).
    profile : (721, 2) float32, optional
        :func:`vote_profile` of the luminaires' distribution (None: lambertian).

    Returns
    -------
    (canvas.size,) float32 flat vote buffer
    """
    out = np.zeros(canvas.size, np.float32)
    views = canvas.split(out)
    with np.errstate(divide="ignore"):
        lnE = np.log(np.maximum(vote_lux, 1e-30) / flux)
    for mi, (mp, view) in enumerate(zip(canvas.maps, views)):
        active = np.flatnonzero(W[mi] > 0)
        cent = mp.pixel_centres().reshape(-1, 3)
        acc = np.full(len(cent), float(baseline))
        if len(active):
            s, m = points.positions[active], points.normals[active]
            step = max(1, chunk_pairs // len(active))
            for a in range(0, len(cent), step):
                c = cent[a:a + step]
                tent, _ = _tent_numpy(c, mp.normal, s, m, lnE[active],
                                      W[mi, active].astype(np.float64), mp.pixel, profile)
                if bvh is not None:
                    pi, ki = np.nonzero(tent > 0)
                    if len(pi):
                        occ = segments_occluded_numpy(
                            bvh, s[ki] + m[ki] * C.RAY_EPS_M,
                            c[pi] + mp.normal * C.RAY_EPS_M)
                        tent[pi[occ], ki[occ]] = 0.0
                acc[a:a + step] += tent.sum(axis=1)
        if shade is not None and len(shade) and shade_limit_lux is not None:
            ln_lim = np.log(shade_limit_lux / flux)
            forbid = np.zeros(len(cent), dtype=bool)
            step = max(1, chunk_pairs // len(shade))
            for a in range(0, len(cent), step):
                c = cent[a:a + step]
                _, lne = _tent_numpy(c, mp.normal, shade.positions, shade.normals,
                                     np.zeros(len(shade)), np.ones(len(shade)), mp.pixel,
                                     profile)
                hot = lne > ln_lim
                if bvh is not None:
                    pi, ki = np.nonzero(hot)
                    if len(pi):
                        occ = segments_occluded_numpy(
                            bvh, shade.positions[ki] + shade.normals[ki] * C.RAY_EPS_M,
                            c[pi] + mp.normal * C.RAY_EPS_M)
                        hot[pi[occ], ki[occ]] = False
                forbid[a:a + step] = hot.any(axis=1)
            acc[forbid] = 0.0
        view[...] = np.where(mp.mask, acc.reshape(mp.shape), 0.0)
    return out



def canvas_device_arrays(canvas):
    """Per-map arrays and 16-pixel work blocks for the vote kernels."""
    maps = canvas.maps
    origin = float4([m.origin for m in maps])
    u = float4([m.u for m in maps])
    v = float4([m.v for m in maps])
    n = float4([m.normal for m in maps], [m.offset for m in maps])
    info = np.array([[m.start, m.stride, m.shape[1], m.shape[0]] for m in maps], np.int32)
    blocks = []
    for mi, m in enumerate(maps):
        nu, nv = m.shape
        i, j = np.meshgrid(np.arange(nu), np.arange(0, m.stride, 16), indexing="ij")
        # skip blocks whose 16 pixels are all masked out
        mk = np.zeros((nu, m.stride), bool)
        mk[:, :nv] = m.mask
        keep = mk.reshape(nu, m.stride // 16, 16).any(axis=2).reshape(-1)
        b = np.stack([np.full(i.size, mi), i.reshape(-1), j.reshape(-1),
                      np.zeros(i.size, int)], axis=1)[keep]
        blocks.append(b)
    blocks = np.concatenate(blocks).astype(np.int32) if blocks else np.zeros((0, 4), np.int32)
    return origin, u, v, n, info, blocks


def cast_exact_opencl(canvas, points, W, vote_lux, flux, bvh=None, shade=None,
                      shade_limit_lux=None, baseline=0.0, profile=None):
    """Exact votes on the OpenCL device; same contract as :func:`cast_exact_numpy`."""
    env = get_env()
    out = np.zeros(canvas.size, np.float32)
    if canvas.size == 0 or (len(points) == 0 and baseline == 0):
        return out
    occlusion = bvh is not None and bvh.n_triangles > 0
    use_shade = shade is not None and len(shade) > 0 and shade_limit_lux is not None
    knl = env.kernel("votes_exact", "exact_votes",
                     [f"-D OCCLUSION={int(occlusion)}", f"-D SHADE={int(use_shade)}",
                      f"-D PROFILE={int(profile is not None)}",
                      f"-D PROFILE_STEP={PROFILE_STEP_DEG!r}f"])
    prof = (np.zeros((2, 2), np.float32) if profile is None
            else np.ascontiguousarray(profile, np.float32))
    origin, u, v, n, info, blocks = canvas_device_arrays(canvas)
    with np.errstate(divide="ignore"):
        lnE = np.log(np.maximum(vote_lux, 1e-30) / flux)

    def buf(a):
        return device_buffer(env, a)

    bvh_bufs = bvh_buffers(env, bvh if occlusion else None)
    if use_shade:
        sp, sn = float4(shade.positions), float4(shade.normals)
        ln_lim = float(np.log(shade_limit_lux / flux))
        ns = len(shade)
    else:
        sp = sn = np.zeros((1, 4), np.float32)
        ln_lim, ns = 0.0, 0
    d_out = device_buffer(env, out, "readwrite")          # the kernel adds to zeros
    nb = len(blocks)
    launch_chunked(env, knl, nb,
                   (buf(blocks), buf(origin), buf(u), buf(v), buf(n), buf(info),
                    np.float32(canvas.pixel), np.int32(len(points)),
                    buf(float4(points.positions, lnE)), buf(float4(points.normals)),
                    buf(np.ascontiguousarray(W, np.float32)), np.int32(ns), buf(sp), buf(sn),
                    np.float32(ln_lim), np.float32(C.RAY_EPS_M), np.float32(baseline),
                    buf(prof), np.int32(len(prof))),
                   (*bvh_bufs, d_out),
                   max(32, C.CL_CHUNK_VOTE_PAIRS // max(1, len(points) + ns)), local=32)
    env.cl.enqueue_copy(env.queue, out, d_out)
    # blocks skipped as fully masked stay 0; masked pixels inside blocks are zeroed here
    out[~canvas.mask_flat()] = 0.0
    return out


register("votes_exact", cast_exact_opencl, cast_exact_numpy,
         "exact votes: iso-illuminance contours per voting point (kernels/votes_exact.cl)")


def cast_exact(canvas, points, W, vote_lux, flux, backend="auto", **kwargs):
    """Exact votes on the backend chosen once (see :func:`cast_exact_numpy`)."""
    return implementation("votes_exact", backend)(canvas, points, W, vote_lux, flux,
                                                  **kwargs)
