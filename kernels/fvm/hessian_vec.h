// The Hessian kernels' shared steps on AoSoA tet blocks (contract in
// hessian_kernel.h): the argument type of this precision, the cached
// U, V-frame eigensystem of a block's lanes, the scatter, and the corner
// directions of the diagonal blocks. Used by hessian_block.c (the product
// and diagonal blocks every isotropic model shares) and hessian_model.h
// (each model's own passes). Include after simd/simd.h.
#ifndef EK_HESSIAN_VEC_H
#define EK_HESSIAN_VEC_H

#include "../material/material_math.h"
#include "fvm_tet.h"
#include "hessian_kernel.h"

#if defined(EK_REAL_F32)
typedef struct ek_hess_args_f32 hess_args;
#else
typedef struct ek_hess_args_f64 hess_args;
#endif

#define L EK_LANES
#define GROUP_BLOCKS (EK_VPB >= 2 ? 1 : 2)

static inline const real *cache_block(const hess_args *a, size_t b) {
  return a->cache + b * (size_t)a->planes * L;
}

// U and V are rotations (det +1, svd3.h), cached as unit quaternions
// (w, x, y, z): 8 planes instead of 18, so a product reads 20 planes per
// tet, not 30 (the products are bound by the cache's bytes); the SVD's own
// quaternion-to-matrix step rebuilds them.
// The cached frame of the EK_W lanes at offset o of a block's cache.
EK_INLINE void load_frame(const real *c, int o, mat_frame *fr) {
  static const int ai[6] = {0, 0, 0, 1, 1, 2}, aj[6] = {0, 1, 2, 1, 2, 2};
  vreal qu[4], qv[4];
  for (int k = 0; k < 4; k++) {
    qu[k] = vload(c + k * L + o);
    qv[k] = vload(c + (4 + k) * L + o);
  }
  svd3_quat_to_matrix(qu, fr->U, 1);
  svd3_quat_to_matrix(qv, fr->V, 1);
  for (int k = 0; k < 6; k++)
    fr->A[ai[k]][aj[k]] = fr->A[aj[k]][ai[k]] = vload(c + (8 + k) * L + o);
  for (int p = 0; p < 3; p++) {
    fr->h[p] = vload(c + (14 + p) * L + o);
    fr->q[p] = vload(c + (17 + p) * L + o);
  }
}

static inline void hess_scatter_block(const hess_args *a, size_t b, const real *hb, int ncomp) {
  tet_scatter_block(a->idx + b * 4 * L, hb, ncomp, a->out);
}

// g_c of corner c for the vector's lanes: row c-1 of Dm^-1, g_0 = -sum.
static inline void corner_dirs(const vreal Dmi[9], vreal g[4][3]) {
  for (int c = 1; c < 4; c++)
    for (int j = 0; j < 3; j++)
      g[c][j] = Dmi[(c - 1) * 3 + j];
  for (int j = 0; j < 3; j++)
    g[0][j] = vneg(vadd(vadd(g[1][j], g[2][j]), g[3][j]));
}

static inline void store_block6(const vreal B[9], int c, int o, real *dst) {
  static const int e[6] = {0, 1, 2, 4, 5, 8};
  for (int k = 0; k < 6; k++)
    vstore(dst + (c * 6 + k) * L + o, B[e[k]]);
}

// ---- Element Hessians (HESS_ELEMENT) ----
// mat_frame_apply (material_math.h) for the unit column dF = e_k g^T: its
// first product U^T dF has the terms of rows
// m != k zero, and vm3_mul_tn's fma(x, 0, y) is y exactly, x * 0 + y is y
// for y != 0, so U^T dF = U[k][i] g_j, one product per entry instead of
// three; only the sign of an exact zero can differ, and the assembly's
// sums (0 + e first) make every zero of K +0 either way (x86's invalid-
// operation NaN has one sign, whatever the operands'; a NaN frame (a
// state outside the domain) is in A, h, q, never in the rotations U, V).
// The rest is mat_frame_apply's (mat_frame_apply_ut).
EK_INLINE void frame_apply_unit(const mat_frame *fr, int k, const vreal g[3], vreal dP[9]) {
  vreal T[9];
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      T[3 * i + j] = vmul(fr->U[3 * k + i], g[j]);
  mat_frame_apply_ut(fr, T, dP);
}

// The 12x12 projected Hessian of a tet, H[(d, i), (c, k)] = V0 g_d^T
// dP(e_k g_c^T) e_i (corner d, c; axes i, k; g_c as corner_dirs), from
// the dP of the 9 unit columns dF = e_k g_c^T of corners 1..3: corner 0's
// columns are minus the sum of the others' (a translation moves no F),
// and the matrix is symmetrised, (H + H^T) / 2, so the assembled matrix is
// symmetric to the bit (a Cholesky or CG reads one triangle's values).
// Column `col` (3 c + k, c >= 1) from its dP: rows (d, i).
EK_INLINE void elem_column(const vreal dP[9], const vreal g[4][3], vreal v0, int col,
                           vreal H[144]) {
  for (int i = 0; i < 3; i++) {
    vreal s = vzero();
    for (int d = 1; d < 4; d++) {
      vreal t =
          vmla(dP[3 * i], g[d][0], vmla(dP[3 * i + 1], g[d][1], vmul(dP[3 * i + 2], g[d][2])));
      H[(3 * d + i) * 12 + col] = vmul(v0, t);
      s = vadd(s, H[(3 * d + i) * 12 + col]);
    }
    H[i * 12 + col] = vneg(s);
  }
}

// Corner 0's columns, the symmetrisation, and the matrices written as 144
// planes of the block's lanes (what the assembly reads, lane by lane):
// dst[((d * 4 + c) * 9 + i * 3 + k) * LANES + o + l] for the EK_W lanes
// from o, rows (d, i), columns (c, k). The loops unrolled: the plane
// offsets (divisions by 3) are then constants, not ~15% of the element
// kernel's samples (docs/perf.md, "Hessian assembly").
EK_INLINE void elem_store(vreal H[144], size_t o, real *dst) {
  const vreal half = vset((real)0.5);
  for (int r = 0; r < 12; r++)
    for (int k = 0; k < 3; k++)
      H[r * 12 + k] = vneg(vadd(vadd(H[r * 12 + 3 + k], H[r * 12 + 6 + k]), H[r * 12 + 9 + k]));
#pragma GCC unroll 12
  for (int r = 0; r < 12; r++)
#pragma GCC unroll 12
    for (int s = r; s < 12; s++) {
      vreal v = s == r ? H[r * 12 + r] : vmul(half, vadd(H[r * 12 + s], H[s * 12 + r]));
      const int d = r / 3, i = r % 3, c = s / 3, k = s % 3;
      vstore(dst + ((d * 4 + c) * 9 + i * 3 + k) * L + o, v);
      if (s != r)
        vstore(dst + ((c * 4 + d) * 9 + k * 3 + i) * L + o, v);
    }
}

#endif
