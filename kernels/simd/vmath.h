// Elementary functions for the vector API, built on the generic ops of
// simd.h and its exponent extraction vmant_exp: include after simd.h.
#ifndef EK_SIMD_VMATH_H
#define EK_SIMD_VMATH_H

#include <math.h>

#define EK_VLOG_TOL_EPS 4

// Natural logarithm, lane-wise; vlog(x) = NaN for x < 0 or NaN, -inf for 0,
// +inf for +inf. Relative error <= EK_VLOG_TOL_EPS machine epsilons (a few
// ulp; tests/test_simd.c checks it on every target).
// Reduction x = 2^e m with m in [sqrt(1/2), sqrt(2)) (vmant_exp; subnormals
// scaled into the normal range first), then log m = 2 atanh(f),
// f = (m-1)/(m+1), |f| <= 0.1716, from its series 2 f sum_k f^(2k)/(2k+1)
// (Abramowitz & Stegun 4.1.27; the reduction of Cody & Waite 1980, ALOG),
// and log x = e ln2_hi + (e ln2_lo + log m) with ln 2 split so e ln2_hi is
// exact.
static inline vreal vlog(vreal x) {
  vreal one = vset(1);
#if defined(EK_REAL_F32)
  const real min_normal = 0x1p-126f, up = 0x1p32f, up_e = 32;
  const real ln2_hi = 0.693145751953125f, ln2_lo = 1.428606765330187045e-06f;
  const int terms = 5; // f^10/11 < 6e-9 relative
#else
  const real min_normal = 0x1p-1022, up = 0x1p64, up_e = 64;
  const real ln2_hi = 6.93147180369123816490e-01, ln2_lo = 1.90821492927058770002e-10;
  const int terms = 11; // f^22/23 < 1e-18 relative
#endif
  vmask sub = vlt(x, vset(min_normal));
  vreal e, m = vmant_exp(vsel(sub, vmul(x, vset(up)), x), &e);
  e = vsel(sub, vsub(e, vset(up_e)), e);
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
