/* OpenCL built-ins on 16-lane vectors, for drivers that cannot take them whole: with
 * -D INVRAD_SPLIT16=1 each built-in that takes or gives a float16 / int16 is called on the
 * two 8-lane halves (lane for lane the same arithmetic).
 *
 * Why: PoCL 3.0 from PyPI (pocl-binary-distribution, LLVM 14, what pyopencl[pocl] installs)
 * on an AMD Zen 4 compiles kernels for -target-cpu znver3 (LLVM 14 does not know Zen 4; no
 * AVX-512) but links the built-ins of its AVX-512 library: a 512-bit vector argument then
 * has one ABI in the kernel and another in the built-in ("AVX vector argument of type
 * int16 without 'avx512f' enabled changes the ABI"), and LLVM aborts the process when the
 * kernel is first launched ("Do not know how to scalarize this operator's operand!",
 * "Cannot emit physreg copy instruction", "Cannot select: i64 = fsqrt"). One call of
 * any(int16), select, sqrt, log, fabs, fmax, vstore16 ... suffices; 8-lane (256-bit)
 * built-ins, operators (+ * / < & ?:) on 16-lane vectors and invrad's own functions are
 * compiled fine. So kernels use 16-lane vectors with operators, and these helpers for
 * built-ins; tests/core/accel/test_kernel_builds.py fails on a 16-lane built-in call
 * elsewhere.
 *
 * -D INVRAD_SPLIT16=1 is set by invrad_wb/core/accel/probe.py split16(), for that driver
 * only (INVRAD_OPENCL_SPLIT16=1 forces it); otherwise the helpers call the built-ins whole: other drivers run them, on an AVX-512 CPU faster
 * (Debian's PoCL on this Zen 4: the vote kernel 1.6 times as fast as split), and their
 * results stay bit for bit those of the kernels before the helpers (under
 * -cl-fast-relaxed-math the split form rounds some votes differently, by ~1e-7).
 */
#ifndef INVRAD_VEC16_H
#define INVRAD_VEC16_H

#if INVRAD_SPLIT16
#define V16_F1(f, x) ((float16)(f((x).lo), f((x).hi)))

inline float16 log16(const float16 x) { return V16_F1(log, x); }
inline float16 sqrt16(const float16 x) { return V16_F1(sqrt, x); }
inline float16 rsqrt16(const float16 x) { return V16_F1(rsqrt, x); }
inline float16 fabs16(const float16 x) { return V16_F1(fabs, x); }
inline float16 acos16(const float16 x) { return V16_F1(acos, x); }

inline float16 fmax16(const float16 x, const float y)
{
    return (float16)(fmax(x.lo, y), fmax(x.hi, y));
}

inline float16 clamp16(const float16 x, const float lo, const float hi)
{
    return (float16)(clamp(x.lo, lo, hi), clamp(x.hi, lo, hi));
}

/* select(a, b, c): b where c's lane is true (its sign bit set), else a */
inline float16 select16(const float16 a, const float16 b, const int16 c)
{
    return (float16)(select(a.lo, b.lo, c.lo), select(a.hi, b.hi, c.hi));
}

inline int any16(const int16 c) { return any(c.lo) | any(c.hi); }
inline int all16(const int16 c) { return all(c.lo) & all(c.hi); }

/* vstore16(v, 0, p) / vload16(0, p) for any address space: p[0..15] */
#define VSTORE16(v, p) (vstore8((v).lo, 0, (p)), vstore8((v).hi, 1, (p)))
#define VLOAD16_FLOAT(p) ((float16)(vload8(0, (p)), vload8(1, (p))))
#define VLOAD16_INT(p) ((int16)(vload8(0, (p)), vload8(1, (p))))

#else /* whole: not INVRAD_SPLIT16 */
inline float16 log16(const float16 x) { return log(x); }
inline float16 sqrt16(const float16 x) { return sqrt(x); }
inline float16 rsqrt16(const float16 x) { return rsqrt(x); }
inline float16 fabs16(const float16 x) { return fabs(x); }
inline float16 acos16(const float16 x) { return acos(x); }
inline float16 fmax16(const float16 x, const float y) { return fmax(x, y); }
inline float16 clamp16(const float16 x, const float lo, const float hi)
{
    return clamp(x, lo, hi);
}
inline float16 select16(const float16 a, const float16 b, const int16 c) { return select(a, b, c); }
inline int any16(const int16 c) { return any(c); }
inline int all16(const int16 c) { return all(c); }
#define VSTORE16(v, p) vstore16((v), 0, (p))
#define VLOAD16_FLOAT(p) vload16(0, (p))
#define VLOAD16_INT(p) vload16(0, (p))
#endif /* INVRAD_SPLIT16 */

#endif
