/* Deformed-ellipse votes (thesis listings 4.5-4.6): one work-item per (point, map) vote.
 *
 * The ellipse comes from the voting table on the host (lookup is cheap and shared with the
 * numpy twin); here it is sampled, tested against the map's face mask and for occlusion, and
 * drawn as a closed polyline (DDA, start pixel skipped) with integer atomics in fixed point.
 * ell_c: centre xyz, w = weight * 65536; ell_w: minor axis w, w = a; ell_v: major axis v,
 * w = b; ell_i: (map, point, K, 0); ell_d: deformation d.
 * Numpy twin: invrad_wb.core.votes_ellipse.cast_ellipse_numpy. Build option -D OCCLUSION.
 */
#include "bvh.h"

/* P(t) from ct = cos t, st = sin t: c + b (cos t + d cos 2t) w + a sin t v */
inline float3 ell_point(const float3 c, const float3 w, const float3 v, const float a,
                        const float b, const float d, const float ct, const float st)
{
    return c + (b * (ct + d * (2.0f * ct * ct - 1.0f))) * w + (a * st) * v;
}

__kernel void ellipse_votes(const int n, const int first, __global const float4 *ell_c,
                            __global const float4 *ell_w, __global const float4 *ell_v,
                            __global const int4 *ell_i, __global const float *ell_d,
                            __global const float4 *m_origin, __global const float4 *m_u,
                            __global const float4 *m_v, __global const float4 *m_n,
                            __global const int4 *m_info, __global const uchar *mask,
                            const float pixel, __global const float4 *pts,
                            __global const float4 *pnrm, const float eps,
                            __global const float4 *lo, __global const float4 *hi,
                            __global const int2 *info, __global const float16 *tris,
                            __global volatile uint *out)
{
    const int g = first + get_global_id(0);   /* chunked launches */
    if (g >= n) return;
    const float4 c4 = ell_c[g], w4 = ell_w[g], v4 = ell_v[g];
    const int4 ei = ell_i[g];
    const int map = ei.x, K = ei.z;
    const float3 c = c4.xyz, w = w4.xyz, v = v4.xyz;
    const float a = w4.w, b = v4.w, d = ell_d[g];
    const uint wq = (uint)rint(c4.w);
    const float3 o = m_origin[map].xyz, mu = m_u[map].xyz, mv = m_v[map].xyz;
    const float3 mn = m_n[map].xyz;
    const int4 mi = m_info[map];  /* start, stride, nu, nv */
    const float3 s = pts[ei.y].xyz + pnrm[ei.y].xyz * eps;
    const float step = 2.0f * M_PI_F / (float)K;
    /* cos/sin of t_k by rotation (no trig per sample), re-anchored every 64 samples */
    const float cs = cos(step), sn = sin(step);
    float ct = 1.0f, st = 0.0f;

    /* sample k: continuous pixel coordinates and validity */
    float fi0 = 0.0f, fj0 = 0.0f, fi_prev = 0.0f, fj_prev = 0.0f;
    int v0 = 0, v_prev = 0;
    for (int k = 0; k <= K; ++k) {
        float fi, fj;
        int valid;
        if (k < K) {
            if ((k & 63) == 0) { ct = cos(step * (float)k); st = sin(step * (float)k); }
            const float3 p = ell_point(c, w, v, a, b, d, ct, st);
            const float ct1 = ct * cs - st * sn;
            st = st * cs + ct * sn;
            ct = ct1;
            const float3 r = p - o;
            fi = dot(r, mu) / pixel;
            fj = dot(r, mv) / pixel;
            const int ii = (int)floor(fi), jj = (int)floor(fj);
            valid = ii >= 0 && jj >= 0 && ii < mi.z && jj < mi.w
                    && mask[mi.x + ii * mi.y + jj];
#if OCCLUSION
            if (valid && segment_occluded(s, p + mn * eps, eps, lo, hi, info, tris)) valid = 0;
#endif
            if (k == 0) { fi0 = fi; fj0 = fj; v0 = valid; }
        } else {
            fi = fi0; fj = fj0; valid = v0;   /* close the polyline */
        }
        if (k > 0 && valid && v_prev) {
            const float pi0 = floor(fi_prev), pj0 = floor(fj_prev);
            const float pi1 = floor(fi), pj1 = floor(fj);
            const int steps = (int)fmax(fabs(pi1 - pi0), fabs(pj1 - pj0));
            for (int q = 1; q <= steps; ++q) {
                const float f = (float)q / (float)steps;
                int li = (int)floor(pi0 + (pi1 - pi0) * f + 0.5f);
                int lj = (int)floor(pj0 + (pj1 - pj0) * f + 0.5f);
                li = clamp(li, 0, mi.z - 1);
                lj = clamp(lj, 0, mi.w - 1);
                atomic_add(out + mi.x + li * mi.y + lj, wq);
            }
        }
        fi_prev = fi; fj_prev = fj; v_prev = valid;
    }
}
