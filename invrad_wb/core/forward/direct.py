"""Direct illuminance at receiver points from lambertian luminaires, with occlusion.

``E = sum_k F_k * cos(theta_l) * cos(theta_s) / (pi * r^2) * V`` over the emitter samples of
:func:`invrad_wb.core.model.luminaires.emitter_samples` (one per point luminaire, a quadrature per
disk). Two implementations with one signature: :func:`direct_illuminance_numpy` (the twin)
and :func:`direct_illuminance_opencl` (``kernels/direct.cl``).
"""
import numpy as np

from invrad_wb import constants as C
from invrad_wb.core.geometry.bvh import segments_occluded_numpy
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


def photometric_numpy(points, normals, luminaires, bvh=None, occlusion=True):
    """Direct illuminance of luminaires with an intensity distribution (numpy), lux:
    ``E = I(direction) * cos(theta_s) / r^2`` with ``I = flux * photometry(direction)``
    in the luminaire's frame (:mod:`invrad_wb.core.model.photometry`; its C = 0 axis is
    the luminaire's ``c0`` where it has one: an aimed spot, :mod:`invrad_wb.core.model.
    aiming`); disk luminaires are taken at their centre."""
    from invrad_wb.core.model.aiming import photometric_frame
    points = np.asarray(points, dtype=np.float64)
    normals = np.asarray(normals, dtype=np.float64)
    out = np.zeros(len(points))
    for lum in luminaires:
        u, v = photometric_frame(lum.normal, getattr(lum, "c0", None))
        r = points - lum.position
        r2 = np.maximum(np.einsum("ij,ij->i", r, r), 1e-12)
        d = r / np.sqrt(r2)[:, None]
        cs = -np.einsum("ij,ij->i", normals, d)
        ok = (cs > 0) & (r2 > 1e-12)
        i_cd = lum.flux_lm * lum.photometry.intensity_per_lm(
            np.stack([d @ u, d @ v, d @ lum.normal], axis=1))
        g = np.where(ok, i_cd * cs / r2, 0.0)
        if occlusion and bvh is not None and ok.any():
            idx = np.flatnonzero(g > 0)
            occ = segments_occluded_numpy(bvh, np.broadcast_to(lum.position, (len(idx), 3)),
                                          points[idx])
            g[idx[occ]] = 0.0
        out += g
    return out


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

    Luminaires with an intensity distribution are added by :func:`photometric_numpy`
    (the kernel is lambertian)."""
    luminaires, photometric = _split(luminaires)
    if photometric:
        rest = photometric_numpy(points, normals, photometric, bvh, occlusion)
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


def direct_illuminance(points, normals, luminaires, bvh=None, occlusion=True,
                       backend="opencl"):
    """Direct illuminance (lux) at points; ``backend`` is 'opencl', 'numpy' or 'auto'.

    The emitter samples' memory grows with the luminaire count and is checked against the
    budget first (:func:`emitter_memory`)."""
    from invrad_wb.core.model.memory import require
    nbytes, samples = emitter_memory(luminaires)
    require(nbytes, f"{len(luminaires)} luminaire(s) ({samples} emitter samples)",
            "give fewer luminaires")
    fn = implementation("direct_illuminance", backend)
    return fn(points, normals, luminaires, bvh=bvh, occlusion=occlusion)


register("direct_illuminance", direct_illuminance_opencl, direct_illuminance_numpy,
         "direct light of point/disk luminaires with occlusion (kernels/direct.cl)")
