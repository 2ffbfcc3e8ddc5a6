/* Segment occlusion against the scene BVH (see invrad_wb/core/bvh.py for the layout).
 *
 * Nodes: lo[i].xyz, hi[i].xyz bounds; info[i] = (left, right) for internal nodes,
 * (-1 - leaf, 0) for leaves. Leaves: 9 float16 rows per leaf (v0 xyz, e1 xyz, e2 xyz),
 * 16 triangles tested at once with vector operations (PoCL vectorises explicit vectors,
 * not scalar work-items). Numpy twin: segments_occluded_numpy().
 */
#ifndef INVRAD_BVH_H
#define INVRAD_BVH_H

#define BVH_STACK 64

inline int leaf_hit(const float3 o, const float3 d, const float tmin, const float tmax,
                    __global const float16 *leaf)
{
    const float16 v0x = leaf[0], v0y = leaf[1], v0z = leaf[2];
    const float16 e1x = leaf[3], e1y = leaf[4], e1z = leaf[5];
    const float16 e2x = leaf[6], e2y = leaf[7], e2z = leaf[8];
    /* pvec = d x e2 */
    const float16 px = d.y * e2z - d.z * e2y;
    const float16 py = d.z * e2x - d.x * e2z;
    const float16 pz = d.x * e2y - d.y * e2x;
    const float16 det = e1x * px + e1y * py + e1z * pz;
    const float16 inv = 1.0f / det;
    const float16 tx = o.x - v0x, ty = o.y - v0y, tz = o.z - v0z;
    const float16 u = (tx * px + ty * py + tz * pz) * inv;
    /* qvec = tvec x e1 */
    const float16 qx = ty * e1z - tz * e1y;
    const float16 qy = tz * e1x - tx * e1z;
    const float16 qz = tx * e1y - ty * e1x;
    const float16 v = (d.x * qx + d.y * qy + d.z * qz) * inv;
    const float16 t = (e2x * qx + e2y * qy + e2z * qz) * inv;
    const int16 hit = (fabs(det) > 1e-20f) & (u >= 0.0f) & (v >= 0.0f) & (u + v <= 1.0f)
                      & (t > tmin) & (t < tmax);
    return any(hit);
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
            if (leaf_hit(p, d, tmin, tmax, tris + 9 * (-1 - nf.x))) return 1;
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
