// Derived vector ops, written once in terms of each target's primitives
// (Highway's habit: hwy/ops/generic_ops-inl.h, where a target that has a
// native sequence defines HWY_NATIVE_<OP> and the generic one steps aside).
// Included by simd.h after the target header, never directly.
//
// A target that maps one of these ops to a better instruction sequence
// defines the op itself and EK_HAVE_<OP> before this header. Each generic
// body is the operation sequence every target used before it moved here, so
// the kernels' bits did not change (the kernel-output hashes before and
// after are identical).
#ifndef EK_SIMD_GENERIC_H
#define EK_SIMD_GENERIC_H

// vmla(a, b, c) = a*b + c, fused where the target has FMA. The scalar target
// defines its own, unfused: baseline x86-64 has no FMA instruction and
// libm's fma is a slow software routine there (scalar.h).
#ifndef EK_HAVE_VMLA
static inline vreal vmla(vreal a, vreal b, vreal c) { return vfma(a, b, c); }
#endif

// vrsqrt(x) = 1/sqrt(x): the correctly rounded square root, then a
// correctly rounded divide (so every target gives the same bits).
static inline vreal vrsqrt(vreal a) { return vdiv(vset(1), vsqrt(a)); }

// vrsqrt_raw / vrsqrt_est. A target with a hardware estimate defines
// vrsqrt_raw (the instruction), EK_HAVE_VRSQRT_RAW, its documented relative
// error bound EK_RSQRT_RAW_TOL and the Newton steps EK_RSQRT_NEWTON that
// vrsqrt_est applies. Without an estimate both are the exact vrsqrt.
#ifdef EK_HAVE_VRSQRT_RAW
// Newton's step for 1/sqrt(a), y' = y (1.5 - (0.5 a y) y), with a fused
// 1.5 - (h y) y (vnmla is fused on every target that has an estimate). A
// step takes a relative error e to about 1.5 e^2, so one step on a 12- or
// 14-bit estimate reaches float precision and two on the 14-bit one reach
// double precision (the bound the test checks: tests/simd_ops.c).
static inline vreal vrsqrt_est(vreal a) {
  vreal y = vrsqrt_raw(a);
  vreal h = vmul(vset((real)0.5), a);
  for (int k = 0; k < EK_RSQRT_NEWTON; k++)
    y = vmul(y, vnmla(vmul(h, y), y, vset((real)1.5)));
  return y;
}
#else
#define EK_RSQRT_NEWTON 0
static inline vreal vrsqrt_raw(vreal a) { return vrsqrt(a); }
static inline vreal vrsqrt_est(vreal a) { return vrsqrt(a); }
#endif

// visfinite(x): x - x is 0 for finite x and NaN for inf or NaN.
static inline vmask visfinite(vreal a) { return veq(vsub(a, a), vzero()); }

// vsel_neg(m, a, b) = m ? -a : b. AVX-512 does it in one masked XOR.
#ifndef EK_HAVE_VSEL_NEG
static inline vreal vsel_neg(vmask m, vreal a, vreal b) { return vsel(m, vneg(a), b); }
#endif

// The record transposes, through a tile of np planes in L1: the records
// are copied field by field between p and the tile, the planes move as
// whole vectors. (Measured on Zen 4, AVX-512 float: 16-lane gathers for
// the loads cost as much as this; gathering the output runs from a
// just-stored tile cost 2x more: the gathers wait for the stores; README,
// "The AoS API".) AVX-512 transposes in registers (avx512.h).
#ifndef EK_HAVE_VRECORDS
static inline void vload_records(const real *p, int np, vreal *planes) {
  real tile[EK_RECORD_MAX * EK_W] __attribute__((aligned(64)));
  for (int l = 0; l < EK_W; l++)
    for (int k = 0; k < np; k++)
      tile[k * EK_W + l] = p[l * np + k];
  for (int k = 0; k < np; k++)
    planes[k] = vload(tile + k * EK_W);
}
static inline void vstore_records(real *p, int np, const vreal *planes) {
  real tile[EK_RECORD_MAX * EK_W] __attribute__((aligned(64)));
  for (int k = 0; k < np; k++)
    vstore(tile + k * EK_W, planes[k]);
  for (int l = 0; l < EK_W; l++)
    for (int k = 0; k < np; k++)
      p[l * np + k] = tile[k * EK_W + l];
}
#endif

// vsum_run3(o, rs, e, off, n, first): one 3x3 block of an assembled
// matrix (rows rs apart) plus n element blocks in order, each 9 values a
// plane stride es apart from e + off[j], summed in double:
//   o[i rs + m] = (((o[i rs + m] + e_0) + e_1) + ... + e_{n-1})
// (o's old value taken as 0 where first). A sum keeps its first NaN: once
// the partial sum is NaN it stays (quieted), as x86's add returns its first
// operand's NaN, whichever way the compiler orders the add's operands
// (kernels/fvm/hessian.c, the assembly, says why the order matters).
#ifndef EK_HAVE_VSUM_RUN3
static inline double vsum_nan_first_(double a, double b) { return a != a ? a + 0.0 : a + b; }
static inline void vsum_run3(double *o, size_t rs, const real *e, size_t es, const uint16_t *off,
                             int n, int first) {
  for (int i = 0; i < 3; i++)
    for (int m = 0; m < 3; m++) {
      double acc = first ? 0 : o[(size_t)i * rs + (size_t)m];
      for (int j = 0; j < n; j++)
        acc = vsum_nan_first_(acc, (double)e[off[j] + (size_t)(3 * i + m) * es]);
      o[(size_t)i * rs + (size_t)m] = acc;
    }
}
#endif

#endif
