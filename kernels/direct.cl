/* Direct illuminance at receivers from lambertian point emitters (disk luminaires arrive
 * as quadrature points), with optional occlusion by the scene.
 *
 *   E = sum_k flux_k * max(0, n_k . w) * max(0, -m . w) / (pi * r^2) * V
 *
 * with w the unit vector from emitter k to the receiver, m the receiver normal.
 * Numpy twin: invrad_wb.core.direct.direct_illuminance_numpy.
 * Build options: -D OCCLUSION=0/1.
 */
#include "bvh.h"

__kernel void direct_illuminance(const int n, const int first, __global const float4 *pts,
                                 __global const float4 *nrm,
                                 const int k, __global const float4 *epos,
                                 __global const float4 *enrm /* w = flux lm */,
                                 const float eps,
                                 __global const float4 *lo, __global const float4 *hi,
                                 __global const int2 *info, __global const float16 *tris,
                                 __global float *out)
{
    const int i = first + get_global_id(0);   /* chunked launches */
    if (i >= n) return;
    const float3 p = pts[i].xyz, m = nrm[i].xyz;
    float e = 0.0f;
    for (int j = 0; j < k; ++j) {
        const float3 c = epos[j].xyz;
        const float4 en = enrm[j];
        const float3 r = p - c;
        const float r2 = dot(r, r);
        if (r2 < 1e-12f) continue;
        const float inv_r = rsqrt(r2);
        const float cl = dot(en.xyz, r) * inv_r;
        const float cs = -dot(m, r) * inv_r;
        if (cl <= 0.0f || cs <= 0.0f) continue;
        const float g = en.w * cl * cs / (M_PI_F * r2);
#if OCCLUSION
        if (segment_occluded(c, p, eps, lo, hi, info, tris)) continue;
#endif
        e += g;
    }
    out[i] = e;
}
