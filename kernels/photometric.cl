/* Direct illuminance at receivers from luminaires with an intensity distribution (type C
 * photometry, taken at the luminaire's centre), with optional occlusion by the scene:
 *
 *   E = sum_k flux_k * I_k(C, gamma) * max(0, -m . w) / r^2 * V
 *
 * with w the unit vector from luminaire k to the receiver, m the receiver normal, gamma
 * the angle between w and the luminaire's axis, C the angle of w about it from the
 * luminaire's C = 0 axis u (C = 90 along v), and I_k its table (cd/lm, 361 C x 181 gamma
 * at 1 degree, bilinear). Pairs outside the distribution's cone (axis . w < cone cos) are
 * skipped before any lookup or ray.
 *
 * Luminaire k: lpos[k] = (position, flux lm), laxis[k] = (axis, cone cos), lu[k], lv[k]
 * its C = 0 / C = 90 axes, ltab[k] = (the index of its table in tables, 361 * 181 floats
 * each; 1 if the table is the same in every C plane: no C angle is computed).
 * Numpy twin: invrad_wb.core.forward.direct.photometric_numpy.
 * Build options: -D OCCLUSION=0/1.
 */
#include "bvh.h"

#define N_C 361
#define N_GAMMA 181
#define DEG (180.0f / M_PI_F)

__kernel void photometric_illuminance(const int n, const int first,
                                      __global const float4 *pts, __global const float4 *nrm,
                                      const int k, __global const float4 *lpos,
                                      __global const float4 *laxis,
                                      __global const float4 *lu, __global const float4 *lv,
                                      __global const int2 *ltab,
                                      __global const float *tables, const float eps,
                                      __global const float4 *lo, __global const float4 *hi,
                                      __global const int2 *info,
                                      __global const float16 *tris, __global float *out)
{
    const int i = first + get_global_id(0);   /* chunked launches */
    if (i >= n) return;
    const float3 p = pts[i].xyz, m = nrm[i].xyz;
    float e = 0.0f;
    for (int j = 0; j < k; ++j) {
        const float4 c = lpos[j];
        const float3 r = p - c.xyz;
        const float r2 = dot(r, r);
        if (r2 <= 1e-12f) continue;
        const float3 w = r * rsqrt(r2);
        const float cs = -dot(m, w);
        if (cs <= 0.0f) continue;
        const float4 ax = laxis[j];
        const float z = dot(w, ax.xyz);
        if (z < ax.w) continue;               /* outside the cone of light */
        const float x = dot(w, lu[j].xyz), y = dot(w, lv[j].xyz);
        /* atan2 keeps gamma accurate near the axis, where acos(z) loses it in float32 */
        const float gamma = atan2(sqrt(x * x + y * y), z) * DEG;
        const int2 tab = ltab[j];
        float cdeg = 0.0f;
        if (!tab.y) {
            cdeg = atan2(y, x) * DEG;
            if (cdeg < 0.0f) cdeg += 360.0f;
        }
        const int g0 = min((int)floor(gamma), N_GAMMA - 2);
        const int c0 = min((int)floor(cdeg), N_C - 2);
        const float tg = gamma - (float)g0, tc = cdeg - (float)c0;
        __global const float *t = tables + (size_t)tab.x * (N_C * N_GAMMA)
                                  + (size_t)c0 * N_GAMMA + g0;
        const float a = mix(t[0], t[1], tg);
        const float b = mix(t[N_GAMMA], t[N_GAMMA + 1], tg);
        const float cd = mix(a, b, tc);
        if (cd <= 0.0f) continue;
        const float g = c.w * cd * cs / r2;
#if OCCLUSION
        if (segment_occluded(c.xyz, p, eps, lo, hi, info, tris)) continue;
#endif
        e += g;
    }
    out[i] = e;
}
