"""Direct illuminance at receiver points from lambertian luminaires, with occlusion.

``E = sum_k F_k * cos(theta_l) * cos(theta_s) / (pi * r^2) * V`` over the emitter samples of
:func:`invrad_wb.core.model.luminaires.emitter_samples` (one per point luminaire, a quadrature per
disk). Two implementations with one signature: :func:`direct_illuminance_numpy` (the twin)
and :func:`direct_illuminance_opencl` (``kernels/direct.cl``). Luminaires with an intensity
distribution: ``E = F_k * I_k(C, gamma) * cos(theta_s) / r^2 * V``, the kernel
:func:`photometric_opencl` (``kernels/photometric.cl``) and its twin
:func:`photometric_numpy`.
"""
import numpy as np

from invrad_wb import constants as C
from invrad_wb.core.geometry.bvh import BVH, cull_occluders, segments_occluded_numpy
from invrad_wb.core.accel.buffers import device_buffer, float4, launch_chunked
from invrad_wb.core.accel.device import get_env
from invrad_wb.core.accel.registry import implementation, register
from invrad_wb.core.forward.occlusion import bvh_buffers
from invrad_wb.core.model.luminaires import emitter_samples


def _geometry(points, normals, c, n, flux):
    r = points - c
    r2 = np.einsum("ij,ij->i", r, r)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv_r = 1.0 / np.sqrt(r2)
        cl = (r @ n) * inv_r
        cs = -np.einsum("ij,ij->i", normals, r) * inv_r
        g = flux * cl * cs / (np.pi * r2)
    ok = (r2 >= 1e-12) & (cl > 0) & (cs > 0)
    return np.where(ok, g, 0.0), ok


#: (luminaire, point) pairs per block of :func:`photometric_numpy` (a few MB of float64
#: temporaries: they stay in the CPU's caches; 1 << 20 pairs was 1.4 times slower)
PHOTOMETRIC_BLOCK_PAIRS = 1 << 16


#: shadow rays of :func:`photometric_numpy` traced at once (the lit pairs of several blocks
#: gathered: one OpenCL launch per block of 65,536 pairs spent more on the launch than on
#: the rays); about 100 bytes a ray while they wait
SHADOW_BATCH_PAIRS = 1 << 19


def photometric_numpy(points, normals, luminaires, bvh=None, occlusion=True,
                      occluded=segments_occluded_numpy):
    """Direct illuminance of luminaires with an intensity distribution (numpy), lux:
    ``E = I(direction) * cos(theta_s) / r^2`` with ``I = flux * photometry(direction)``
    in the luminaire's frame (:mod:`invrad_wb.core.model.photometry`; its C = 0 axis is
    the luminaire's ``c0`` where it has one: an aimed spot, :mod:`invrad_wb.core.model.
    aiming`); disk luminaires are taken at their centre.

    Luminaires go in blocks of about :data:`PHOTOMETRIC_BLOCK_PAIRS` (luminaire, point)
    pairs (:func:`photometric_pairs`); one at a time took 7 s for 1000 luminaires on
    11,000 points here. ``occluded(bvh, p, q)`` traces the shadow rays (numpy by
    default). The numpy twin of :func:`photometric_opencl`."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    normals = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    out = np.zeros(len(points))
    lums = list(luminaires)
    if not lums or not len(points):
        return out
    pos = np.array([lum.position for lum in lums], dtype=np.float64).reshape(-1, 3)
    axis = np.array([lum.normal for lum in lums], dtype=np.float64).reshape(-1, 3)
    cones = {}
    for lum in lums:
        if id(lum.photometry) not in cones:
            cones[id(lum.photometry)] = _cone_cos(lum.photometry)
    cone = np.array([cones[id(lum.photometry)] for lum in lums])
    per = max(1, PHOTOMETRIC_BLOCK_PAIRS // len(points))
    pp = np.einsum("ij,ij->i", points, points)
    pn = np.einsum("ij,ij->i", points, normals)
    shadows = occlusion and bvh is not None
    pending = []                              # lit pairs waiting for their shadow rays

    def trace():
        pj, lk, g = (np.concatenate(x) for x in zip(*pending))
        pending.clear()
        g[occluded(bvh, pos[lk], points[pj])] = 0.0
        return np.bincount(pj, weights=g, minlength=len(points))

    for b0 in range(0, len(lums), per):
        b1 = min(len(lums), b0 + per)
        # the pairs in front of the point and inside the luminaire's cone of light, found
        # on (block, points) arrays by matrix products (no (block, points, 3) array: 4.4
        # times faster); the rest (lookups, shadows) for those pairs only. The products
        # round differently from r = p - c, so each test keeps a margin: a superset of the
        # pairs, which photometric_pairs tests exactly (the result is unchanged)
        c = pos[b0:b1]
        r2 = pp[None, :] + np.einsum("bi,bi->b", c, c)[:, None] - 2.0 * (c @ points.T)
        rn = pn[None, :] - c @ normals.T
        ra = axis[b0:b1] @ points.T - np.einsum("bi,bi->b", c, axis[b0:b1])[:, None]
        with np.errstate(divide="ignore", invalid="ignore"):
            lit = ((r2 > 1e-13) & (rn < 1e-9)
                   & (ra >= (cone[b0:b1, None] - 1e-9) * np.sqrt(np.maximum(r2, 0.0)) - 1e-9))
        li, pj = np.nonzero(lit)
        if len(li):
            g = photometric_pairs(points[pj], normals[pj], lums[b0:b1], li, occlusion=False)
            if not shadows:
                out += np.bincount(pj, weights=g, minlength=len(points))
                continue
            keep = g > 0                      # outside the distribution's cone: no ray
            pending.append((pj[keep], li[keep] + b0, g[keep]))
            if sum(len(x[0]) for x in pending) >= SHADOW_BATCH_PAIRS:
                out += trace()
    if pending:
        out += trace()
    return out


def _cone_cos(phot):
    """cos of the largest gamma at which ``phot`` has light (with the table's 1 degree
    interpolation step beyond it): directions further from the axis get none."""
    lit = np.flatnonzero(phot.table.any(axis=0))
    if not len(lit):
        return 2.0
    g = min(180.0, float(lit.max()) + 1.0)
    return float(np.cos(np.radians(g))) - 1e-12 if g < 180.0 else -2.0


def photometric_pairs(points, normals, luminaires, owner, bvh=None, occlusion=True,
                      occluded=segments_occluded_numpy):
    """Direct illuminance (lux) of luminaire ``luminaires[owner[k]]`` (with an intensity
    distribution) at ``points[k]``, for (luminaire, point) pairs.

    Parameters
    ----------
    points, normals : (k, 3) float64, metres / unit receiver normals
    luminaires : list of Luminaire with a photometry
    owner : (k,) int64, index into ``luminaires`` of each pair
    occluded : (bvh, p, q) -> (k,) bool, the shadow rays' tracer

    Returns
    -------
    (k,) float64, lux
    """
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    normals = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    owner = np.asarray(owner, dtype=np.int64).reshape(-1)
    out = np.zeros(len(points))
    if not len(points):
        return out
    pos = np.array([lum.position for lum in luminaires], dtype=np.float64).reshape(-1, 3)
    axis = np.array([lum.normal for lum in luminaires], dtype=np.float64).reshape(-1, 3)
    flux = np.array([lum.flux_lm for lum in luminaires], dtype=np.float64)
    u, v = _frames(luminaires, axis)
    r = points - pos[owner]
    r2 = np.maximum(np.einsum("ij,ij->i", r, r), 1e-12)
    d = r / np.sqrt(r2)[:, None]
    cs = -np.einsum("ij,ij->i", normals, d)
    ok = (cs > 0) & (r2 > 1e-12)
    along = np.einsum("ij,ij->i", d, axis[owner])
    phots = {}
    for i, lum in enumerate(luminaires):
        phots.setdefault(id(lum.photometry), (lum.photometry, []))[1].append(i)
    i_cd = np.zeros(len(points))
    for phot, members in phots.values():
        if phot is None:
            continue                          # not a pair's luminaire here
        mine = ok if len(phots) == 1 else ok & np.isin(owner, members)
        # outside the distribution's cone (beyond its last lit gamma) nothing is looked up
        sel = np.flatnonzero(mine & (along >= _cone_cos(phot)))
        local = np.stack([np.einsum("ij,ij->i", d[sel], u[owner[sel]]),
                          np.einsum("ij,ij->i", d[sel], v[owner[sel]]), along[sel]], axis=1)
        i_cd[sel] = phot.intensity_per_lm(local)
    g = np.where(ok, flux[owner] * i_cd * cs / r2, 0.0)
    if occlusion and bvh is not None:
        idx = np.flatnonzero(g > 0)           # outside the distribution's cone: no ray
        if len(idx):
            g[idx[occluded(bvh, pos[owner[idx]], points[idx])]] = 0.0
    return g


def _frames(luminaires, axis):
    """(u, v): (k, 3) float64 C = 0 and C = 90 axes of each luminaire (axis ``axis[i]``,
    its ``c0`` where it has one; :func:`~invrad_wb.core.model.aiming.photometric_frame`)."""
    from invrad_wb.core.model.aiming import photometric_frame
    frames = {}
    u = np.empty_like(axis)
    v = np.empty_like(axis)
    for i, lum in enumerate(luminaires):     # many luminaires share a frame: once each
        c0 = getattr(lum, "c0", None)
        key = (axis[i].tobytes(), None if c0 is None else np.asarray(c0).tobytes())
        if key not in frames:
            frames[key] = photometric_frame(lum.normal, c0)
        u[i], v[i] = frames[key]
    return u, v


def photometric_opencl(points, normals, luminaires, bvh=None, occlusion=True):
    """Direct illuminance of luminaires with an intensity distribution on the OpenCL
    device (``kernels/photometric.cl``), lux; the same contract as
    :func:`photometric_numpy` (its twin): one work-item per point looping over the
    luminaires, the cone test, the table lookup (bilinear in C and gamma, in the
    luminaire's frame) and the shadow ray in the kernel, in float32.

    Measured on the box of ``bench/bench_render.py`` (10,000 luminaires of 40 degrees,
    11,326 vertices and the patches): the numpy twin with the segment kernel's shadow rays
    spent 14 s of its 20 s CPU time in the cone prefilter, the lookups and the gathers."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    normals = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    n = len(points)
    lums = list(luminaires)
    if not n or not lums:
        return np.zeros(n)
    if bvh is None:
        occlusion = False
    env = get_env()
    pos = np.array([lum.position for lum in lums], dtype=np.float64).reshape(-1, 3)
    axis = np.array([lum.normal for lum in lums], dtype=np.float64).reshape(-1, 3)
    flux = np.array([lum.flux_lm for lum in lums], dtype=np.float64)
    u, v = _frames(lums, axis)
    index, tables, cones, plain = {}, [], [], []
    for lum in lums:
        if id(lum.photometry) not in index:
            index[id(lum.photometry)] = len(tables)
            t = lum.photometry.table
            tables.append(t)
            cones.append(_cone_cos(lum.photometry))
            plain.append(bool(np.all(t == t[:1])))      # the same in every C plane
    which = np.array([index[id(lum.photometry)] for lum in lums], dtype=np.int32)
    tab = np.stack([which, np.asarray(plain, dtype=np.int32)[which]], axis=1)
    cone = np.asarray(cones, dtype=np.float64)[which]
    knl = env.kernel("photometric", "photometric_illuminance",
                     [f"-D OCCLUSION={1 if occlusion else 0}"])
    out = np.empty(n, np.float32)
    args = (device_buffer(env, float4(points)), device_buffer(env, float4(normals)),
            np.int32(len(lums)), device_buffer(env, float4(pos, flux)),
            device_buffer(env, float4(axis, cone)), device_buffer(env, float4(u)),
            device_buffer(env, float4(v)), device_buffer(env, tab),
            device_buffer(env, np.asarray(tables, dtype=np.float32)),
            np.float32(C.RAY_EPS_M))
    d_out = device_buffer(env, out, "write")
    launch_chunked(env, knl, n, args, (*bvh_buffers(env, bvh if occlusion else None), d_out),
                   max(64, C.CL_CHUNK_PHOTOMETRIC_PAIRS // len(lums)))
    env.cl.enqueue_copy(env.queue, out, d_out)
    return out.astype(np.float64)


def _split(luminaires):
    """(lambertian luminaires, luminaires with a photometry)."""
    return ([lum for lum in luminaires if getattr(lum, "photometry", None) is None],
            [lum for lum in luminaires if getattr(lum, "photometry", None) is not None])


def direct_illuminance_numpy(points, normals, luminaires, bvh=None, occlusion=True):
    """Direct illuminance (numpy twin).

    Parameters
    ----------
    points : (n, 3) float64, metres
    normals : (n, 3) float64, unit receiver normals
    luminaires : list of Luminaire
    bvh : BVH, optional
        Occluding triangles; required when ``occlusion`` is True.

    Returns
    -------
    (n,) float64, lux
    """
    points = np.asarray(points, dtype=np.float64)
    normals = np.asarray(normals, dtype=np.float64)
    luminaires, photometric = _split(luminaires)
    pos, nrm, flux, _ = emitter_samples(luminaires)
    out = photometric_numpy(points, normals, photometric, bvh, occlusion)
    for c, n, f in zip(pos, nrm, flux):
        g, ok = _geometry(points, normals, c, n, f)
        if occlusion and bvh is not None and ok.any():
            idx = np.flatnonzero(ok)
            occ = segments_occluded_numpy(bvh, np.broadcast_to(c, (len(idx), 3)), points[idx])
            g[idx[occ]] = 0.0
        out += g
    return out



def direct_illuminance_opencl(points, normals, luminaires, bvh=None, occlusion=True):
    """Direct illuminance on the OpenCL device (same contract as the numpy twin).

    Luminaires with an intensity distribution are added by :func:`photometric_opencl`
    (``kernels/photometric.cl``; ``kernels/direct.cl`` is lambertian)."""
    luminaires, photometric = _split(luminaires)
    if photometric:
        rest = photometric_opencl(points, normals, photometric, bvh, occlusion)
        return rest + direct_illuminance_opencl(points, normals, luminaires, bvh, occlusion)
    env = get_env()
    cl = env.cl
    points = np.asarray(points, dtype=np.float64)
    n = len(points)
    pos, nrm, flux, _ = emitter_samples(luminaires)
    if n == 0 or len(pos) == 0:
        return np.zeros(n)
    if bvh is None:
        occlusion = False
    knl = env.kernel("direct", "direct_illuminance", [f"-D OCCLUSION={1 if occlusion else 0}"])
    bufs = bvh_buffers(env, bvh)
    out = np.empty(n, np.float32)
    d_pts, d_nrm = device_buffer(env, float4(points)), device_buffer(env, float4(normals))
    d_epos, d_enrm = device_buffer(env, float4(pos)), device_buffer(env, float4(nrm, flux))
    d_out = device_buffer(env, out, "write")
    launch_chunked(env, knl, n, (d_pts, d_nrm, np.int32(len(pos)), d_epos, d_enrm,
                                 np.float32(C.RAY_EPS_M)), (*bufs, d_out),
                   max(64, C.CL_CHUNK_RECEIVERS // max(1, len(pos))))
    cl.enqueue_copy(env.queue, out, d_out)
    return out.astype(np.float64)


#: bytes per luminaire and per emitter sample while the samples are built and sent: the
#: per-luminaire arrays before concatenation (4 small numpy arrays) and, per sample,
#: float64 position, normal, flux and owner, their float4 copies and device buffers
LUMINAIRE_BYTES = 600
SAMPLE_BYTES = 130


def emitter_memory(luminaires):
    """Estimated bytes of the emitter samples of ``luminaires`` (no luminaire x receiver
    array is ever made: the numpy twin loops over samples, the kernel over chunks of
    receivers, ``CL_CHUNK_RECEIVERS / samples`` at a time)."""
    from invrad_wb.core.model.luminaires import disk_quadrature
    per_disk = len(disk_quadrature()[1])
    samples = sum(per_disk if getattr(l, "radius_m", 0) > 0 else 1 for l in luminaires)
    return LUMINAIRE_BYTES * len(luminaires) + SAMPLE_BYTES * samples, samples


#: (luminaire, point) pairs between two progress reports of :func:`direct_illuminance`
PROGRESS_PAIRS = 2e7


def direct_illuminance(points, normals, luminaires, bvh=None, occlusion=True,
                       backend="opencl", progress=None):
    """Direct illuminance (lux) at points; ``backend`` is 'opencl', 'numpy' or 'auto'.

    The emitter samples' memory grows with the luminaire count and is checked against the
    budget first (:func:`emitter_memory`). Shadow rays are traced only against the
    triangles that can shadow a luminaire from a point (:func:`~invrad_wb.core.geometry.
    bvh.cull_occluders`; none in a convex room).

    ``progress(fraction)``: called with the fraction of luminaires done, after blocks of
    about :data:`PROGRESS_PAIRS` (luminaire, point) pairs (it may raise to cancel)."""
    from invrad_wb.core.model.memory import require
    nbytes, samples = emitter_memory(luminaires)
    require(nbytes, f"{len(luminaires)} luminaire(s) ({samples} emitter samples)",
            "give fewer luminaires")
    fn = implementation("direct_illuminance", backend)
    if occlusion and bvh is not None:
        # only triangles that separate some luminaire from some point can shadow
        bvh = cull_occluders(bvh, emitter_extent(luminaires), points)
        occlusion = bvh is not None
    lums = list(luminaires)
    if progress is None or len(lums) < 2:
        out = fn(points, normals, lums, bvh=bvh, occlusion=occlusion)
        if progress is not None:
            progress(1.0)
        return out
    block = max(1, int(PROGRESS_PAIRS // max(1, len(points))))
    out = np.zeros(len(points))
    progress(0.0)
    for b0 in range(0, len(lums), block):
        out += fn(points, normals, lums[b0:b0 + block], bvh=bvh, occlusion=occlusion)
        progress(min(len(lums), b0 + block) / len(lums))
    return out


def emitter_extent(luminaires):
    """(k, 3) float64 points whose convex hull holds every emitting point of
    ``luminaires``: a point luminaire's position, the corners of a square around a disk."""
    pts = [np.zeros((0, 3))]
    disks = [lum for lum in luminaires if getattr(lum, "radius_m", 0) > 0]
    pts.append(np.array([lum.position for lum in luminaires
                         if not getattr(lum, "radius_m", 0) > 0]).reshape(-1, 3))
    if disks:
        from invrad_wb.core.model.scene import plane_basis
        for lum in disks:
            u, v = plane_basis(lum.normal)
            r = lum.radius_m
            pts.append(lum.position + r * np.array([u + v, u - v, -u + v, -u - v]))
    return np.concatenate(pts)


register("direct_illuminance", direct_illuminance_opencl, direct_illuminance_numpy,
         "direct light of point/disk luminaires with occlusion (kernels/direct.cl)")
register("photometric_illuminance", photometric_opencl, photometric_numpy,
         "direct light of luminaires with an intensity distribution, with occlusion"
         " (kernels/photometric.cl)")
