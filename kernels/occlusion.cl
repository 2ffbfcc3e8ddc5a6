/* Occlusion of arbitrary segments p[i] -> q[i] by the scene (radiosity visibility,
 * tests). Numpy twin: invrad_wb.core.bvh.segments_occluded_numpy. */
#include "bvh.h"

__kernel void segments_occluded(const int n, const int first, __global const float4 *p,
                                __global const float4 *q, const float eps,
                                __global const float4 *lo, __global const float4 *hi,
                                __global const int2 *info, __global const float16 *tris,
                                __global uchar *out)
{
    const int i = first + get_global_id(0);   /* chunked launches */
    if (i >= n) return;
    out[i] = (uchar)segment_occluded(p[i].xyz, q[i].xyz, eps, lo, hi, info, tris);
}
