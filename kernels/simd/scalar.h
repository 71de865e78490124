// Portable scalar target: one lane, plain C. Included through simd.h only.
#ifndef EK_SIMD_SCALAR_H
#define EK_SIMD_SCALAR_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>

#define EK_W 1
typedef real vreal;
typedef int vmask;

static inline vreal vset(real x) { return x; }
static inline vreal vzero(void) { return 0; }
static inline vreal vload(const real *p) { return *p; }
static inline void vstore(real *p, vreal v) { *p = v; }
// No streaming store on the scalar target: a plain one (simd.h).
static inline void vstream(real *p, vreal v) { *p = v; }
#define EK_NO_VSTREAM

static inline vreal vadd(vreal a, vreal b) { return a + b; }
static inline vreal vsub(vreal a, vreal b) { return a - b; }
static inline vreal vmul(vreal a, vreal b) { return a * b; }
static inline vreal vdiv(vreal a, vreal b) { return a / b; }
static inline vreal vneg(vreal a) { return -a; }
#if defined(EK_REAL_F32)
static inline vreal vabs(vreal a) { return fabsf(a); }
static inline vreal vsqrt(vreal a) { return sqrtf(a); }
static inline vreal vfma(vreal a, vreal b, vreal c) { return fmaf(a, b, c); }
#else
static inline vreal vabs(vreal a) { return fabs(a); }
static inline vreal vsqrt(vreal a) { return sqrt(a); }
static inline vreal vfma(vreal a, vreal b, vreal c) { return fma(a, b, c); }
#endif
// Same operand order and NaN behaviour as the x86 min/max instructions
// (second operand returned when either is NaN), so all targets agree.
static inline vreal vmin(vreal a, vreal b) { return a < b ? a : b; }
static inline vreal vmax(vreal a, vreal b) { return a > b ? a : b; }
// Unfused (baseline x86-64 has no FMA instruction; libm's fma is a slow
// software routine there): the generic vmla is vfma.
#define EK_HAVE_VMLA
static inline vreal vmla(vreal a, vreal b, vreal c) { return a * b + c; }
static inline vreal vmls(vreal a, vreal b, vreal c) { return a * b - c; }
static inline vreal vnmla(vreal a, vreal b, vreal c) { return c - a * b; }

static inline vmask vlt(vreal a, vreal b) { return a < b; }
static inline vmask vle(vreal a, vreal b) { return a <= b; }
static inline vmask vgt(vreal a, vreal b) { return a > b; }
static inline vmask vge(vreal a, vreal b) { return a >= b; }
static inline vmask veq(vreal a, vreal b) { return a == b; }
static inline vmask vmand(vmask a, vmask b) { return a && b; }
static inline vmask vmor(vmask a, vmask b) { return a || b; }
static inline vmask vmnot(vmask a) { return !a; }
static inline vreal vsel(vmask m, vreal a, vreal b) { return m ? a : b; }
static inline vreal vxorsign(vreal y, vreal x) { return signbit(x) ? -y : y; }
static inline int vany(vmask m) { return m; }
static inline int vall(vmask m) { return m; }

// vmant_exp(x, &e): x = m 2^e with m in [1, 2) and e an integer (as a
// vreal), for positive normal x only (subnormal, zero, negative, inf, NaN
// give unspecified m and e: callers select those lanes away). Exponent
// extraction for vlog (kernels/simd/vmath.h).
static inline vreal vmant_exp(vreal x, vreal *e) {
  int k;
#if defined(EK_REAL_F32)
  real m = frexpf(x, &k); // m in [0.5, 1)
#else
  real m = frexp(x, &k);
#endif
  *e = (real)(k - 1);
  return m + m;
}
// vgather(x, idx): x[idx], x[0] for idx < 0 (padding).
static inline vreal vgather(const real *x, const int32_t *idx) { return x[*idx < 0 ? 0 : *idx]; }
// vgather_points(x, idx, p): p[k] lane l = x[3 idx[l] + k] (x: points,
// n x 3), EK_W int32 indices from idx; a lane with idx < 0 (padding) reads
// point 0 and is set in the returned mask. Indices below 2^31 / 3.
static inline vmask vgather_points(const real *x, const int32_t *idx, vreal p[3]) {
  int32_t v = *idx < 0 ? 0 : *idx;
  p[0] = x[(size_t)v * 3], p[1] = x[(size_t)v * 3 + 1], p[2] = x[(size_t)v * 3 + 2];
  return *idx < 0;
}

#endif
