/* Segment occlusion against the scene BVH (see invrad_wb/core/geometry/bvh.py for the layout).
 *
 * Nodes: lo[i].xyz, hi[i].xyz bounds; info[i] = (left, right) for internal nodes,
 * (-1 - leaf, 0) for leaves. Leaves: 9 float16 rows per leaf (v0 xyz, v1 xyz, v2 xyz),
 * 16 triangles tested at once with vector operations (PoCL vectorises explicit vectors,
 * not scalar work-items). Numpy twin: segments_occluded_numpy().
 *
 * The ray-triangle test is watertight (Woop, Benthin and Wald, "Watertight ray/triangle
 * intersection", JCGT 2013): the vertices are moved into the ray's frame (origin at the
 * ray's start, the ray's largest axis kz as z, sheared so the ray is that axis), and the
 * 2-d edge functions are computed from those vertex images alone. A vertex shared by two
 * triangles has the same image in both, so an edge's function in one triangle is the exact
 * negative of its function in the other (the products commute, a - b = -(b - a)): a ray
 * through a shared edge or vertex hits at least one of them (an edge counts as inside).
 * Moller-Trumbore, used before, computes barycentrics per triangle from its own edges; a
 * ray through a shared wall edge missed both triangles at some points (l_room, 0.1 m mesh:
 * 225 of 11790 vertices lit through a wall by one of its 18 lights). No fused multiply-add
 * may break the exact negation, hence FP_CONTRACT OFF; nor may a reordering of the vertex
 * images' sums (-cl-fast-relaxed-math allows it: LLVM 14, PoCL 3.0 from PyPI, computed one
 * vertex's image differently for two of its triangles: tests/core/forward/test_watertight.py
 * failed, the parity test's pillar room had a point lit through the pillar), hence
 * "clang fp reassociate(off)" in leaf_hit (other compilers ignore the pragma).
 */
#ifndef INVRAD_BVH_H
#define INVRAD_BVH_H

#pragma OPENCL FP_CONTRACT OFF

#include "vec16.h"

#define BVH_STACK 64

/* o: ray start, (kx, ky, kz) its axes, (sx, sy, sz) its shear; t in units of the segment */
inline int leaf_hit(const float ox, const float oy, const float oz,
                    const int kx, const int ky, const int kz,
                    const float sx, const float sy, const float sz,
                    const float tmin, const float tmax, __global const float16 *leaf)
{
#pragma clang fp reassociate(off)
    const float16 az = leaf[kz] - oz, bz = leaf[3 + kz] - oz, cz = leaf[6 + kz] - oz;
    const float16 ax = (leaf[kx] - ox) - sx * az, ay = (leaf[ky] - oy) - sy * az;
    const float16 bx = (leaf[3 + kx] - ox) - sx * bz, by = (leaf[3 + ky] - oy) - sy * bz;
    const float16 cx = (leaf[6 + kx] - ox) - sx * cz, cy = (leaf[6 + ky] - oy) - sy * cz;
    /* edge functions: each is (x of its second vertex)(y of its first) - ... */
    const float16 u = cx * by - cy * bx;
    const float16 v = ax * cy - ay * cx;
    const float16 w = bx * ay - by * ax;
    const float16 det = u + v + w;
    const float16 t = (u * az + v * bz + w * cz) * sz / det;
    const int16 inside = ((u >= 0.0f) & (v >= 0.0f) & (w >= 0.0f))
                         | ((u <= 0.0f) & (v <= 0.0f) & (w <= 0.0f));
    const int16 hit = inside & (det != 0.0f) & (t > tmin) & (t < tmax);
    return any16(hit);
}

/* 1 if a triangle crosses the segment p -> q strictly between eps and |q-p| - eps. */
inline int segment_occluded(const float3 p, const float3 q, const float eps,
                            __global const float4 *lo, __global const float4 *hi,
                            __global const int2 *info, __global const float16 *tris)
{
    const float3 d = q - p;
    const float len = length(d);
    if (len <= 2.0f * eps) return 0;
    const float tmin = eps / len, tmax = 1.0f - eps / len;
    const float3 inv = (float3)(1.0f) / d;   /* +-inf for axis-parallel rays */
    /* the ray's frame: kz its largest axis, then kx, ky cyclically (the inside test takes
     * either winding, so no swap for d[kz] < 0) */
    const float3 ad = fabs(d);
    const int kz = (ad.x >= ad.y && ad.x >= ad.z) ? 0 : (ad.y >= ad.z ? 1 : 2);
    const int kx = kz == 2 ? 0 : kz + 1, ky = kx == 2 ? 0 : kx + 1;
    const float pc[3] = {p.x, p.y, p.z}, dc[3] = {d.x, d.y, d.z};
    const float sz = 1.0f / dc[kz], sx = dc[kx] * sz, sy = dc[ky] * sz;
    int stack[BVH_STACK];
    int sp = 0;
    stack[sp++] = 0;
    while (sp > 0) {
        const int node = stack[--sp];
        const float3 t0 = (lo[node].xyz - p) * inv;
        const float3 t1 = (hi[node].xyz - p) * inv;
        const float3 tn = fmin(t0, t1), tf = fmax(t0, t1);
        /* NaN from 0 * inf (ray on a slab face) is dropped by fmax/fmin */
        const float enter = fmax(fmax(tn.x, tn.y), tn.z);
        const float leave = fmin(fmin(tf.x, tf.y), tf.z);
        if (!(enter <= leave && leave >= tmin && enter <= tmax)) continue;
        const int2 nf = info[node];
        if (nf.x < 0) {
            if (leaf_hit(pc[kx], pc[ky], pc[kz], kx, ky, kz, sx, sy, sz, tmin, tmax,
                         tris + 9 * (-1 - nf.x))) return 1;
        } else if (sp + 2 <= BVH_STACK) {
            stack[sp++] = nf.y;
            stack[sp++] = nf.x;
        } else {
            return 1;  /* cannot happen for a balanced tree of < 2^60 triangles */
        }
    }
    return 0;
}

#endif
