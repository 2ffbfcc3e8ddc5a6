/* Point-to-patch form factors for the radiosity model (invrad_wb/core/forward/radiosity.py).
 *
 * out[i, j] = F(receiver i -> patch j) * V(patch of receiver i, j), float32, for receivers
 * (points with unit normals) and the patches of one room. Coordinates are relative to a
 * room centre (so float32 keeps ~1e-7 m resolution). Numpy twin (float64):
 * invrad_wb.core.forward.radiosity._form_factors_numpy.
 *
 *  - far field (|c_j - p| >= blend_r_j): A_j cos_i cos_j / (pi r^2) to the patch centroid,
 *    16 patches per work-item as float16 lanes (PoCL vectorises explicit vectors only);
 *  - near field (|c_j - p| < near_r_j): the exact differential-area-to-polygon (Lambert /
 *    Nusselt contour) formula summed over the patch's triangles, each clipped at the
 *    receiver's tangent plane, 8 triangles at a time as float8 lanes; between near_r and
 *    blend_r the two are blended linearly in r^2;
 *  - a patch on the receiver's own plane gives 0; so does a patch whose plane the receiver
 *    lies behind. A receiver within eps of the patch's plane (a vertex on a room edge) is
 *    moved eps in front of it, which keeps the contour integral regular.
 *
 * Layout: pblk is (nblk, 8) float16 rows cx cy cz nx ny nz area blend_r2 (16 patches per
 * block; padding patches have area 0 and blend_r2 0; near_r2 = inner * blend_r2);
 * pplane (nblk) int16 plane ids; tstart (P+1) first 8-triangle block of each patch;
 * tris (nb8, 9) float8 rows
 * v0xyz v1xyz v2xyz (triangles counter-clockwise seen from the front of the patch;
 * padding triangles are degenerate and contribute 0).
 *
 * Kernels: form_factors (receiver rows) and patch_form_factors (the patch-to-patch matrix:
 * rows summed over each patch's sub-patch samples on the device; numpy twin
 * invrad_wb.core.forward.radiosity._patch_form_factors_numpy).
 *
 * Build options: -D VIS=0/1 (multiply by the patch-to-patch visibility vis[P, ppad]).
 */

#include "vec16.h"

#define INV_TWO_PI 0.15915494309189535f

/* gamma_e * (m . unit(a x b)) of one contour edge a -> b (vectors from the receiver). */
inline float8 edge_term(const float8 ax, const float8 ay, const float8 az,
                        const float8 bx, const float8 by, const float8 bz, const float3 m)
{
    const float8 cx = ay * bz - az * by;
    const float8 cy = az * bx - ax * bz;
    const float8 cz = ax * by - ay * bx;
    const float8 s2 = cx * cx + cy * cy + cz * cz;
    const float8 la2 = ax * ax + ay * ay + az * az;
    const float8 lb2 = bx * bx + by * by + bz * bz;
    const float8 s = sqrt(s2);
    const float8 d = ax * bx + ay * by + az * bz;
    const float8 g = atan2(s, d);
    const float8 t = (m.x * cx + m.y * cy + m.z * cz) * g / fmax(s, 1e-30f);
    /* parallel vectors (zero-length or degenerate edge): the term vanishes */
    return select((float8)(0.0f), t, s2 > 1e-12f * la2 * lb2);
}

/* Contour sum of 8 triangles (vertex vectors a, b, c from the receiver, heights h above
 * its tangent plane), each clipped to h > 0. */
inline float8 clipped_triangles(const float8 ax, const float8 ay, const float8 az,
                                const float8 bx, const float8 by, const float8 bz,
                                const float8 cx, const float8 cy, const float8 cz,
                                const float3 m)
{
    const float8 ha = m.x * ax + m.y * ay + m.z * az;
    const float8 hb = m.x * bx + m.y * by + m.z * bz;
    const float8 hc = m.x * cx + m.y * cy + m.z * cz;
    const int8 ia = ha > 0.0f, ib = hb > 0.0f, ic = hc > 0.0f;
    float8 acc = (float8)(0.0f);
    float8 exx = (float8)(0.0f), exy = exx, exz = exx;   /* where the contour leaves */
    float8 enx = exx, eny = exx, enz = exx;              /* where it comes back */

#define CLIP_EDGE(px, py, pz, hp, ip, qx, qy, qz, hq, iq)                                 \
    {                                                                                   \
        const int8 crs = ip ^ iq;                                                       \
        const float8 t = hp / select((float8)(1.0f), hp - hq, crs);                     \
        const float8 xx = px + t * (qx - px), xy = py + t * (qy - py),                  \
                     xz = pz + t * (qz - pz);                                           \
        const float8 sx = select(xx, px, ip), sy = select(xy, py, ip),                  \
                     sz = select(xz, pz, ip);                                           \
        const float8 fx = select(xx, qx, iq), fy = select(xy, qy, iq),                  \
                     fz = select(xz, qz, iq);                                           \
        acc += select((float8)(0.0f), edge_term(sx, sy, sz, fx, fy, fz, m), ip | iq);   \
        const int8 leave = ip & ~iq, enter = ~ip & iq;                                  \
        exx = select(exx, xx, leave); exy = select(exy, xy, leave);                     \
        exz = select(exz, xz, leave);                                                   \
        enx = select(enx, xx, enter); eny = select(eny, xy, enter);                     \
        enz = select(enz, xz, enter);                                                   \
    }
    CLIP_EDGE(ax, ay, az, ha, ia, bx, by, bz, hb, ib)
    CLIP_EDGE(bx, by, bz, hb, ib, cx, cy, cz, hc, ic)
    CLIP_EDGE(cx, cy, cz, hc, ic, ax, ay, az, ha, ia)
#undef CLIP_EDGE
    /* the closing edge along the tangent plane, where the triangle is cut */
    const int8 cut = (ia | ib | ic) & ~(ia & ib & ic);
    acc += select((float8)(0.0f), edge_term(exx, exy, exz, enx, eny, enz, m), cut);
    return acc;
}

/* Exact form factor from receiver (p, m) to patch j (near field). */
inline float patch_near(float3 p, const float3 m, const int j, __global const float *pf,
                        __global const int *tstart, __global const float8 *tris,
                        const float eps)
{
    const int base = (j / 16) * 128 + (j % 16);
    const float3 c = (float3)(pf[base], pf[base + 16], pf[base + 32]);
    const float3 n = (float3)(pf[base + 48], pf[base + 64], pf[base + 80]);
    const float h = dot(p - c, n);
    if (h <= -eps) return 0.0f;                 /* behind the patch's plane */
    p += fmax(eps - h, 0.0f) * n;               /* on its plane (edge vertex): step off */
    float8 acc = (float8)(0.0f);
    for (int t = tstart[j]; t < tstart[j + 1]; ++t) {
        __global const float8 *T = tris + 9 * t;
        acc += clipped_triangles(T[0] - p.x, T[1] - p.y, T[2] - p.z,
                                 T[3] - p.x, T[4] - p.y, T[5] - p.z,
                                 T[6] - p.x, T[7] - p.y, T[8] - p.z, m);
    }
    const float4 s4 = acc.lo + acc.hi;
    return -(s4.x + s4.y + s4.z + s4.w) * INV_TWO_PI;
}

/* Form factors from receiver (p, m) with info ri (plane, visibility row) to the 16
 * patches of block b (visibility applied with VIS=1). */
inline float16 block_form_factors(const float3 p, const float3 m, const int2 ri, const int b,
                                  const int ppad, __global const float16 *pblk,
                                  __global const int16 *pplane, __global const int *tstart,
                                  __global const float8 *tris, __global const uchar *vis,
                                  const float eps, const float inner)
{
    __global const float16 *B = pblk + 8 * b;
    const float16 dx = B[0] - p.x, dy = B[1] - p.y, dz = B[2] - p.z;
    const float16 d2 = fmax16(dx * dx + dy * dy + dz * dz, 1e-12f);
    const float16 ci = m.x * dx + m.y * dy + m.z * dz;            /* r cos_i */
    const float16 cj = -(B[3] * dx + B[4] * dy + B[5] * dz);      /* r cos_j */
    const float16 ffar = B[6] * fmax16(ci, 0.0f) * fmax16(cj, 0.0f) / (M_PI_F * d2 * d2);
    const int16 same = pplane[b] == (int16)(ri.x);
    const int16 isnear = (d2 < B[7]) & ~same;
    float16 f = select16(ffar, (float16)(0.0f), same | isnear);
    if (any16(isnear)) {
        /* exact inside the near radius, blended linearly in r^2 into the far field up to
         * the blend radius (continuous: no seam, no backend-dependent jump) */
        const float16 t = clamp16((d2 - inner * B[7]) / ((1.0f - inner) * B[7]), 0.0f, 1.0f);
        float fv[16], tv[16], av[16];
        int nv[16];
        VSTORE16(f, fv);
        VSTORE16(ffar, av);
        VSTORE16(t, tv);
        VSTORE16(isnear, nv);
        for (int k = 0; k < 16; ++k)
            if (nv[k]) {
                const float e = patch_near(p, m, 16 * b + k, (__global const float *)pblk,
                                           tstart, tris, eps);
                fv[k] = e + tv[k] * (av[k] - e);
            }
        f = VLOAD16_FLOAT(fv);
    }
#if VIS
    __global const uchar *v = vis + (size_t)ri.y * ppad + 16 * b;
    f *= (float16)(convert_float8(vload8(0, v)), convert_float8(vload8(1, v)));
#endif
    return f;
}

/* One work-item: receiver i x 16 patches of block b. Global size (n rounded, nblk). */
__kernel void form_factors(const int n, const int ppad,
                           __global const float4 *pts, __global const float4 *nrm,
                           __global const int2 *rinfo /* plane, patch (visibility row) */,
                           __global const float16 *pblk, __global const int16 *pplane,
                           __global const int *tstart, __global const float8 *tris,
                           __global const uchar *vis, const float eps,
                           const float inner /* (near radius / blend radius)^2 */,
                           __global float *out)
{
    const int i = get_global_id(0);
    const int b = get_global_id(1);
    if (i >= n) return;
    const float16 f = block_form_factors(pts[i].xyz, nrm[i].xyz, rinfo[i], b, ppad, pblk,
                                         pplane, tstart, tris, vis, eps, inner);
    VSTORE16(f, out + (size_t)i * ppad + 16 * b);
}

/* Patch-to-patch form factors: row r (a receiving patch) x 16 patches of block b, the
 * weighted sum over its sub-patch samples sstart[r] .. sstart[r+1]-1 (samples sorted by
 * row; weight = sample area / patch area). The samples' sum stays on the device: the host
 * gets P x P values instead of q^2 P x P. Global size (rows rounded, nblk). */
__kernel void patch_form_factors(const int nrows, const int ppad,
                                 __global const float4 *pts, __global const float4 *nrm,
                                 __global const int2 *rinfo, __global const float *weight,
                                 __global const int *sstart,
                                 __global const float16 *pblk, __global const int16 *pplane,
                                 __global const int *tstart, __global const float8 *tris,
                                 __global const uchar *vis, const float eps,
                                 const float inner, __global float *out)
{
    const int r = get_global_id(0);
    const int b = get_global_id(1);
    if (r >= nrows) return;
    float16 acc = (float16)(0.0f);
    for (int s = sstart[r]; s < sstart[r + 1]; ++s)
        acc += weight[s] * block_form_factors(pts[s].xyz, nrm[s].xyz, rinfo[s], b, ppad,
                                              pblk, pplane, tstart, tris, vis, eps, inner);
    VSTORE16(acc, out + (size_t)r * ppad + 16 * b);
}
