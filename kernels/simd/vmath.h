// Elementary functions for the vector API, built on the generic ops of
// simd.h only (no new per-target primitive): include after simd.h.
#ifndef EK_SIMD_VMATH_H
#define EK_SIMD_VMATH_H

#include <math.h>

// Natural logarithm, lane-wise; vlog(x) = NaN for x < 0 or NaN, -inf for 0,
// +inf for +inf. Relative error a few ulp.
// Range reduction x = 2^e m with m in [sqrt(1/2), sqrt(2)) by conditional
// power-of-two scalings (a binary search on the exponent, so no exponent
// extraction primitive is needed), then log m = 2 atanh(f), f = (m-1)/(m+1),
// |f| <= 0.1716, from its series 2 f sum_k f^(2k)/(2k+1) (Abramowitz &
// Stegun 4.1.27; the same reduction as Cody & Waite 1980, ch. 5).
static inline vreal vlog(vreal x) {
  vreal one = vset(1), m = x, e = vzero();
#if defined(EK_REAL_F32)
  // Subnormals first (2^-149 .. 2^-126), then 2^64 .. 2^1 both ways.
  const real first = (real)0x1p100, first_inv = (real)0x1p-100;
  const int first_e = 100, top = 64;
  const real ln2_hi = 0.693145751953125f, ln2_lo = 1.428606765330187045e-06f;
  const int terms = 5;
#else
  const real first = 0x1p600, first_inv = 0x1p-600;
  const int first_e = 600, top = 512;
  const real ln2_hi = 6.93147180369123816490e-01, ln2_lo = 1.90821492927058770002e-10;
  const int terms = 11;
#endif
  vmask tiny = vlt(m, vset(first_inv));
  m = vsel(tiny, vmul(m, vset(first)), m);
  e = vsel(tiny, vset((real)-first_e), e);
  for (int k = top; k >= 1; k /= 2) {
    real p = (real)ldexp(1.0, k), pinv = (real)ldexp(1.0, -k);
    vmask big = vge(m, vset(p));
    m = vsel(big, vmul(m, vset(pinv)), m);
    e = vsel(big, vadd(e, vset((real)k)), e);
    vmask small = vlt(m, vset((real)ldexp(1.0, 1 - k)));
    m = vsel(small, vmul(m, vset(p)), m);
    e = vsel(small, vsub(e, vset((real)k)), e);
  }
  // m in [1, 2) now; move to [sqrt(1/2), sqrt(2)).
  vmask hi = vgt(m, vset((real)1.41421356237309504880));
  m = vsel(hi, vmul(m, vset((real)0.5)), m);
  e = vsel(hi, vadd(e, one), e);
  vreal f = vdiv(vsub(m, one), vadd(m, one));
  vreal z = vmul(f, f);
  vreal s = vset((real)(1.0 / (2 * terms - 1)));
  for (int k = terms - 2; k >= 0; k--)
    s = vmla(s, z, vset((real)(1.0 / (2 * k + 1))));
  vreal logm = vmul(vadd(f, f), s);
  vreal r = vmla(e, vset(ln2_hi), vmla(e, vset(ln2_lo), logm));
  r = vsel(veq(x, vset((real)INFINITY)), x, r);
  r = vsel(veq(x, vzero()), vset((real)-INFINITY), r);
  return vsel(vge(x, vzero()), r, vset((real)NAN));
}

#endif
