/* Exact vote model: every vote-map pixel gathers the votes of all voting points.
 *
 * A point s (normal m) with vote illuminance E votes for the candidate luminaire positions c
 * on a map (luminaire normal n) where a lambertian luminaire of flux F gives exactly E:
 *     F * e(c) = E,   e(c) = A * B / (pi * r^4),  A = -n.d,  B = m.d,  d = c - s, r = |d|.
 * The contour's distance from a pixel centre is estimated to first order from the log:
 *     delta = |ln(F e(c)) - ln E| / |grad_t ln e(c)|,   grad ln e = -n/A + m/B - 4 d / r^2
 * (grad_t: component in the map's plane), and the pixel receives the tent weight
 * W * max(0, 1 - delta / pixel): one pixel's width of vote per unit contour length.
 * No ellipse fit: exact for any plane orientation.
 *
 * Work-item = 16 consecutive pixels of one map row (float16 vectors, structure of arrays;
 * PoCL vectorises explicit vectors only). Pixels gather, so no atomics are needed.
 * Optional: occlusion of (point, pixel) segments that vote (-D OCCLUSION=1) and shade
 * points that forbid pixels whose luminaire would light them above a limit (-D SHADE=1).
 * A photometric distribution replaces the lambertian e(c) with -D PROFILE=1 (see below).
 * Numpy twin: invrad_wb.core.inverse.votes.cast_exact_numpy.
 */
#include "bvh.h"
#include "vec16.h"

#define LN_PI 1.1447298858494002f

#if PROFILE
/* A photometric distribution (-D PROFILE=1): prof[i] = (ln p, w) at gamma = i * PROFILE_STEP
 * degrees, p the C-averaged intensity (cd/lm) and w = (d ln p / d gamma) / sin gamma; then
 *     ln e = ln p(gamma) + ln B - 3 ln r,
 *     grad ln e = w (n / r + A d / r^3) + m / B - 3 d / r^2     (cos gamma = A / r).
 * ln p < -1e29: dark there, no vote. Numpy twin: votes.vote_profile / _profile_at. */
inline void profile16(const float16 cosg, __global const float2 *prof, const int nprof,
                      float16 *lnp, float16 *w)
{
    const float16 f = acos16(clamp16(cosg, -1.0f, 1.0f)) * (57.29577951308232f / PROFILE_STEP);
    float fa[16], la[16], wa[16];
    VSTORE16(f, fa);
    for (int l = 0; l < 16; ++l) {
        const int i = min((int)fa[l], nprof - 2);
        const float t = fa[l] - (float)i;
        const float2 a = prof[i], b = prof[i + 1];
        la[l] = a.x + t * (b.x - a.x);
        wa[l] = a.y + t * (b.y - a.y);
    }
    *lnp = VLOAD16_FLOAT(la);
    *w = VLOAD16_FLOAT(wa);
}
#endif

inline float16 tent_votes(const float16 cx, const float16 cy, const float16 cz,
                          const float3 n, const float3 s, const float3 m,
                          const float lnE, const float w, const float pixel,
                          __global const float2 *prof, const int nprof, float16 *lnF)
{
    const float16 dx = cx - s.x, dy = cy - s.y, dz = cz - s.z;
    const float16 A = -(n.x * dx + n.y * dy + n.z * dz);
    const float16 B = m.x * dx + m.y * dy + m.z * dz;
    const float16 r2 = dx * dx + dy * dy + dz * dz;
    int16 ok = (A > 1e-6f) & (B > 1e-6f);
    const float16 Ac = select16((float16)(1.0f), A, ok);
    const float16 Bc = select16((float16)(1.0f), B, ok);
    const float16 inv_r2 = 1.0f / r2;
    const float16 iA = 1.0f / Ac, iB = 1.0f / Bc;
#if PROFILE
    const float16 inv_r = rsqrt16(r2);
    float16 lnp, wp;
    profile16(Ac * inv_r, prof, nprof, &lnp, &wp);
    ok &= (lnp > -1e29f);
    const float16 lne = lnp + log16(Bc) - 1.5f * log16(r2);
    const float16 k = Ac * inv_r2 * inv_r;                /* A / r^3 */
    const float16 gx = wp * (n.x * inv_r + k * dx) + m.x * iB - 3.0f * dx * inv_r2;
    const float16 gy = wp * (n.y * inv_r + k * dy) + m.y * iB - 3.0f * dy * inv_r2;
    const float16 gz = wp * (n.z * inv_r + k * dz) + m.z * iB - 3.0f * dz * inv_r2;
#else
    const float16 lne = log16(Ac * Bc * inv_r2 * inv_r2) - LN_PI;
    const float16 gx = -n.x * iA + m.x * iB - 4.0f * dx * inv_r2;
    const float16 gy = -n.y * iA + m.y * iB - 4.0f * dy * inv_r2;
    const float16 gz = -n.z * iA + m.z * iB - 4.0f * dz * inv_r2;
#endif
    *lnF = lne;
    const float16 L = lne - lnE;
    const float16 gn = gx * n.x + gy * n.y + gz * n.z;
    const float16 tx = gx - gn * n.x, ty = gy - gn * n.y, tz = gz - gn * n.z;
    const float16 gt = sqrt16(tx * tx + ty * ty + tz * tz);
    const float16 delta = fabs16(L) / fmax16(gt, 1e-12f);
    const float16 tent = fmax16(1.0f - delta / pixel, 0.0f) * w;
    return select16((float16)(0.0f), tent, ok);
}

__kernel void exact_votes(const int nblocks, const int first, __global const int4 *blocks,
                          __global const float4 *map_origin, __global const float4 *map_u,
                          __global const float4 *map_v, __global const float4 *map_n,
                          __global const int4 *map_info, const float pixel,
                          const int npts, __global const float4 *pts,
                          __global const float4 *pnrm, __global const float *W,
                          const int nshade, __global const float4 *shade_pts,
                          __global const float4 *shade_nrm, const float ln_shade_limit,
                          const float eps, const float baseline,
                          __global const float2 *prof, const int nprof,
                          __global const float4 *lo, __global const float4 *hi,
                          __global const int2 *info, __global const float16 *tris,
                          __global float *out)
{
    const int g = first + get_global_id(0);   /* chunked launches: any scene size fits */
    if (g >= nblocks) return;
    const int4 b = blocks[g];
    const int map = b.x;
    const int4 mi = map_info[map];
    const float3 n = map_n[map].xyz;
    const float3 o = map_origin[map].xyz + ((float)b.y + 0.5f) * pixel * map_u[map].xyz;
    const float3 V = map_v[map].xyz * pixel;
    const float16 jj = (float16)(0.5f, 1.5f, 2.5f, 3.5f, 4.5f, 5.5f, 6.5f, 7.5f, 8.5f, 9.5f,
                                 10.5f, 11.5f, 12.5f, 13.5f, 14.5f, 15.5f) + (float)b.z;
    const float16 cx = o.x + jj * V.x, cy = o.y + jj * V.y, cz = o.z + jj * V.z;
    float16 acc = (float16)(baseline);
    float16 lne;
    __global const float *Wm = W + (size_t)map * npts;
    for (int p = 0; p < npts; ++p) {
        const float w = Wm[p];
        if (w <= 0.0f) continue;
        const float4 sp = pts[p];
        const float3 s = sp.xyz, m = pnrm[p].xyz;
        float16 v = tent_votes(cx, cy, cz, n, s, m, sp.w, w, pixel, prof, nprof, &lne);
#if OCCLUSION
        if (any16(v > 0.0f)) {
            float va[16], xa[16], ya[16], za[16];
            VSTORE16(v, va); VSTORE16(cx, xa); VSTORE16(cy, ya); VSTORE16(cz, za);
            const float3 s_off = s + m * eps;
            for (int l = 0; l < 16; ++l) {
                if (va[l] > 0.0f) {
                    const float3 c = (float3)(xa[l], ya[l], za[l]) + n * eps;
                    if (segment_occluded(s_off, c, eps, lo, hi, info, tris)) va[l] = 0.0f;
                }
            }
            v = VLOAD16_FLOAT(va);
        }
#endif
        acc += v;
    }
#if SHADE
    /* forbid pixels whose luminaire would put more than the limit on a shade point */
    int16 forbid = (int16)(0);
    for (int p = 0; p < nshade && !all16(forbid); ++p) {
        const float3 s = shade_pts[p].xyz, m = shade_nrm[p].xyz;
        const float16 dx = cx - s.x, dy = cy - s.y, dz = cz - s.z;
        const float16 A = -(n.x * dx + n.y * dy + n.z * dz);
        const float16 B = m.x * dx + m.y * dy + m.z * dz;
        const float16 r2 = dx * dx + dy * dy + dz * dz;
        int16 ok = (A > 1e-6f) & (B > 1e-6f);
#if PROFILE
        float16 lnp, wp;
        profile16(select16((float16)(1.0f), A, ok) * rsqrt16(r2), prof, nprof, &lnp, &wp);
        ok &= (lnp > -1e29f);
        const float16 lnev = lnp + log16(select16((float16)(1.0f), B, ok)) - 1.5f * log16(r2);
#else
        const float16 lnev = log16(select16((float16)(1e-30f), A * B / (r2 * r2), ok)) - LN_PI;
#endif
        int16 hot = ok & (lnev > ln_shade_limit) & !forbid;
#if OCCLUSION
        if (any16(hot)) {
            int ha[16]; float xa[16], ya[16], za[16];
            VSTORE16(hot, ha); VSTORE16(cx, xa); VSTORE16(cy, ya); VSTORE16(cz, za);
            const float3 s_off = s + m * eps;
            for (int l = 0; l < 16; ++l) {
                if (ha[l]) {
                    const float3 c = (float3)(xa[l], ya[l], za[l]) + n * eps;
                    if (segment_occluded(s_off, c, eps, lo, hi, info, tris)) ha[l] = 0;
                }
            }
            hot = VLOAD16_INT(ha);
        }
#endif
        forbid |= hot;
    }
    acc = select16(acc, (float16)(0.0f), forbid);
#endif
    VSTORE16(acc, out + mi.x + b.y * mi.y + b.z);
}
