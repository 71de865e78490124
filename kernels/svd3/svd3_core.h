// The 3x3 SVD on registers: one vreal per matrix entry, EK_W matrices at once.
// Included by kernel sources after simd/simd.h (the SVD kernel and every
// kernel that needs a polar decomposition inline, e.g. materials).
//
// Algorithm (McAdams, Selle, Tamstorf, Teran, Sifakis 2011, "Computing the
// Singular Value Decomposition of 3x3 matrices with minimal branching and
// elementary floating point operations", UW-Madison TR1690), with ek's
// changes marked:
//   0. [ek] non-finite lanes are found from the trace of step 2 and set to
//      NaN at the end
//   1. [ek] scale A by 1/max|a_ij| (after a power-of-two prescale of tiny
//      matrices) so A^T A neither overflows nor underflows
//   2. S = A^T A
//   3. Jacobi eigenanalysis of S with approximate Givens rotations (TR1690
//      sec. 2, with its pi/8 fallback), accumulated in a quaternion; [ek]
//      beyond the default sweeps, with subnormals flushed to zero
//      (svd3_jacobi_sweeps)
//   4. V from the quaternion, B = A V
//   5. [ek] one-sided Jacobi sweeps (Hestenes) on the columns of B with exact
//      angles: step 3 works on A^T A and squares the condition number, so once
//      s1/s2 >~ 1e3 no number of sweeps meets the float budget; this step
//      works on A itself (DESIGN.md, "Accuracy")
//   6. sort columns of B and V by norm, descending, keeping det V = +1
//   7. QR of B by Givens rotations: B = U R, S = diag(R)
// Conventions: A = U diag(S) V^T, det U = det V = +1, S0 >= S1 >= |S2|.
// A rotation in plane (p,q) maps e_p -> c e_p + s e_q, e_q -> -s e_p + c e_q,
// i.e. a rotation by +theta about e_k with (p,q,k) cyclic.
#ifndef EK_SVD3_CORE_H
#define EK_SVD3_CORE_H

#include <math.h>

#include <ek/svd3.h>

#include "kernels.h"

// Below TINY (after scaling, relative to the largest entry) a rotation
// angle is taken as zero. TINY^2 is a normal number of the precision and far
// below its budget: 1e-36 for float; 1e-300 for double, so a 2x2 block
// living at 1e-10 of the largest singular value (a graded matrix) still gets
// its rotations and its singular values to 1e-12 of s1.
#if defined(EK_REAL_F32)
#define SVD3_TINY2 ((real)1e-36)
#else
#define SVD3_TINY2 ((real)1e-300)
#endif

// TINY = sqrt(TINY2), a normal number of the precision.
#if defined(EK_REAL_F32)
#define SVD3_TINY ((real)1e-18)
#else
#define SVD3_TINY ((real)1e-150)
#endif

EK_INLINE vreal svd3_rsq(vreal x, int exact) { return exact ? vrsqrt(x) : vrsqrt_est(x); }

// 1/sqrt(x) where only the direction of a rotation depends on it, not its
// orthogonality: the Givens half-angle of step 3 (whose rotations are
// accumulated in a quaternion that step 4 normalises) and the angle of a
// one-sided pair (step 5). With the approximate rsqrt, cheaper estimates
// are enough when exact one-sided sweeps follow (rough = 1): an angle off
// by a relative d leaves an off-diagonal residue of d times the pair's,
// which the following sweeps remove. Step 3 takes the bare hardware
// estimate (vrsqrt_raw: d <= 2^-14 AVX-512, 1.5 2^-12 AVX2 float). Step 5
// takes it too in float; in double its last sweep's residue, d times the
// pair's, must stay below 1e-12, so it takes one Newton step (d ~ 2^-28;
// measured with ek-verify, AVX-512, worst of every family: bare 1.3e-9,
// one step 7.3e-14, two steps 6.5e-14 for 2% more time). Without those
// sweeps (refine none, McAdams et al. 2011 as published) the estimate gets
// its Newton steps, as in TR1690.
EK_INLINE vreal svd3_rsq_angle(vreal x, int exact, int rough) {
  if (rough && !exact)
    return vrsqrt_raw(x);
  return svd3_rsq(x, exact);
}

EK_INLINE vreal svd3_rsq_onesided(vreal x, int exact) {
#if defined(EK_REAL_F32)
  return svd3_rsq_angle(x, exact, 1);
#else
  if (exact)
    return vrsqrt(x);
  vreal y = vrsqrt_raw(x); // y (1.5 - 0.5 x y^2): Newton on 1/sqrt
  return vmul(y, vnmla(vmul(vmul(vset(0.5), x), y), y, vset(1.5)));
#endif
}

// Index of entry (i, j) of the symmetric S of step 3 stored as its 6
// distinct entries: the diagonal s_ii at i, s_01, s_12, s_20 at 3, 4, 5.
// Each entry is stored once: with 4 vectors the state lives in memory
// (svd3_jacobi_sweep), where the full 3x3's mirrored copies were a store
// each (3 of a pair's 12). The same values, so the same bits.
EK_INLINE int svd3_sym(int i, int j) { return i == j ? i : i + j == 1 ? 3 : i + j == 3 ? 4 : 5; }

// Step 3, one pair: approximate Givens half-angle (ch, sh) for the (p,q)
// block of the symmetric S, conjugate S by it and append it to quaternion
// qt = (w, x, y, z). McAdams et al. 2011 (TR1690), sec. 2.
EK_INLINE void svd3_jacobi_pair(vreal s[6], vreal qt[4], int p, int q, int k, int exact,
                                int rough) {
  const real gamma = (real)5.82842712474619009760; // 3 + 2 sqrt(2) = cot^2(pi/8)
  const real cstar = (real)0.92387953251128675613; // cos(pi/8)
  const real sstar = (real)0.38268343236508977173; // sin(pi/8)
  vreal a = s[p], d = s[q], b = s[svd3_sym(p, q)], e = s[svd3_sym(p, k)], f = s[svd3_sym(q, k)];
  vreal ch = vmul(vset(2), vsub(a, d)), sh = b;
  // Use the exact-angle direction unless the angle is beyond pi/8 (then the
  // fixed pi/8 rotation still reduces the off-diagonal); no rotation when
  // the block is already negligible (a unit (ch, sh) keeps the quaternion
  // unit, whatever the scale).
  vreal ch2 = vmul(ch, ch), sh2 = vmul(sh, sh), n2 = vadd(ch2, sh2);
  vmask exact_angle = vlt(vmul(vset(gamma), sh2), ch2);
  vmask negligible = vle(n2, vset(SVD3_TINY2));
  vreal om = svd3_rsq_angle(vmax(n2, vset(SVD3_TINY2)), exact, rough);
  ch = vsel_op(exact_angle, vmul(om, ch), vset(cstar));
  sh = vsel_op(exact_angle, vmul(om, sh), vset(sstar));
  ch = vsel_op(negligible, vset(1), ch);
  sh = vsel_op(negligible, vzero(), sh);
  // cos and sin of the full angle.
  vreal c = vmls(ch, ch, vmul(sh, sh)), sn = vmul(vadd(ch, ch), sh);
  // S <- Q^T S Q on the (p,q) block, with w = (d - a) s + 2 c b:
  //   s_pp = c^2 a + 2cs b + s^2 d = a + s w,   s_qq = d - s w (trace kept),
  //   s_pq = (d - a) cs + (c^2 - s^2) b = c w - b.
  vreal w = vmla(vsub(d, a), sn, vmul(vadd(c, c), b));
  s[p] = vmla(sn, w, a);
  s[q] = vnmla(sn, w, d);
  s[svd3_sym(p, q)] = vmls(c, w, b);
  s[svd3_sym(p, k)] = vmla(c, e, vmul(sn, f));
  s[svd3_sym(q, k)] = vmls(c, f, vmul(sn, e));
  // qt <- qt (x) (ch, sh e_k), Hamilton product: the rotation is appended
  // on the right (V <- V Q).
  int k1 = (k + 1) % 3, k2 = (k + 2) % 3;
  vreal qw = qt[0], vk = qt[1 + k], vk1 = qt[1 + k1], vk2 = qt[1 + k2];
  qt[0] = vmls(ch, qw, vmul(sh, vk));
  qt[1 + k] = vmla(qw, sh, vmul(ch, vk));
  qt[1 + k1] = vmla(sh, vk2, vmul(ch, vk1));
  qt[1 + k2] = vmls(ch, vk2, vmul(sh, vk1));
}

// Step 4: rotation matrix of the (normalised) quaternion.
EK_INLINE void svd3_quat_to_matrix(const vreal qt[4], vreal V[9], int exact) {
  vreal n2 = vmla(qt[0], qt[0], vmla(qt[1], qt[1], vmla(qt[2], qt[2], vmul(qt[3], qt[3]))));
  vreal inv = svd3_rsq(n2, exact);
  vreal w = vmul(qt[0], inv), x = vmul(qt[1], inv), y = vmul(qt[2], inv), z = vmul(qt[3], inv);
  vreal one = vset(1), two = vset(2);
  vreal xx = vmul(x, x), yy = vmul(y, y), zz = vmul(z, z);
  vreal xy = vmul(x, y), xz = vmul(x, z), yz = vmul(y, z);
  vreal wx = vmul(w, x), wy = vmul(w, y), wz = vmul(w, z);
  V[0] = vsub(one, vmul(two, vadd(yy, zz)));
  V[1] = vmul(two, vsub(xy, wz));
  V[2] = vmul(two, vadd(xz, wy));
  V[3] = vmul(two, vadd(xy, wz));
  V[4] = vsub(one, vmul(two, vadd(xx, zz)));
  V[5] = vmul(two, vsub(yz, wx));
  V[6] = vmul(two, vsub(xz, wy));
  V[7] = vmul(two, vadd(yz, wx));
  V[8] = vsub(one, vmul(two, vadd(xx, yy)));
}

// Rotate columns p, q of a row-major 3x3 M by (c, s): M <- M Q.
EK_INLINE void svd3_rotate_cols(vreal M[9], int p, int q, vreal c, vreal s) {
  for (int r = 0; r < 3; r++) {
    vreal mp = M[3 * r + p], mq = M[3 * r + q];
    M[3 * r + p] = vmla(c, mp, vmul(s, mq));
    M[3 * r + q] = vmls(c, mq, vmul(s, mp));
  }
}

// Entry col of rows i, j of a row-major 3x3 M <- G M, G the rotation (c, s).
EK_INLINE void svd3_rotate_row_pair(vreal M[9], int i, int j, int col, vreal c, vreal s) {
  vreal mi = M[3 * i + col], mj = M[3 * j + col];
  M[3 * i + col] = vmla(c, mi, vmul(s, mj));
  M[3 * j + col] = vmls(c, mj, vmul(s, mi));
}

EK_INLINE vreal svd3_col_dot(const vreal M[9], int p, int q) {
  return vmla(M[p], M[q], vmla(M[3 + p], M[3 + q], vmul(M[6 + p], M[6 + q])));
}

// Step 5, one pair: the exact Jacobi angle that makes columns p and q of B
// orthogonal (Hestenes' one-sided Jacobi), the small rotation |theta| <=
// pi/4: tan(theta) = sgn(x) y / (|x| + sqrt(x^2 + y^2)) with x = |b_p|^2 -
// |b_q|^2, y = 2 b_p.b_q, which solves tan(2 theta) = y / x without division.
// [ek] t = |x| + sqrt(x^2 + y^2) + TINY > 0, so (c, s) = (t, u) / |(t, u)|
// needs no test: a negligible pair (x, y ~ 0) gets c = 1, s = 0 (up to the
// rounding of 1/sqrt), and TINY is far below any angle that matters.
// svd3_refine_angle rotates B and returns (c, s); svd3_refine_pair also
// rotates V.
EK_INLINE void svd3_refine_angle(vreal B[9], int p, int q, int exact, vreal *cout, vreal *sout) {
  vreal alpha = svd3_col_dot(B, p, p), beta = svd3_col_dot(B, q, q);
  vreal gam = svd3_col_dot(B, p, q);
  vreal x = vsub(alpha, beta), y = vadd(gam, gam);
  vreal z = vmla(x, x, vmul(y, y));
  vreal r = vmul(z, svd3_rsq_onesided(vmax(z, vset(SVD3_TINY2)), exact)); // sqrt(z)
  vreal t = vadd(vadd(vabs(x), vset(SVD3_TINY)), r);
  vreal u = vxorsign(y, x); // x = alpha - beta is never -0
  vreal om = svd3_rsq(vmla(t, t, vmul(u, u)), exact);
  // Columns already orthogonal (y = 0: the identity, diagonal and zero
  // matrices) keep c exactly 1, so U and V stay exact there; the estimated
  // 1/sqrt would leave c = 1 +- 1e-7.
  vreal c = vsel_op(veq(u, vzero()), vset(1), vmul(t, om)), s = vmul(u, om);
  svd3_rotate_cols(B, p, q, c, s);
  *cout = c, *sout = s;
}

EK_INLINE void svd3_refine_pair(vreal B[9], vreal V[9], int p, int q, int exact) {
  vreal c, s;
  svd3_refine_angle(B, p, q, exact, &c, &s);
  svd3_rotate_cols(V, p, q, c, s);
}

// Step 6, one conditional swap: if |b_i| < |b_j| swap columns i and j of B
// and V and negate the new column j, so det V stays +1.
EK_INLINE void svd3_sort_pair(vreal B[9], vreal V[9], vreal rho[3], int i, int j) {
  vmask m = vlt(rho[i], rho[j]);
  for (int r = 0; r < 3; r++) {
    vreal bi = B[3 * r + i], bj = B[3 * r + j], vi = V[3 * r + i], vj = V[3 * r + j];
    B[3 * r + i] = vsel_op(m, bj, bi);
    B[3 * r + j] = vsel_neg(m, bi, bj);
    V[3 * r + i] = vsel_op(m, vj, vi);
    V[3 * r + j] = vsel_neg(m, vi, vj);
  }
  vreal ri = rho[i];
  rho[i] = vsel_op(m, rho[j], ri);
  rho[j] = vsel_op(m, ri, rho[j]);
}

// Step 7, Givens rotation that zeroes a2 against a1 (the QR step of
// TR1690): c = a1/n, s = a2/n, so the diagonal entry becomes n >= 0; the
// identity when both are negligible (rank-deficient B).
EK_INLINE void svd3_givens(vreal a1, vreal a2, vreal *c, vreal *s, int exact) {
  vreal n2 = vmla(a1, a1, vmul(a2, a2));
  vmask ok = vgt(n2, vset(SVD3_TINY2));
  vreal om = svd3_rsq(vmax(n2, vset(SVD3_TINY2)), exact);
  *c = vsel_op(ok, vmul(a1, om), vset(1));
  *s = vsel_op(ok, vmul(a2, om), vzero());
}

// Working state of one vector of matrices through the steps below.
typedef struct {
  vreal A[9], s[6], qt[4], B[9], V[9], amax;
  vmask finite;
} svd3_state;

// Steps 0-2: non-finite lanes, scaling, S = A^T A.
// The scale is 1/max|a_ij|, after an exact power-of-two prescale of tiny
// matrices so that subnormal entries become normal and 1/max stays finite.
#if defined(EK_REAL_F32)
#define SVD3_TINY_MATRIX 0x1p-64f
#define SVD3_PRESCALE 0x1p64f
#else
#define SVD3_TINY_MATRIX 0x1p-512
#define SVD3_PRESCALE 0x1p512
#endif
EK_INLINE void svd3_start(svd3_state *st, const vreal Ain[9]) {
  vreal one = vset(1), zero = vzero();
  vreal amax = zero;
  for (int i = 0; i < 9; i++)
    amax = vmax(amax, vabs(Ain[i]));
  vreal pre = vsel_op(vlt(amax, vset(SVD3_TINY_MATRIX)), vset(SVD3_PRESCALE), one);
  // The zero matrix gets sc = 1 (any finite value would do).
  vreal m = vmul(amax, pre);
  vreal sc = vsel_op(vgt(m, zero), vdiv(one, m), one);
  for (int i = 0; i < 9; i++)
    st->A[i] = vmul(vmul(Ain[i], pre), sc);
  st->amax = amax;
  for (int i = 0; i < 3; i++)
    for (int j = i; j < 3; j++)
      st->s[svd3_sym(i, j)] = svd3_col_dot(st->A, i, j);
  st->qt[0] = one, st->qt[1] = st->qt[2] = st->qt[3] = zero;
  // [ek] Step 0 without a test per entry: a finite A has a scaled Gram
  // trace in [0, 9]. A NaN or infinity leaves a NaN or infinity in the
  // scaled A (inf / inf, inf * 0, or the entry itself when max lost a NaN),
  // hence in the trace. Such a lane runs on (lanes never mix) and every
  // output of it is set to NaN at the end.
  st->finite = visfinite(vadd(vadd(st->s[0], st->s[1]), st->s[2]));
}

// Step 4: V from the quaternion, B = A V.
EK_INLINE void svd3_form_B(svd3_state *st, int exact) {
  svd3_quat_to_matrix(st->qt, st->V, exact);
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      st->B[3 * i + j] =
          vmla(st->A[3 * i], st->V[j],
               vmla(st->A[3 * i + 1], st->V[3 + j], vmul(st->A[3 * i + 2], st->V[6 + j])));
}

// Steps 6-8: sort, QR, NaN for non-finite input. S is left scaled (the
// singular values of the scaled matrix, O(1)); the caller multiplies by
// *scale (so a polar stretch of a tiny matrix is also formed at O(1) and
// rounded into the subnormal range once).
EK_INLINE void svd3_finish(svd3_state *st, vreal U[9], vreal S[3], vreal V[9], vreal *scale,
                           int exact) {
  vreal *B = st->B;
  vreal rho[3] = {svd3_col_dot(B, 0, 0), svd3_col_dot(B, 1, 1), svd3_col_dot(B, 2, 2)};
  svd3_sort_pair(B, st->V, rho, 0, 1);
  svd3_sort_pair(B, st->V, rho, 0, 2);
  svd3_sort_pair(B, st->V, rho, 1, 2);
  // QR: B = U R with U = G1^T G2^T G3^T. [ek] Only the entries read later
  // are formed: each rotation's zeroed entry (b10, b20, b21) is not, nor
  // are R's off-diagonal entries once no rotation reads them (S is R's
  // diagonal); U's (2,1) entry, zero before G3^T, is folded in. Every
  // entry formed is rounded as in the full rotations.
  vreal c1, s1, c2, s2, c3, s3;
  svd3_givens(B[0], B[3], &c1, &s1, exact);
  B[0] = vmla(c1, B[0], vmul(s1, B[3]));
  for (int col = 1; col < 3; col++)
    svd3_rotate_row_pair(B, 0, 1, col, c1, s1);
  svd3_givens(B[0], B[6], &c2, &s2, exact);
  B[0] = vmla(c2, B[0], vmul(s2, B[6]));
  B[7] = vmls(c2, B[7], vmul(s2, B[1]));
  B[8] = vmls(c2, B[8], vmul(s2, B[2]));
  svd3_givens(B[4], B[7], &c3, &s3, exact);
  B[4] = vmla(c3, B[4], vmul(s3, B[7]));
  B[8] = vmls(c3, B[8], vmul(s3, B[5]));
  vreal c1s2 = vmul(c1, s2), s1s2 = vmul(s1, s2);
  U[0] = vmul(c1, c2);
  U[1] = vneg(vmla(c3, s1, vmul(s3, c1s2))); // -s1 c3 - c1 s2 s3
  U[2] = vnmla(c3, c1s2, vmul(s3, s1));      // s1 s3 - c1 s2 c3
  U[3] = vmul(s1, c2);
  U[4] = vmls(c3, c1, vmul(s3, s1s2));       // c1 c3 - s1 s2 s3
  U[5] = vneg(vmla(c3, s1s2, vmul(s3, c1))); // -c1 s3 - s1 s2 c3
  U[6] = s2;
  U[7] = vmul(s3, c2);
  U[8] = vmul(c3, c2);
  *scale = st->amax;
  for (int i = 0; i < 3; i++)
    S[i] = B[4 * i];
  for (int i = 0; i < 9; i++)
    V[i] = st->V[i];
  // Step 0's NaN outputs only where a lane needs them: the 21 selects keep
  // every output of an all-finite vector as it is, so skipping them there
  // gives the same bits (Zen 4, AVX2 float SVD: ~1% less time; docs/perf.md,
  // "SVD", twelfth round).
  if (!vall(st->finite)) {
    vreal nan = vset((real)NAN);
    for (int i = 0; i < 3; i++)
      S[i] = vsel_op(st->finite, S[i], nan);
    for (int i = 0; i < 9; i++) {
      U[i] = vsel_op(st->finite, U[i], nan);
      V[i] = vsel_op(st->finite, V[i], nan);
    }
  }
}

// One sweep of step 3 / step 5 over n vectors, pair by pair.
// With 4 vectors (the wide copy, svd3_block.c) each pair's loop over the
// vectors stays a loop (GCC unroll 1: each vector's state is loaded from
// and stored back to svd3_state on the stack, ~50 instructions of code per
// pair instead of ~200 unrolled with their spills): Zen 5, AVX-512 float,
// 4096 cache-resident matrices, in-process A/B against the unrolled code,
// min of 1000 alternated calls: 4.1-4.8% less time with the one-sided
// sweeps' angle loops below rolled too (AVX2 1.8%; docs/perf.md, "SVD",
// eighth round). The same operations on every vector, so the same bits.
// Two vectors keep the unrolled code (rolled they took 3.5% more).
EK_INLINE void svd3_jacobi_sweep(int n, svd3_state *st, int exact, int rough) {
  if (n >= 4) {
#pragma GCC unroll 1
    for (int j = 0; j < n; j++)
      svd3_jacobi_pair(st[j].s, st[j].qt, 0, 1, 2, exact, rough);
#pragma GCC unroll 1
    for (int j = 0; j < n; j++)
      svd3_jacobi_pair(st[j].s, st[j].qt, 1, 2, 0, exact, rough);
#pragma GCC unroll 1
    for (int j = 0; j < n; j++)
      svd3_jacobi_pair(st[j].s, st[j].qt, 2, 0, 1, exact, rough);
    return;
  }
  for (int j = 0; j < n; j++)
    svd3_jacobi_pair(st[j].s, st[j].qt, 0, 1, 2, exact, rough);
  for (int j = 0; j < n; j++)
    svd3_jacobi_pair(st[j].s, st[j].qt, 1, 2, 0, exact, rough);
  for (int j = 0; j < n; j++)
    svd3_jacobi_pair(st[j].s, st[j].qt, 2, 0, 1, exact, rough);
}

EK_INLINE void svd3_refine_sweep(int n, svd3_state *st, int exact) {
  for (int j = 0; j < n; j++)
    svd3_refine_pair(st[j].B, st[j].V, 0, 1, exact);
  for (int j = 0; j < n; j++)
    svd3_refine_pair(st[j].B, st[j].V, 1, 2, exact);
  for (int j = 0; j < n; j++)
    svd3_refine_pair(st[j].B, st[j].V, 2, 0, exact);
}

// Step 3, all sweeps; with more sweeps than the precision's default, with
// subnormals flushed to zero (FTZ/DAZ, kernels/simd/fpmode.h).
// Why flush: each rotation multiplies the off-diagonal entries of S by a
// small sine and nothing rounds them to a floor, so they fall below
// FLT_MIN after 3-4 float sweeps (5-6 double) and every later sweep
// computes on subnormals, which costs a microcode assist per operation on
// Intel cores (6 exact float sweeps: 10-14x the 2-sweep time on a Xeon, 7x in
// issue 22) and ~25% on Zen 4 (README, "Subnormals").
// Why it is safe: S is the Gram matrix of A scaled to max |a_ij| = 1, so
// its entries are at most 3, and an entry below FLT_MIN (DBL_MIN) is below
// the float (double) budget by over 30 (290) orders of magnitude; flushing
// it to zero only makes a rotation the identity a little earlier, and the
// quaternion stays unit ((ch, sh) is normalised, or (1, 0) when n2 <=
// TINY2). A sweep that meets no subnormal gives the same bits either way.
// Why only this step: the Gram matrix before it, and the refinement, QR
// and output scaling after it, keep gradual underflow, which
// rank-deficient, graded and tiny inputs need (with FTZ/DAZ everywhere
// their errors were 200-500x the budget).
// Why not at the default sweeps (2 float, 3 double, kernels/svd3/svd3.c):
// they stop before the entries get there (over the extremes catalogue only
// the rotation_180, graded and mixed-scale families meet a subnormal in
// this step, a few operations per matrix), while loading MXCSR waits for
// the instructions before it: +2% on 2 exact sweeps, more inside the
// memory-bound fused kernels (the Hessian's gradient pass). So the default
// path runs exactly as before, the same bits for every input.
// Double too: its sweeps reach DBL_MIN from 5-6 sweeps on (8 exact double
// sweeps: 2.0x the 2-sweep time before, 1.7x flushed, Zen 4), and its
// default (3 sweeps) is below SVD3_FLUSH_SWEEPS, so its bits stay as well.
// Order (fpmode.h): every later step depends on qt[0] (through |q|^2 in
// svd3_quat_to_matrix), so passing qt[0] through vfence after the change
// back keeps all of them in IEEE mode. A compiler moving code the other way
// could only run a sweep operation in IEEE mode (slower, same budget) or a
// Gram entry in flush mode (below the budget as above); GCC keeps the mode
// changes in place (checked in the assembly). Fencing S and qt on both
// sides cost 2.5%; this costs nothing measurable.
#if defined(EK_REAL_F32)
#define SVD3_FLUSH_SWEEPS 3 // one more than the float default
#else
#define SVD3_FLUSH_SWEEPS 4 // one more than the double default
#endif
EK_INLINE void svd3_jacobi_sweeps(int n, svd3_state *st, int sweeps, int refine, int exact) {
  int flush = sweeps >= SVD3_FLUSH_SWEEPS;
  if (flush)
    vflush_begin();
  // rough is a constant in each branch, so each gets its own code.
  if (refine > 0)
    for (int sweep = 0; sweep < sweeps; sweep++)
      svd3_jacobi_sweep(n, st, exact, 1);
  else
    for (int sweep = 0; sweep < sweeps; sweep++)
      svd3_jacobi_sweep(n, st, exact, 0);
  if (flush) {
    vflush_end();
    for (int j = 0; j < n; j++)
      vfence(st[j].qt[0]);
  }
}

// The SVD of n independent vectors of matrices (n a compile-time constant
// at every call), S scaled: A = U diag(S * scale) V^T. Each step runs for all n before the next:
// the Jacobi chain of one vector is a long series of dependent operations (latency bound), so two
// independent chains side by side let the core overlap them.
#define SVD3_MAX_N 4
EK_INLINE void svd3_core_n(int n, const vreal (*A)[9], vreal (*U)[9], vreal (*S)[3], vreal (*V)[9],
                           vreal *scale, int sweeps, int refine, int exact) {
  svd3_state st[SVD3_MAX_N];
  for (int j = 0; j < n; j++)
    svd3_start(&st[j], A[j]);
  svd3_jacobi_sweeps(n, st, sweeps, refine, exact);
  for (int j = 0; j < n; j++)
    svd3_form_B(&st[j], exact);
  // Step 5 rotates B and V by the same (c, s), but only B's columns feed
  // the next pair's angle: with several vectors, V's rotations are kept and
  // applied after the sweeps, in the same order (the same operations on
  // every entry of V, so the same bits). V's 9 planes per vector then stay
  // out of the registers while the chains of B's pairs run (4 vectors of B
  // and V do not fit 32 zmm registers): Zen 5, 4 vectors, f32 0-3% less time, f64 4-6%
  // (docs/perf.md, "SVD"). One vector (the kernels that inline an SVD)
  // keeps the plain sweep: its B and V fit.
  if (n == 1) {
    for (int sweep = 0; sweep < refine; sweep++)
      svd3_refine_sweep(1, st, exact);
    for (int j = 0; j < n; j++)
      svd3_finish(&st[j], U[j], S[j], V[j], &scale[j], exact);
    return;
  }
  vreal rc[3 * EK_SVD3_MAX_REFINE][SVD3_MAX_N], rs[3 * EK_SVD3_MAX_REFINE][SVD3_MAX_N];
  for (int sweep = 0; sweep < refine; sweep++) {
    vreal(*c)[SVD3_MAX_N] = rc + 3 * sweep, (*s)[SVD3_MAX_N] = rs + 3 * sweep;
    if (n >= 4) { // rolled loops, as in svd3_jacobi_sweep (same bits)
#pragma GCC unroll 1
      for (int j = 0; j < n; j++)
        svd3_refine_angle(st[j].B, 0, 1, exact, &c[0][j], &s[0][j]);
#pragma GCC unroll 1
      for (int j = 0; j < n; j++)
        svd3_refine_angle(st[j].B, 1, 2, exact, &c[1][j], &s[1][j]);
#pragma GCC unroll 1
      for (int j = 0; j < n; j++)
        svd3_refine_angle(st[j].B, 2, 0, exact, &c[2][j], &s[2][j]);
      continue;
    }
    for (int j = 0; j < n; j++)
      svd3_refine_angle(st[j].B, 0, 1, exact, &c[0][j], &s[0][j]);
    for (int j = 0; j < n; j++)
      svd3_refine_angle(st[j].B, 1, 2, exact, &c[1][j], &s[1][j]);
    for (int j = 0; j < n; j++)
      svd3_refine_angle(st[j].B, 2, 0, exact, &c[2][j], &s[2][j]);
  }
  // V's rotations vector by vector, all sweeps on a local copy: V is
  // stored once per vector, not after every sweep (the same rotations in
  // the same order on every entry).
  for (int j = 0; j < n; j++) {
    vreal v[9];
    for (int i = 0; i < 9; i++)
      v[i] = st[j].V[i];
    for (int sweep = 0; sweep < refine; sweep++) {
      vreal(*c)[SVD3_MAX_N] = rc + 3 * sweep, (*s)[SVD3_MAX_N] = rs + 3 * sweep;
      svd3_rotate_cols(v, 0, 1, c[0][j], s[0][j]);
      svd3_rotate_cols(v, 1, 2, c[1][j], s[1][j]);
      svd3_rotate_cols(v, 2, 0, c[2][j], s[2][j]);
    }
    for (int i = 0; i < 9; i++)
      st[j].V[i] = v[i];
  }
  for (int j = 0; j < n; j++)
    svd3_finish(&st[j], U[j], S[j], V[j], &scale[j], exact);
}

// One or two vectors (nv) of matrices side by side, S scaled back: the
// kernels that fuse an SVD into a per-element pass (the force, the
// Hessian's gradient pass) run their vectors in pairs through this.
EK_INLINE void svd3_core_pair(int nv, const vreal A[2][9], vreal U[2][9], vreal S[2][3],
                              vreal V[2][9], int sweeps, int refine, int exact) {
  vreal scale[2];
  if (nv == 2)
    svd3_core_n(2, A, U, S, V, scale, sweeps, refine, exact);
  else
    svd3_core_n(1, A, U, S, V, scale, sweeps, refine, exact);
  for (int j = 0; j < nv; j++)
    for (int i = 0; i < 3; i++)
      S[j][i] = vmul(S[j][i], scale[j]);
}

// svd3_core_pair built once per (ISA x precision) in svd3_block.c, one per
// rsqrt mode: the kernels that fuse an SVD into a per-element pass (the
// material, force and Hessian kernels of every model) call it out of line
// instead of inlining a whole SVD per model and variant (~430 copies made
// the kernel build take minutes). The same operations in the same order,
// so the same bits; the call costs ~1% of a pair's time (README, "Build").
void EK_SYM(svd3_pair_exact)(int nv, const vreal A[2][9], vreal U[2][9], vreal S[2][3],
                             vreal V[2][9], int sweeps, int refine);
void EK_SYM(svd3_pair_est)(int nv, const vreal A[2][9], vreal U[2][9], vreal S[2][3], vreal V[2][9],
                           int sweeps, int refine);
EK_INLINE void svd3_pair(int nv, const vreal A[2][9], vreal U[2][9], vreal S[2][3], vreal V[2][9],
                         int sweeps, int refine, int exact) {
  if (exact)
    EK_SYM(svd3_pair_exact)(nv, A, U, S, V, sweeps, refine);
  else
    EK_SYM(svd3_pair_est)(nv, A, U, S, V, sweeps, refine);
}

// Four vectors side by side (nv = 1..4; fewer go through the pair), the
// approximate rsqrt only: the fused force kernel's wide variant where the
// row's svd3_chains is 4 (svd3_block.c says why 4 pay on some cores).
// Built in svd3_block.c; the same operations per lane, so the same bits.
void EK_SYM(svd3_quad_est)(int nv, const vreal A[4][9], vreal U[4][9], vreal S[4][3], vreal V[4][9],
                           int sweeps, int refine);

// The SVD of one vector of matrices with the given knobs.
EK_INLINE void svd3_core(const vreal A[9], vreal U[9], vreal S[3], vreal V[9],
                         const ek_svd3_knobs *k) {
  vreal scale;
  if (k->exact_rsqrt)
    svd3_core_n(1, (const vreal(*)[9])A, (vreal(*)[9])U, (vreal(*)[3])S, (vreal(*)[9])V, &scale,
                k->sweeps, k->refine, 1);
  else
    svd3_core_n(1, (const vreal(*)[9])A, (vreal(*)[9])U, (vreal(*)[3])S, (vreal(*)[9])V, &scale,
                k->sweeps, k->refine, 0);
  for (int i = 0; i < 3; i++)
    S[i] = vmul(S[i], scale);
}

// Polar decomposition from the SVD: R = U V^T, Ssym = V diag(S) V^T scale.
EK_INLINE void svd3_polar(const vreal U[9], const vreal S[3], const vreal V[9], vreal scale,
                          vreal R[9], vreal Ssym[9]) {
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++) {
      R[3 * i + j] = vmla(U[3 * i], V[3 * j],
                          vmla(U[3 * i + 1], V[3 * j + 1], vmul(U[3 * i + 2], V[3 * j + 2])));
      Ssym[3 * i + j] = vmla(vmul(V[3 * i], S[0]), V[3 * j],
                             vmla(vmul(V[3 * i + 1], S[1]), V[3 * j + 1],
                                  vmul(vmul(V[3 * i + 2], S[2]), V[3 * j + 2])));
      Ssym[3 * i + j] = vmul(Ssym[3 * i + j], scale);
    }
}

#endif
