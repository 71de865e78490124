// The warm-started polar decomposition on registers: the rotation R of
// A = R S (S symmetric), seeded with a guess (the previous step's rotation of
// the element), for EK_W matrices at once. Included by kernel sources after
// simd/simd.h (the polar kernel, and the FVM force kernel for fixed
// corotated / ARAP, which need R alone).
//
// The answer is the rotation that maximises tr(R^T A) over SO(3); with the
// rotation-variant SVD A = U diag(s) V^T (det U = det V = +1) that is
// R = U V^T, the SVD polar of include/ek/svd3.h, also for det A < 0.
//
// Iteration (Mueller, Bender, Chentanez, Macklin 2016, "A robust method to
// extract the rotational part of deformations", MIG 2016, eq. 8 and its
// listing: omega = sum_i r_i x a_i / (|sum_i r_i . a_i| + eps), R <- exp(omega)
// R, in a quaternion), with the Newton step of the analytic polar
// decomposition (Kugelstadt, Koschier, Bender 2018, "Fast corotated FEM
// using operator splitting", sec. 5): with M = A R^T, the objective
// f(theta) = tr(exp(-[theta]) M) near theta = 0 is
//   f ~ tr M + theta . g - theta^T H theta / 2,
//   g = (M21 - M12, M02 - M20, M10 - M01)  (= sum_i r_i x a_i, Mueller's
//                                           numerator, columns r_i, a_i)
//   H = tr(M) I - sym(M)                   (Mueller takes H ~ tr(M) I),
// so the Newton step is theta = H^-1 g. Near the answer H's eigenvalues are
// s_i + s_j, so Newton converges quadratically where Mueller's step
// converges linearly by the factor ~s_k / (s_1 + s_2 + s_3) (~1/3 per
// iteration at small stretch). [ek] Where H is not positive definite (far
// from the answer, inverted or flat elements) the step is Mueller's, which
// is always an ascent direction; a positive definite H makes Newton's one
// too (theta . g = g^T H^-1 g > 0).
//
// [ek] departures, for SIMD and cost:
//   - exp(theta) is replaced by the unit quaternion of (1, theta / 2) (the
//     Cayley map): angle 2 atan(|theta| / 2) = |theta| - |theta|^3 / 12 + ...,
//     so Newton's quadratic convergence is kept, no sin/cos is needed, and a
//     step of any size is a rotation by less than pi (the iteration cannot
//     leave SO(3) and a huge step cannot blow up);
//   - the quaternion is only roughly normalised between steps (by the
//     rsqrt estimate: g / |tr|, and H^-1 g, are invariant to the scale of
//     M, so the scale only has to stay bounded: a step of size |v| grows
//     |q|^2 by 1 + |v|^2, which overflowed float after a few huge steps far
//     from the answer) and R is formed from it by the homogeneous formula
//     divided by |q|^2 at the end, so the output is orthogonal to rounding
//     whatever the guess;
//   - A is scaled by 1 / max |a_ij| first, so det H (cubic in A) neither
//     overflows nor underflows for A at 1e+-30;
//   - a fixed iteration count (no tolerance test): branch-free lanes, and the
//     same bits on every thread count and schedule.
// The guess enters once, through its quaternion (Shepperd's choice of the
// largest diagonal term, by selects): a guess that is not a rotation is
// replaced by the rotation of that quaternion after the first step.
// Non-finite A or guess: NaN in R. A = 0: R = the guess's rotation
// (g = 0, Mueller's step is 0).
#ifndef EK_POLAR_WARM_CORE_H
#define EK_POLAR_WARM_CORE_H

#include "../svd3/svd3_core.h" // kernels.h, and the SVD of the kernels that include this

// Mueller's eps: only keeps 0 / 0 away (tr M = 0 with g = 0); M is of the
// order of |q|^2 >= 1 after the scaling of A unless A is 0.
#if defined(EK_REAL_F32)
#define POLAR_WARM_EPS ((real)1e-30)
#else
#define POLAR_WARM_EPS ((real)1e-300)
#endif

// Quaternion q = (w, x, y, z), unnormalised, of the rotation R (row-major),
// Shepperd 1978 ("Quaternion from rotation matrix", J. Guidance Control 1):
// with c_0 = 1 + tr R, c_k = 1 + 2 R_kk - tr R, the largest c picks the row
//   c_0: (c_0, R21 - R12, R02 - R20, R10 - R01)       (= 4 w q)
//   c_1: (R21 - R12, c_1, R01 + R10, R02 + R20)       (= 4 x q)
//   c_2: (R02 - R20, R01 + R10, c_2, R12 + R21)       (= 4 y q)
//   c_3: (R10 - R01, R02 + R20, R12 + R21, c_3)       (= 4 z q)
EK_INLINE void polar_warm_quat_from(const vreal R[9], vreal q[4]) {
  vreal one = vset(1), tr = vadd(vadd(R[0], R[4]), R[8]);
  vreal c0 = vadd(one, tr);
  vreal c1 = vadd(one, vsub(vadd(R[0], R[0]), tr));
  vreal c2 = vadd(one, vsub(vadd(R[4], R[4]), tr));
  vreal c3 = vadd(one, vsub(vadd(R[8], R[8]), tr));
  vreal d21 = vsub(R[7], R[5]), d02 = vsub(R[2], R[6]), d10 = vsub(R[3], R[1]);
  vreal s01 = vadd(R[1], R[3]), s02 = vadd(R[2], R[6]), s12 = vadd(R[5], R[7]);
  q[0] = c0, q[1] = d21, q[2] = d02, q[3] = d10;
  vreal best = c0;
  vmask m = vgt(c1, best);
  best = vsel(m, c1, best);
  q[0] = vsel(m, d21, q[0]), q[1] = vsel(m, c1, q[1]), q[2] = vsel(m, s01, q[2]);
  q[3] = vsel(m, s02, q[3]);
  m = vgt(c2, best);
  best = vsel(m, c2, best);
  q[0] = vsel(m, d02, q[0]), q[1] = vsel(m, s01, q[1]), q[2] = vsel(m, c2, q[2]);
  q[3] = vsel(m, s12, q[3]);
  m = vgt(c3, best);
  q[0] = vsel(m, d10, q[0]), q[1] = vsel(m, s02, q[1]), q[2] = vsel(m, s12, q[2]);
  q[3] = vsel(m, c3, q[3]);
}

// |q|^2 R(q / |q|) by the homogeneous formula (each entry quadratic in q).
EK_INLINE void polar_warm_quat_matrix(const vreal q[4], vreal R[9]) {
  vreal w = q[0], x = q[1], y = q[2], z = q[3];
  vreal ww = vmul(w, w), xx = vmul(x, x), yy = vmul(y, y), zz = vmul(z, z);
  vreal xy = vmul(x, y), xz = vmul(x, z), yz = vmul(y, z);
  vreal wx = vmul(w, x), wy = vmul(w, y), wz = vmul(w, z);
  vreal a = vsub(ww, xx), b = vsub(yy, zz);
  R[0] = vsub(vadd(ww, xx), vadd(yy, zz));
  R[4] = vadd(a, b);
  R[8] = vsub(a, b);
  R[1] = vmul(vset(2), vsub(xy, wz)), R[3] = vmul(vset(2), vadd(xy, wz));
  R[2] = vmul(vset(2), vadd(xz, wy)), R[6] = vmul(vset(2), vsub(xz, wy));
  R[5] = vmul(vset(2), vsub(yz, wx)), R[7] = vmul(vset(2), vadd(yz, wx));
}

// One step from M = A R^T (R = R(q) up to the scale |q|^2): theta, then
// q <- (1, theta / 2) (x) q (Hamilton product: the world-frame update
// R <- exp([theta]) R).
EK_INLINE void polar_warm_step(const vreal M[9], vreal q[4]) {
  vreal half = vset((real)0.5), zero = vzero();
  vreal g0 = vsub(M[7], M[5]), g1 = vsub(M[2], M[6]), g2 = vsub(M[3], M[1]);
  vreal t = vadd(vadd(M[0], M[4]), M[8]);
  // H = tr(M) I - sym(M).
  vreal h00 = vadd(M[4], M[8]), h11 = vadd(M[0], M[8]), h22 = vadd(M[0], M[4]);
  vreal h01 = vmul(vneg(half), vadd(M[1], M[3]));
  vreal h02 = vmul(vneg(half), vadd(M[2], M[6]));
  vreal h12 = vmul(vneg(half), vadd(M[5], M[7]));
  // adj(H) (symmetric) and det H.
  vreal a00 = vmls(h11, h22, vmul(h12, h12)), a11 = vmls(h00, h22, vmul(h02, h02));
  vreal a22 = vmls(h00, h11, vmul(h01, h01));
  vreal a01 = vmls(h02, h12, vmul(h01, h22)), a02 = vmls(h01, h12, vmul(h02, h11));
  vreal a12 = vmls(h01, h02, vmul(h00, h12));
  vreal det = vmla(h00, a00, vmla(h01, a01, vmul(h02, a02)));
  // H positive definite: its leading minors h00, a22, det all positive.
  vmask pd = vmand(vmand(vgt(h00, zero), vgt(a22, zero)), vgt(det, zero));
  // Newton theta = adj(H) g / det, else Mueller's g / (|tr M| + eps); half of
  // it goes into the quaternion.
  vreal den = vsel(pd, det, vadd(vabs(t), vset(POLAR_WARM_EPS)));
  vreal s = vdiv(half, den);
  vreal n0 = vmla(a00, g0, vmla(a01, g1, vmul(a02, g2)));
  vreal n1 = vmla(a01, g0, vmla(a11, g1, vmul(a12, g2)));
  vreal n2 = vmla(a02, g0, vmla(a12, g1, vmul(a22, g2)));
  vreal v0 = vmul(vsel(pd, n0, g0), s), v1 = vmul(vsel(pd, n1, g1), s);
  vreal v2 = vmul(vsel(pd, n2, g2), s);
  // (1, v) (x) (w, u) = (w - v . u, u + w v + v x u).
  vreal w = q[0], u0 = q[1], u1 = q[2], u2 = q[3];
  q[0] = vnmla(v0, u0, vnmla(v1, u1, vnmla(v2, u2, w)));
  q[1] = vmla(w, v0, vadd(u0, vmls(v1, u2, vmul(v2, u1))));
  q[2] = vmla(w, v1, vadd(u1, vmls(v2, u0, vmul(v0, u2))));
  q[3] = vmla(w, v2, vadd(u2, vmls(v0, u1, vmul(v1, u0))));
}

// M = A R^T: M_ij = row i of A . row j of R.
EK_INLINE void polar_warm_ART(const vreal A[9], const vreal R[9], vreal M[9]) {
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      M[i * 3 + j] = vmla(A[i * 3], R[j * 3],
                          vmla(A[i * 3 + 1], R[j * 3 + 1], vmul(A[i * 3 + 2], R[j * 3 + 2])));
}

// n (1 or 2, a compile-time constant at the call) independent matrices
// stage by stage, so their dependency chains interleave (the SVD kernel's
// svd3_core_n idea); per lane the same operations as polar_warm_core.
#define POLAR_WARM_MAX_N 2
EK_INLINE void polar_warm_core_n(int n, const vreal A_in[][9], vreal R[][9], int iters) {
  vreal A[POLAR_WARM_MAX_N][9], q[POLAR_WARM_MAX_N][4], M[POLAR_WARM_MAX_N][9];
  for (int j = 0; j < n; j++) {
    vreal amax = vabs(A_in[j][0]);
    for (int i = 1; i < 9; i++)
      amax = vmax(amax, vabs(A_in[j][i]));
    vreal inv = vdiv(vset(1), vsel(vgt(amax, vzero()), amax, vset(1)));
    for (int i = 0; i < 9; i++)
      A[j][i] = vmul(A_in[j][i], inv);
    polar_warm_quat_from(R[j], q[j]);
    polar_warm_ART(A[j], R[j], M[j]);
  }
  for (int j = 0; j < n; j++)
    polar_warm_step(M[j], q[j]);
  for (int it = 1; it < iters; it++) {
    for (int j = 0; j < n; j++) {
      vreal Rq[9];
      vreal n2 = vmla(q[j][0], q[j][0],
                      vmla(q[j][1], q[j][1], vmla(q[j][2], q[j][2], vmul(q[j][3], q[j][3]))));
      vreal rn = vrsqrt_est(n2);
      for (int i = 0; i < 4; i++)
        q[j][i] = vmul(q[j][i], rn);
      polar_warm_quat_matrix(q[j], Rq);
      polar_warm_ART(A[j], Rq, M[j]);
    }
    for (int j = 0; j < n; j++)
      polar_warm_step(M[j], q[j]);
  }
  for (int j = 0; j < n; j++) {
    polar_warm_quat_matrix(q[j], R[j]);
    vreal n2 = vmla(q[j][0], q[j][0],
                    vmla(q[j][1], q[j][1], vmla(q[j][2], q[j][2], vmul(q[j][3], q[j][3]))));
    vreal rn2 = vdiv(vset(1), n2);
    for (int i = 0; i < 9; i++)
      R[j][i] = vmul(R[j][i], rn2);
  }
}

// R: in, the guess; out, the rotation of A after `iters` steps (>= 1).
EK_INLINE void polar_warm_core(const vreal A_in[9], vreal R[9], int iters) {
  // [ek] Scale A by 1 / max |a_ij| (1 for A = 0; a non-finite entry stays
  // non-finite or becomes NaN, which then reaches every entry of R).
  vreal amax = vabs(A_in[0]);
  for (int i = 1; i < 9; i++)
    amax = vmax(amax, vabs(A_in[i]));
  vreal inv = vdiv(vset(1), vsel(vgt(amax, vzero()), amax, vset(1)));
  vreal A[9];
  for (int i = 0; i < 9; i++)
    A[i] = vmul(A_in[i], inv);
  vreal q[4], M[9];
  polar_warm_quat_from(R, q);
  // The first step takes M from the guess itself (a rotation in the loops;
  // R(q) = R there up to the scale |q|^2, which the step ignores).
  polar_warm_ART(A, R, M);
  polar_warm_step(M, q);
  for (int it = 1; it < iters; it++) {
    vreal Rq[9];
    vreal n2 = vmla(q[0], q[0], vmla(q[1], q[1], vmla(q[2], q[2], vmul(q[3], q[3]))));
    vreal rn = vrsqrt_est(n2);
    for (int i = 0; i < 4; i++)
      q[i] = vmul(q[i], rn);
    polar_warm_quat_matrix(q, Rq);
    polar_warm_ART(A, Rq, M);
    polar_warm_step(M, q);
  }
  polar_warm_quat_matrix(q, R);
  vreal n2 = vmla(q[0], q[0], vmla(q[1], q[1], vmla(q[2], q[2], vmul(q[3], q[3]))));
  vreal rn2 = vdiv(vset(1), n2);
  for (int i = 0; i < 9; i++)
    R[i] = vmul(R[i], rn2);
}

#endif
