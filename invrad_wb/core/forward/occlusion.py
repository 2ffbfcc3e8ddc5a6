"""Occlusion of arbitrary segments on the OpenCL device (``kernels/occlusion.cl``).

Numpy twin: :func:`invrad_wb.core.geometry.bvh.segments_occluded_numpy` (and the brute-force
reference :func:`invrad_wb.core.geometry.bvh.segments_occluded_bruteforce`).
"""
import numpy as np

from invrad_wb import constants as C
from invrad_wb.core.accel.buffers import device_buffer, float4, launch_chunked
from invrad_wb.core.accel.device import get_env
from invrad_wb.core.accel.registry import implementation, register
from invrad_wb.core.geometry.bvh import segments_occluded_numpy


def segments_occluded_opencl(bvh, p, q, eps=C.RAY_EPS_M):
    """(k,) bool: whether a triangle of ``bvh`` crosses segment p[i] -> q[i] (metres)."""
    p = np.asarray(p, dtype=np.float64).reshape(-1, 3)
    q = np.asarray(q, dtype=np.float64).reshape(-1, 3)
    n = len(p)
    if n == 0 or bvh.n_triangles == 0:
        return np.zeros(n, dtype=bool)
    env = get_env()
    out = np.empty(n, np.uint8)
    d_p, d_q = device_buffer(env, float4(p)), device_buffer(env, float4(q))
    d_o = device_buffer(env, out, "write")
    knl = env.kernel("occlusion", "segments_occluded")
    launch_chunked(env, knl, n, (d_p, d_q, np.float32(eps)), (*bvh.cl_buffers(env), d_o),
                   C.CL_CHUNK_SEGMENTS)
    env.cl.enqueue_copy(env.queue, out, d_o)
    return out.astype(bool)


def segments_occluded(bvh, p, q, backend="auto"):
    """(k,) bool: is segment p[i] -> q[i] blocked by a triangle of ``bvh``?"""
    return implementation("segments_occluded", backend)(bvh, p, q)


register("segments_occluded", segments_occluded_opencl,
         lambda bvh, p, q, eps=C.RAY_EPS_M: segments_occluded_numpy(bvh, p, q, eps),
         "segment occlusion through the BVH (kernels/occlusion.cl)")
