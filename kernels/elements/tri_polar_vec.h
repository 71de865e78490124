// Internal: the vectorised polar decomposition of a 3x2 F (seed 003 eqs.
// 14-20), written once against simd/simd.h and included by the kernel
// sources that need it: the public polar32 kernel
// (kernels/cloth/cloth_block.c, include/ek/cloth.h states its conventions)
// and the membrane energy and Hessian kernels
// (kernels/cloth_force/cloth_membrane_block.c), which read its SVD form
// F = s [u1 u2] diag(sigma1, sigma2) [v1 v2]^T. Its scalar double
// reference is reference/cloth/cloth_ref.c (ek_polar32 against LAPACK
// dgesvd, tests/test_cloth.c) and reference/cloth_force (the membrane).
//
// Only correctly rounded operations (add, mul, div, sqrt), no fused ones
// and the same order on every target: each ISA gives the same bits as the
// scalar build.
#ifndef EK_KERNELS_ELEMENTS_TRI_POLAR_VEC_H
#define EK_KERNELS_ELEMENTS_TRI_POLAR_VEC_H

#include <float.h>
#include <math.h>

#include "../simd/simd.h"

#if defined(EK_REAL_F32)
#define EK_TRI_MIN_NORMAL FLT_MIN
#else
#define EK_TRI_MIN_NORMAL DBL_MIN
#endif

EK_INLINE vreal dot3(const vreal a[3], const vreal b[3]) {
  return vadd(vadd(vmul(a[0], b[0]), vmul(a[1], b[1])), vmul(a[2], b[2]));
}

EK_INLINE void cross3(const vreal a[3], const vreal b[3], vreal c[3]) {
  c[0] = vsub(vmul(a[1], b[2]), vmul(a[2], b[1]));
  c[1] = vsub(vmul(a[2], b[0]), vmul(a[0], b[2]));
  c[2] = vsub(vmul(a[0], b[1]), vmul(a[1], b[0]));
}

// Largest |entry| of n values, and whether all of them are finite.
EK_INLINE vreal max_abs(const vreal *a, int n, vmask *finite) {
  vreal s = vabs(a[0]);
  vmask f = visfinite(a[0]);
  for (int i = 1; i < n; i++) {
    s = vmax(s, vabs(a[i]));
    f = vmand(f, visfinite(a[i]));
  }
  *finite = f;
  return s;
}

// ---- Eigenvector of the larger eigenvalue of a 2x2 symmetric matrix -------
// [[a, b], [b, c]], lambda1 = (a + c)/2 + h, h = sqrt(d^2 + b^2),
// d = (a - c)/2. (C - lambda1 I) v = 0 gives v = (h + d, b) from the second
// row and v = (b, h - d) from the first; the one without cancellation is
// taken (d >= 0: h + d >= 2|d|; d < 0: h - d > 0). h + d = 0 only when
// b = d = 0 (C a multiple of I): every vector is an eigenvector, (1, 0).
EK_INLINE void sym2_top_eigvec(vreal a, vreal b, vreal c, vreal v[2]) {
  vreal half = vset((real)0.5);
  vreal d = vmul(vsub(a, c), half);
  vreal h = vsqrt(vadd(vmul(d, d), vmul(b, b)));
  vmask dpos = vge(d, vzero());
  vreal x = vsel(dpos, vadd(h, d), b);
  vreal y = vsel(dpos, b, vsub(h, d));
  vreal n2 = vadd(vmul(x, x), vmul(y, y));
  vmask none = veq(n2, vzero());
  vreal inv = vrsqrt(vsel(none, vset(1), n2));
  v[0] = vsel(none, vset(1), vmul(x, inv));
  v[1] = vsel(none, vzero(), vmul(y, inv));
}

// ---- Polar decomposition of a 3x2 F (seed 003 eqs. 14-20) -----------------
// F = R Uc with C = F^T F = V diag(lambda) V^T, Uc = V diag(sigma) V^T and
// R = [u1 u2] V^T; cloth.h states the conventions. Steps:
//   1. scale F by its largest entry s (C's entries then lie in [0, 3]);
//   2. C, the top eigenvector v1 (sym2_top_eigvec), v2 = (-v1y, v1x);
//   3. u1 = F v1 / |F v1|, sigma1 = |F v1| (>= 1 after step 1);
//   4. u2 = n x u1, n = f1 x f2 / |f1 x f2|; sigma2 = |f1 x f2| / sigma1
//      (|f1 x f2|^2 = det C, without the cancellation of lambda1 lambda2
//      or of a c - b^2); rank-deficient: u2 from a coordinate axis;
//   5. R = u1 v1^T + u2 v2^T, Uc = s (sigma1 v1 v1^T + sigma2 v2 v2^T).
// The SVD form of steps 1-4, in the units of F / s: F = s U diag(sigma) V^T
// for a finite F (s = 0: rank 0, U = [e1 e2], sigma = 0).
typedef struct {
  vreal s;              // the scale: F's largest |entry| (step 1)
  vmask finite, rank0;  // F finite; F = 0
  vreal u1[3], u2[3];   // U's columns (u1 x u2 = the deformed normal at rank 2)
  vreal v1[2], v2[2];   // V's columns, det V = +1
  vreal sigma1, sigma2; // sigma1 >= sigma2 >= 0, scaled by 1 / s
} tri_svd_vec;

EK_INLINE void tri_svd32_vec(const vreal f[6], tri_svd_vec *d) {
  vreal zero = vzero(), one = vset(1);
  // 1. Scale.
  vmask finite;
  vreal s = max_abs(f, 6, &finite);
  vmask rank0 = veq(s, zero);
  vreal sd = vsel(vmand(finite, vmnot(rank0)), s, one);
  vreal c1[3], c2[3];
  for (int i = 0; i < 3; i++) {
    c1[i] = vdiv(f[2 * i], sd);
    c2[i] = vdiv(f[2 * i + 1], sd);
  }
  // 2. C = F^T F and its eigenvectors.
  vreal v1[2];
  sym2_top_eigvec(dot3(c1, c1), dot3(c1, c2), dot3(c2, c2), v1);
  vreal v2[2] = {vneg(v1[1]), v1[0]};
  // 3. u1 and sigma1.
  vreal w[3];
  for (int i = 0; i < 3; i++)
    w[i] = vadd(vmul(c1[i], v1[0]), vmul(c2[i], v1[1]));
  vreal w2 = dot3(w, w);
  vreal sigma1 = vsqrt(w2);
  vreal winv = vrsqrt(vsel(rank0, one, w2));
  vreal u1[3];
  for (int i = 0; i < 3; i++)
    u1[i] = vsel(rank0, i == 0 ? one : zero, vmul(w[i], winv));
  // 4. u2 from the normal (rank 2) or from the axis least aligned with u1.
  // n is accurate to ~eps sigma1 / sigma2 (the cross product of nearly
  // parallel columns); n x u1 is renormalised, and taken only while it is
  // clearly non-zero, so u2 is a unit vector orthogonal to u1 either way.
  vreal n[3], un[3];
  cross3(c1, c2, n);
  vreal n2 = dot3(n, n);
  cross3(n, u1, un);
  vreal un2 = dot3(un, un);
  vmask rank2 = vmand(vge(n2, vset(EK_TRI_MIN_NORMAL)), vgt(un2, vmul(n2, vset((real)0.5))));
  vreal uninv = vrsqrt(vsel(rank2, un2, one));
  vreal ax = vabs(u1[0]), ay = vabs(u1[1]), az = vabs(u1[2]);
  vmask kx = vmand(vle(ax, ay), vle(ax, az));
  vmask ky = vmand(vmnot(kx), vle(ay, az));
  // e_x x u = (0, -uz, uy), e_y x u = (uz, 0, -ux), e_z x u = (-uy, ux, 0).
  vreal p[3] = {vsel(kx, zero, vsel(ky, u1[2], vneg(u1[1]))),
                vsel(kx, vneg(u1[2]), vsel(ky, zero, u1[0])),
                vsel(kx, u1[1], vsel(ky, vneg(u1[0]), zero))};
  vreal pinv = vrsqrt(dot3(p, p)); // |p|^2 = 1 - u_k^2 >= 2/3
  vreal u2[3];
  for (int i = 0; i < 3; i++) {
    vreal perp = vsel(rank0, i == 1 ? one : zero, vmul(p[i], pinv));
    u2[i] = vsel(rank2, vmul(un[i], uninv), perp);
  }
  vreal sigma2 = vsel(rank0, zero, vdiv(vsqrt(n2), vsel(rank0, one, sigma1)));
  d->s = s, d->finite = finite, d->rank0 = rank0;
  for (int i = 0; i < 3; i++)
    d->u1[i] = u1[i], d->u2[i] = u2[i];
  d->v1[0] = v1[0], d->v1[1] = v1[1], d->v2[0] = v2[0], d->v2[1] = v2[1];
  d->sigma1 = sigma1, d->sigma2 = sigma2;
}

// R and Uc of F from its SVD form (cloth.h: NaN for a non-finite F).
EK_INLINE void polar32_vec(const vreal f[6], vreal R[6], vreal Uc[4]) {
  tri_svd_vec d;
  tri_svd32_vec(f, &d);
  const vreal s = d.s, sigma1 = d.sigma1, sigma2 = d.sigma2;
  const vmask finite = d.finite;
  const vreal *u1 = d.u1, *u2 = d.u2, *v1 = d.v1, *v2 = d.v2;
  // 5. R and Uc; NaN for a non-finite F.
  vreal nan = vset((real)NAN);
  for (int i = 0; i < 3; i++) {
    R[2 * i] = vsel(finite, vadd(vmul(u1[i], v1[0]), vmul(u2[i], v2[0])), nan);
    R[2 * i + 1] = vsel(finite, vadd(vmul(u1[i], v1[1]), vmul(u2[i], v2[1])), nan);
  }
  // Uc in the scaled units, then one multiplication by s (one rounding
  // when the output is subnormal).
  vreal u00 = vadd(vmul(sigma1, vmul(v1[0], v1[0])), vmul(sigma2, vmul(v2[0], v2[0])));
  vreal u01 = vadd(vmul(sigma1, vmul(v1[0], v1[1])), vmul(sigma2, vmul(v2[0], v2[1])));
  vreal u11 = vadd(vmul(sigma1, vmul(v1[1], v1[1])), vmul(sigma2, vmul(v2[1], v2[1])));
  u00 = vmul(u00, s), u01 = vmul(u01, s), u11 = vmul(u11, s);
  Uc[0] = vsel(finite, u00, nan);
  Uc[1] = Uc[2] = vsel(finite, u01, nan);
  Uc[3] = vsel(finite, u11, nan);
}

#endif
