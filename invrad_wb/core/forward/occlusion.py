"""The BVH kernel family: occlusion of arbitrary segments on the OpenCL device
(``kernels/occlusion.cl``), and the BVH's device buffers that every kernel walking a BVH
through ``kernels/bvh.h`` takes (direct.cl, occlusion.cl, votes_exact.cl,
votes_ellipse.cl): :func:`bvh_buffers`, uploaded once per BVH and OpenCL context.

Numpy twin: :func:`invrad_wb.core.geometry.bvh.segments_occluded_numpy` (and the brute-force
reference :func:`invrad_wb.core.geometry.bvh.segments_occluded_bruteforce`).
"""
import threading
import weakref

import numpy as np

from invrad_wb import constants as C
from invrad_wb.core.accel.buffers import device_buffer, float4, launch_chunked
from invrad_wb.core.accel.device import get_env
from invrad_wb.core.accel.registry import implementation, register
from invrad_wb.core.geometry.bvh import BVH, LEAF, segments_occluded_numpy

#: BVH -> (OpenCL context, its device buffers); a BVH that goes away takes its buffers
#: with it, and a pickled BVH (a worker's) carries none
_BUFFERS = weakref.WeakKeyDictionary()
_LOCK = threading.Lock()
_EMPTY = None


def bvh_buffers(env, bvh=None):
    """The BVH's device buffers (node lo, node hi, node info, leaf triangles) as
    ``kernels/bvh.h`` reads them, uploaded once per BVH and context; ``bvh=None``: those
    of an empty BVH (a kernel built without occlusion still takes the arguments)."""
    global _EMPTY
    if bvh is None:
        if _EMPTY is None:
            _EMPTY = BVH(np.zeros((0, 3, 3)))
        bvh = _EMPTY
    with _LOCK:
        hit = _BUFFERS.get(bvh)
    if hit is not None and hit[0] is env.ctx:
        return hit[1]
    n = bvh.n_nodes
    lo4 = np.zeros((n, 4), np.float32)
    hi4 = np.zeros((n, 4), np.float32)
    # widen the bounds by a float32 ulp-scale margin so float rounding never culls a hit
    pad = 1e-5 * max(1.0, float(np.abs(np.concatenate([bvh.lo, bvh.hi])).max()))
    lo4[:, :3] = bvh.lo - pad
    hi4[:, :3] = bvh.hi + pad
    info = np.zeros((n, 2), np.int32)
    internal = bvh.leaf < 0
    info[internal, 0] = bvh.left[internal]
    info[internal, 1] = bvh.right[internal]
    info[~internal, 0] = -1 - bvh.leaf[~internal]
    tris = np.ascontiguousarray(bvh.tris.astype(np.float32))
    if tris.size == 0:
        tris = np.zeros((1, 9, LEAF), np.float32)
    bufs = tuple(device_buffer(env, a) for a in (lo4, hi4, info, tris))
    with _LOCK:
        _BUFFERS[bvh] = (env.ctx, bufs)
    return bufs


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
    launch_chunked(env, knl, n, (d_p, d_q, np.float32(eps)), (*bvh_buffers(env, bvh), d_o),
                   C.CL_CHUNK_SEGMENTS)
    env.cl.enqueue_copy(env.queue, out, d_o)
    return out.astype(bool)


def segments_occluded(bvh, p, q, backend="auto"):
    """(k,) bool: is segment p[i] -> q[i] blocked by a triangle of ``bvh``?"""
    return implementation("segments_occluded", backend)(bvh, p, q)


register("segments_occluded", segments_occluded_opencl,
         lambda bvh, p, q, eps=C.RAY_EPS_M: segments_occluded_numpy(bvh, p, q, eps),
         "segment occlusion through the BVH (kernels/occlusion.cl)")
