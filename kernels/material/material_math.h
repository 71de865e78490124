// Shared vector math of the material kernels: 3x3 matrix helpers on
// registers (one vreal per entry, row-major), the singular-value form of an
// isotropic model (Irving et al. 2004 sec. 5; Teran et al. 2005), the
// U, V-frame Hessian apply, and the 3x3 PSD projection. Include after
// simd/simd.h. Everything here is static inline: kernels and the FVM
// kernel (through material_core.h) inline it into their block loops.
#ifndef EK_MATERIAL_MATH_H
#define EK_MATERIAL_MATH_H

#include "../kernels.h"
#include "../simd/vmath.h"
#include "../svd3/svd3_core.h"

// Model parameters for one call, in the precision of the translation unit.
// svd: the SVD knobs used by the models that need an SVD (the defaults,
// ek_svd3_default_knobs_f32/f64(), unless the caller chose others).
typedef struct {
  real mu, lambda, clamp;
  ek_svd3_knobs svd;
} ek_material_lanes;

// ---- 3x3 helpers (C must not alias A or B) ----
// Always inlined: out of line, each call passes three 3x3 matrices of
// vectors through memory, and GCC's heuristics decide per translation unit
// (a model file with its force and Hessian kernels made different choices
// than one material file: StVK's dP ran 1.9x slower, measured).
EK_INLINE void vm3_mul(const vreal A[9], const vreal B[9], vreal C[9]) {
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      C[3 * i + j] =
          vmla(A[3 * i], B[j], vmla(A[3 * i + 1], B[3 + j], vmul(A[3 * i + 2], B[6 + j])));
}
// C = A^T B
EK_INLINE void vm3_mul_tn(const vreal A[9], const vreal B[9], vreal C[9]) {
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      C[3 * i + j] = vmla(A[i], B[j], vmla(A[3 + i], B[3 + j], vmul(A[6 + i], B[6 + j])));
}
// C = A B^T
EK_INLINE void vm3_mul_nt(const vreal A[9], const vreal B[9], vreal C[9]) {
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      C[3 * i + j] = vmla(A[3 * i], B[3 * j],
                          vmla(A[3 * i + 1], B[3 * j + 1], vmul(A[3 * i + 2], B[3 * j + 2])));
}
EK_INLINE vreal vm3_ddot(const vreal A[9], const vreal B[9]) {
  vreal s = vmul(A[0], B[0]);
  for (int k = 1; k < 9; k++)
    s = vmla(A[k], B[k], s);
  return s;
}
// cof(A) = det(A) A^-T (a polynomial, defined for every A).
EK_INLINE void vm3_cof(const vreal A[9], vreal C[9]) {
  C[0] = vsub(vmul(A[4], A[8]), vmul(A[5], A[7]));
  C[1] = vsub(vmul(A[5], A[6]), vmul(A[3], A[8]));
  C[2] = vsub(vmul(A[3], A[7]), vmul(A[4], A[6]));
  C[3] = vsub(vmul(A[2], A[7]), vmul(A[1], A[8]));
  C[4] = vsub(vmul(A[0], A[8]), vmul(A[2], A[6]));
  C[5] = vsub(vmul(A[1], A[6]), vmul(A[0], A[7]));
  C[6] = vsub(vmul(A[1], A[5]), vmul(A[2], A[4]));
  C[7] = vsub(vmul(A[2], A[3]), vmul(A[0], A[5]));
  C[8] = vsub(vmul(A[0], A[4]), vmul(A[1], A[3]));
}
// det A from its cofactor matrix (first row expansion).
EK_INLINE vreal vm3_det_cof(const vreal A[9], const vreal C[9]) {
  return vmla(A[0], C[0], vmla(A[1], C[1], vmul(A[2], C[2])));
}
// d cof(A; dA), the bilinear part of the quadratic cof.
EK_INLINE void vm3_cof_diff(const vreal A[9], const vreal d[9], vreal D[9]) {
  static const int idx[9][4] = {{4, 8, 5, 7}, {5, 6, 3, 8}, {3, 7, 4, 6},
                                {2, 7, 1, 8}, {0, 8, 2, 6}, {1, 6, 0, 7},
                                {1, 5, 2, 4}, {2, 3, 0, 5}, {0, 4, 1, 3}};
  for (int k = 0; k < 9; k++) {
    const int a = idx[k][0], b = idx[k][1], c = idx[k][2], e = idx[k][3];
    vreal plus = vmla(A[a], d[b], vmul(d[a], A[b]));
    vreal minus = vmla(A[c], d[e], vmul(d[c], A[e]));
    D[k] = vsub(plus, minus);
  }
}

// ---- Singular-value form of an isotropic model ----
// For psi(F) = psi_hat(sigma) (Irving et al. 2004 sec. 5; Teran et al.
// 2005): P = U diag(g) V^T with g_i = d psi_hat / d sigma_i, and in the
// U, V frame the Hessian splits into the 3x3 block A_ij = d^2 psi_hat /
// d sigma_i d sigma_j on the diagonal entries and, for each pair (i, j),
// a 2x2 block on entries (ij, ji) with eigenvalues
//   flip  = (g_i - g_j) / (sigma_i - sigma_j)  (eigenvector (1, 1)/sqrt 2)
//   twist = (g_i + g_j) / (sigma_i + sigma_j)  (eigenvector (1, -1)/sqrt 2)
// (Smith et al. 2019, "Analytic eigensystems for isotropic distortion
// energies"). Each model writes flip and twist in closed form, so
// there is no cancellation at repeated singular values.
// Pairs: 0 = (0,1), 1 = (0,2), 2 = (1,2).
typedef struct {
  vreal psi;
  vreal g[3];
  vreal A[3][3];
  vreal flip[3], twist[3];
} mat_sigma_terms;

static const int mat_pair_i[3] = {0, 0, 1}, mat_pair_j[3] = {1, 2, 2}, mat_pair_k[3] = {2, 1, 0};

// M = U diag(d) V^T.
EK_INLINE void mat_udvt(const vreal U[9], const vreal d[3], const vreal V[9], vreal M[9]) {
  for (int i = 0; i < 3; i++) {
    vreal u0 = vmul(U[3 * i], d[0]), u1 = vmul(U[3 * i + 1], d[1]), u2 = vmul(U[3 * i + 2], d[2]);
    for (int j = 0; j < 3; j++)
      M[3 * i + j] = vmla(u0, V[3 * j], vmla(u1, V[3 * j + 1], vmul(u2, V[3 * j + 2])));
  }
}

// Projection of the symmetric 3x3 A to PSD: negative eigenvalues -> 0, or,
// with mirror != 0, -> their absolute value (Chen et al. 2024, "Stabler
// neo-Hookean simulation: absolute eigenvalue filtering for projected
// Newton").
// Lanes that are positive definite (Sylvester: leading minors > 0) keep A
// as is; the others go through cyclic Jacobi (Golub & Van Loan,
// Matrix Computations, sec. 8.5; the rotation written without division by a_pq
// so a zero off-diagonal gives the identity), then A = Q max(L, 0) Q^T.
static inline void mat_project_psd3(vreal A[3][3], int mirror) {
  vreal zero = vzero(), one = vset(1);
  vreal m1 = A[0][0];
  vreal m2 = vsub(vmul(A[0][0], A[1][1]), vmul(A[0][1], A[0][1]));
  vreal c0 = vsub(vmul(A[1][1], A[2][2]), vmul(A[1][2], A[1][2]));
  vreal c1 = vsub(vmul(A[1][2], A[0][2]), vmul(A[0][1], A[2][2]));
  vreal c2 = vsub(vmul(A[0][1], A[1][2]), vmul(A[1][1], A[0][2]));
  vreal m3 = vmla(A[0][0], c0, vmla(A[0][1], c1, vmul(A[0][2], c2)));
  vmask pd = vmand(vgt(m1, zero), vmand(vgt(m2, zero), vgt(m3, zero)));
  if (vall(pd))
    return;
  vreal a[3][3], Q[3][3];
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++) {
      a[i][j] = A[i][j];
      Q[i][j] = i == j ? one : zero;
    }
  const int sweeps = sizeof(real) == 4 ? 5 : 6;
  static const int P[3] = {0, 0, 1}, Qi[3] = {1, 2, 2}, Ri[3] = {2, 1, 0};
  for (int sweep = 0; sweep < sweeps; sweep++)
    for (int r = 0; r < 3; r++) {
      const int p = P[r], q = Qi[r], o = Ri[r];
      vreal apq = a[p][q], d = vsub(a[q][q], a[p][p]);
      vreal den = vadd(vabs(d), vsqrt(vmla(d, d, vmul(vset(4), vmul(apq, apq)))));
      vreal num = vsel(vge(d, zero), vadd(apq, apq), vneg(vadd(apq, apq)));
      vmask ok = vgt(den, zero);
      vreal t = vsel(ok, vdiv(num, vsel(ok, den, one)), zero);
      vreal c = vdiv(one, vsqrt(vmla(t, t, one))), s = vmul(t, c);
      a[p][p] = vsub(a[p][p], vmul(t, apq));
      a[q][q] = vmla(t, apq, a[q][q]);
      a[p][q] = a[q][p] = zero;
      vreal aop = a[o][p], aoq = a[o][q];
      a[o][p] = a[p][o] = vsub(vmul(c, aop), vmul(s, aoq));
      a[o][q] = a[q][o] = vmla(s, aop, vmul(c, aoq));
      for (int i = 0; i < 3; i++) {
        vreal qp = Q[i][p], qq = Q[i][q];
        Q[i][p] = vsub(vmul(c, qp), vmul(s, qq));
        Q[i][q] = vmla(s, qp, vmul(c, qq));
      }
    }
  vreal lam[3];
  for (int i = 0; i < 3; i++)
    lam[i] = mirror ? vabs(a[i][i]) : vmax(zero, a[i][i]);
  for (int i = 0; i < 3; i++)
    for (int j = i; j < 3; j++) {
      vreal h = vmla(vmul(Q[i][0], lam[0]), Q[j][0],
                     vmla(vmul(Q[i][1], lam[1]), Q[j][1], vmul(vmul(Q[i][2], lam[2]), Q[j][2])));
      A[i][j] = vsel(pd, A[i][j], h);
      A[j][i] = A[i][j];
    }
}

// The frame operator, prepared once per element and applied to any dF:
// dP = U Y V^T with Y = H_hat(U^T dF V) (Teran et al. 2005).
typedef struct {
  vreal U[9], V[9];
  vreal A[3][3];
  vreal h[3], q[3]; // per pair: (flip + twist)/2, (flip - twist)/2
} mat_frame;

// project: 0 exact, 1 negative eigenvalues clamped to 0, 2 negative
// eigenvalues mirrored (their absolute value; mat_project_psd3).
static inline void mat_frame_prepare(mat_frame *fr, const mat_sigma_terms *t, int project) {
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      fr->A[i][j] = t->A[i][j];
  vreal half = vset((real)0.5);
  for (int p = 0; p < 3; p++) {
    vreal fl = t->flip[p], tw = t->twist[p];
    if (project == 2) {
      fl = vabs(fl);
      tw = vabs(tw);
    } else if (project) {
      // max(0, x): x86 max returns its second operand for NaN, so a NaN
      // (outside the domain) stays NaN.
      fl = vmax(vzero(), fl);
      tw = vmax(vzero(), tw);
    }
    fr->h[p] = vmul(half, vadd(fl, tw));
    fr->q[p] = vmul(half, vsub(fl, tw));
  }
  if (project)
    mat_project_psd3(fr->A, project == 2);
}

// mat_frame_apply from T = U^T dF (the Hessian assembly forms T of a unit
// column by itself: hessian_vec.h, frame_apply_unit); T is overwritten.
EK_INLINE void mat_frame_apply_ut(const mat_frame *fr, vreal T[9], vreal dP[9]) {
  vreal D[9], Y[9];
  vm3_mul(T, fr->V, D);
  for (int i = 0; i < 3; i++)
    Y[4 * i] = vmla(fr->A[i][0], D[0], vmla(fr->A[i][1], D[4], vmul(fr->A[i][2], D[8])));
  for (int p = 0; p < 3; p++) {
    const int i = mat_pair_i[p], j = mat_pair_j[p];
    vreal x = D[3 * i + j], y = D[3 * j + i];
    Y[3 * i + j] = vmla(fr->h[p], x, vmul(fr->q[p], y));
    Y[3 * j + i] = vmla(fr->q[p], x, vmul(fr->h[p], y));
  }
  vm3_mul(fr->U, Y, T);
  vm3_mul_nt(T, fr->V, dP);
}

EK_INLINE void mat_frame_apply(const mat_frame *fr, const vreal dF[9], vreal dP[9]) {
  vreal T[9];
  vm3_mul_tn(fr->U, dF, T);
  mat_frame_apply_ut(fr, T, dP);
}

#endif
