// The product and diagonal blocks every isotropic model shares (contract
// in hessian_kernel.h), built per (ISA x precision): both read the element's
// cached U, V-frame eigensystem (Teran et al. 2005; Smith et al. 2019),
// written by the model's own gradient pass (hessian_model.h), and never the
// model: one kernel for all of them.
//   apply:    dF = dDs Dm^-1 of the direction, dP = U Hhat(U^T dF V) V^T
//             (mat_frame_apply), V0 dP Dm^-T;
//   diagonal: per corner c, dF = e_k g_c^T for a unit move along k (g_c
//             row c-1 of Dm^-1, g_0 = -(sum of rows)), so U^T dF V =
//             a b^T with a = U^T e_k, b = V^T g_c, and the block is
//             V0 U M U^T with M (3x3, symmetric) read off the frame:
//               M_ii = A_ii b_i^2 + sum_{j != i} h_ij b_j^2,
//               M_il = b_i b_l (A_il + q_il)   (i != l)
//             (mat_frame_apply's entries contracted with b twice).
#include "../simd/simd.h"

#include "../svd3/svd3_core.h" // svd3_quat_to_matrix
#include "hessian_vec.h"

static void frame_apply_blocks(const hess_args *a, size_t b0, size_t b1) {
  _Alignas(64) real hb[12 * L];
  for (size_t b = b0; b < b1; b++) {
    const real *dmi = a->dm_inv + b * 9 * L, *c = cache_block(a, b);
    real *dst = a->corner ? a->corner + b * 12 * L : hb;
    for (int o = 0; o < L; o += EK_W) {
      vreal dF[9], dP[9];
      mat_frame fr;
      tet_gradient(a->x, a->idx + b * 4 * L, dmi, o, 0, dF);
      load_frame(c, o, &fr);
      mat_frame_apply(&fr, dF, dP);
      tet_corner_values(dP, dmi, vload(a->v0 + b * L + o), o, dst);
    }
    if (!a->corner)
      hess_scatter_block(a, b, hb, 3);
  }
}

static void frame_diag_blocks(const hess_args *a, size_t b0, size_t b1) {
  _Alignas(64) real hb[24 * L];
  for (size_t b = b0; b < b1; b++) {
    const real *dmi = a->dm_inv + b * 9 * L, *cb = cache_block(a, b);
    real *dst = a->corner ? a->corner + b * 24 * L : hb;
    for (int o = 0; o < L; o += EK_W) {
      vreal Dmi[9], g[4][3], B[9], v0 = vload(a->v0 + b * L + o);
      for (int k = 0; k < 9; k++)
        Dmi[k] = vload(dmi + k * L + o);
      corner_dirs(Dmi, g);
      mat_frame fr;
      load_frame(cb, o, &fr);
      for (int c = 0; c < 4; c++) {
        vreal bv[3], M[9], T[9];
        for (int i = 0; i < 3; i++)
          bv[i] = vmla(fr.V[i], g[c][0], vmla(fr.V[3 + i], g[c][1], vmul(fr.V[6 + i], g[c][2])));
        for (int p = 0; p < 3; p++) {
          const int i = mat_pair_i[p], j = mat_pair_j[p];
          M[3 * i + j] = M[3 * j + i] = vmul(vmul(bv[i], bv[j]), vadd(fr.A[i][j], fr.q[p]));
        }
        vreal b2[3] = {vmul(bv[0], bv[0]), vmul(bv[1], bv[1]), vmul(bv[2], bv[2])};
        // pairs: 0 = (0,1), 1 = (0,2), 2 = (1,2)
        M[0] = vmla(fr.A[0][0], b2[0], vmla(fr.h[0], b2[1], vmul(fr.h[1], b2[2])));
        M[4] = vmla(fr.A[1][1], b2[1], vmla(fr.h[0], b2[0], vmul(fr.h[2], b2[2])));
        M[8] = vmla(fr.A[2][2], b2[2], vmla(fr.h[1], b2[0], vmul(fr.h[2], b2[1])));
        vm3_mul(fr.U, M, T);
        vm3_mul_nt(T, fr.U, B);
        for (int k = 0; k < 9; k++)
          B[k] = vmul(v0, B[k]);
        store_block6(B, c, o, dst);
      }
    }
    if (!a->corner)
      hess_scatter_block(a, b, hb, 6);
  }
}

// HESS_ELEMENT: the 12x12 element Hessians of blocks [b0, b1) into
// a->corner (144 planes per block from b0: hessian_vec.h, elem_store). The 9 unit
// columns' U^T dF V are rank one, a b^T (a = U^T e_k, b = V^T g_c), but
// mat_frame_apply's arithmetic on the full dF keeps this the product's
// bits; frame_apply_unit skips only the products of dF's structural
// zeros (hessian_vec.h says why the bits stay).
static void frame_element_blocks(const hess_args *a, size_t b0, size_t b1) {
  for (size_t b = b0; b < b1; b++) {
    const real *dmi = a->dm_inv + b * 9 * L, *cb = cache_block(a, b);
    for (int o = 0; o < L; o += EK_W) {
      vreal Dmi[9], g[4][3], H[144], v0 = vload(a->v0 + b * L + o);
      for (int k = 0; k < 9; k++)
        Dmi[k] = vload(dmi + k * L + o);
      corner_dirs(Dmi, g);
      mat_frame fr;
      load_frame(cb, o, &fr);
      for (int c = 1; c < 4; c++)
        for (int k = 0; k < 3; k++) {
          vreal dP[9];
          frame_apply_unit(&fr, k, g[c], dP);
          elem_column(dP, g, v0, 3 * c + k, H);
        }
      elem_store(H, (size_t)o, a->corner + (b - b0) * 144 * L);
    }
  }
}

// HESS_ELEMENT_R1: the same 12x12 element Hessians and layout as
// HESS_ELEMENT, from the rank-one structure of the unit columns (the
// upper-triangle assembly's element kernel; its bits are not
// HESS_ELEMENT's, so the default assembly keeps that one). The column of
// corner c along k has U^T dF V = a b_c^T, a = U^T e_k (a_m = U[k][m]), b_c
// = V^T g_c (as frame_diag_blocks), and mat_frame_apply's Y of e_m b_c^T
// contracted with b_d gives the corner pair's 3x3 block in the U frame:
//   H_dc = V0 U Mhat U^T,  P = (V0 b_d) b_c^T,
//   Mhat[i][k] = A_ik P_ik + q_ik P_ki                  (i != k),
//   Mhat[k][k] = A_kk P_kk + sum_{n != k} h_kn P_nn
// (the frame's A, flip/twist h, q: Smith et al. 2019 sec. 5, as
// mat_frame_apply). Only the 10 blocks d <= c are formed (H_cd = H_dc^T:
// written transposed, so the matrix is symmetric to the bit; H_dd from its
// upper triangle): ~800 vector operations per tet instead of ~1500 for 9
// products, the corner-0 columns and the symmetrisation.
static void frame_element_r1_blocks(const hess_args *a, size_t b0, size_t b1) {
  for (size_t b = b0; b < b1; b++) {
    const real *dmi = a->dm_inv + b * 9 * L, *cb = cache_block(a, b);
    real *dst = a->corner + (b - b0) * 144 * L;
    for (int o = 0; o < L; o += EK_W) {
      vreal g[3], bc[4][3], bd[4][3], v0 = vload(a->v0 + b * L + o);
      mat_frame fr;
      load_frame(cb, o, &fr);
      // b_c = V^T g_c (g_c row c - 1 of Dm^-1), b_0 = -(b_1 + b_2 + b_3);
      // bd = V0 b.
      for (int c = 1; c < 4; c++) {
        for (int j = 0; j < 3; j++)
          g[j] = vload(dmi + ((c - 1) * 3 + j) * L + o);
        for (int i = 0; i < 3; i++)
          bc[c][i] = vmla(fr.V[i], g[0], vmla(fr.V[3 + i], g[1], vmul(fr.V[6 + i], g[2])));
      }
      for (int i = 0; i < 3; i++)
        bc[0][i] = vneg(vadd(vadd(bc[1][i], bc[2][i]), bc[3][i]));
      for (int c = 0; c < 4; c++)
        for (int i = 0; i < 3; i++)
          bd[c][i] = vmul(v0, bc[c][i]);
      vreal aq[3]; // A_ik + q_ik: the diagonal blocks' P is symmetric
      for (int p = 0; p < 3; p++)
        aq[p] = vadd(fr.A[mat_pair_i[p]][mat_pair_j[p]], fr.q[p]);
#pragma GCC unroll 4
      for (int d = 0; d < 4; d++)
#pragma GCC unroll 4
        for (int c = d; c < 4; c++) {
          vreal P[9], M[9], T[9];
          for (int i = 0; i < 3; i++)
            for (int k = 0; k < 3; k++)
              P[3 * i + k] = d == c && k < i ? P[3 * k + i] : vmul(bd[d][i], bc[c][k]);
          for (int p = 0; p < 3; p++) {
            const int i = mat_pair_i[p], k = mat_pair_j[p];
            if (d == c) {
              M[3 * i + k] = M[3 * k + i] = vmul(aq[p], P[3 * i + k]);
            } else {
              M[3 * i + k] = vmla(fr.A[i][k], P[3 * i + k], vmul(fr.q[p], P[3 * k + i]));
              M[3 * k + i] = vmla(fr.A[i][k], P[3 * k + i], vmul(fr.q[p], P[3 * i + k]));
            }
          }
          // pairs: 0 = (0,1), 1 = (0,2), 2 = (1,2)
          M[0] = vmla(fr.A[0][0], P[0], vmla(fr.h[0], P[4], vmul(fr.h[1], P[8])));
          M[4] = vmla(fr.A[1][1], P[4], vmla(fr.h[0], P[0], vmul(fr.h[2], P[8])));
          M[8] = vmla(fr.A[2][2], P[8], vmla(fr.h[1], P[0], vmul(fr.h[2], P[4])));
          vm3_mul(fr.U, M, T);
          for (int i = 0; i < 3; i++)
            for (int k = d == c ? i : 0; k < 3; k++) {
              vreal v =
                  vmla(T[3 * i], fr.U[3 * k],
                       vmla(T[3 * i + 1], fr.U[3 * k + 1], vmul(T[3 * i + 2], fr.U[3 * k + 2])));
              vstore(dst + ((d * 4 + c) * 9 + i * 3 + k) * L + o, v);
              if (d != c || k != i)
                vstore(dst + ((c * 4 + d) * 9 + k * 3 + i) * L + o, v);
            }
        }
    }
  }
}

void EK_SYM(hessian_frame_block)(const hess_args *a, size_t b0, size_t b1);
void EK_SYM(hessian_frame_block)(const hess_args *a, size_t b0, size_t b1) {
  if (a->op == HESS_APPLY)
    frame_apply_blocks(a, b0, b1);
  else if (a->op == HESS_ELEMENT)
    frame_element_blocks(a, b0, b1);
  else if (a->op == HESS_ELEMENT_R1)
    frame_element_r1_blocks(a, b0, b1);
  else
    frame_diag_blocks(a, b0, b1);
}

// The assembly's sums (hessian_kernel.h, hessian_sum): the runs of the
// thread's plan group asm_k, each the group's element blocks that add
// into one 3x3 block of K, in ascending slot order, summed in registers
// and stored once (vsum_run3: masked 3-wide rows where the target has
// them). The rows of the run RUN_AHEAD runs on (the next entry's past the
// last) are prefetched: K's rows are scattered over ~20 MB, and a
// prefetch of a whole block's rows before its element Hessians was
// dropped or evicted (no gain); 32 runs on (~11 tets' runs, 2.9 per tet
// in f32) was a few % faster than 6 or 16 (docs/perf.md, "Hessian
// assembly").
#define RUN_AHEAD 32

// The upper block triangle's sums (ek_fvm_hessian_assemble_upper_*): the
// same runs, each into its K block's 9 contiguous values (row-major) at
// uvalues + run_up, summed in this precision in ascending slot order from
// 0 (a run with first set ignores the old values). A block is one or two
// cache lines, so one prefetch covers it where the CSR's 3 rows need 3.
static void sum_upper(const hess_args *a) {
  const struct ek_fvm_hessian *h = a->asm_h;
  const int32_t i0 = h->krun[a->asm_k], i1 = h->krun[a->asm_k + 1];
  const int32_t end = h->krun[h->tgrp[h->plan_threads]];
  const uint16_t *off = h->run_e + h->kcon[a->asm_k];
  for (int32_t i = i0; i < i1; i++) {
    const ek_hess_run *r = h->runs + i;
    if (i + RUN_AHEAD < end) {
      const real *q = a->uvalues + h->run_up[i + RUN_AHEAD];
      __builtin_prefetch(q, 1, 3);
      __builtin_prefetch(q + 8, 1, 3);
    }
    real *o = a->uvalues + h->run_up[i], acc[9];
    for (int m = 0; m < 9; m++)
      acc[m] = r->first ? 0 : o[m];
    for (int j = 0; j < r->n; j++) {
      const real *e = a->corner + off[j];
      for (int m = 0; m < 9; m++)
        acc[m] += e[(size_t)m * L];
    }
    for (int m = 0; m < 9; m++)
      o[m] = acc[m];
    off += r->n;
  }
}

void EK_SYM(hessian_sum)(const hess_args *a, size_t b0, size_t b1);
void EK_SYM(hessian_sum)(const hess_args *a, size_t b0, size_t b1) {
  (void)b0, (void)b1; // the plan group's blocks
  if (a->uvalues) {
    sum_upper(a);
    return;
  }
  const struct ek_fvm_hessian *h = a->asm_h;
  const ek_hess_run *r = h->runs + h->krun[a->asm_k], *r1 = h->runs + h->krun[a->asm_k + 1];
  const ek_hess_run *end = h->runs + h->krun[h->tgrp[h->plan_threads]];
  const uint16_t *off = h->run_e + h->kcon[a->asm_k];
  for (; r < r1; r++) {
    if (r + RUN_AHEAD < end) {
      const double *q = a->values + r[RUN_AHEAD].p;
      const size_t rs = (size_t)r[RUN_AHEAD].rs;
      __builtin_prefetch(q, 1, 3);
      __builtin_prefetch(q + rs, 1, 3);
      __builtin_prefetch(q + 2 * rs, 1, 3);
    }
    vsum_run3(a->values + r->p, (size_t)r->rs, a->corner, L, off, r->n, r->first);
    off += r->n;
  }
}

// This source's entries in a kernel table row (dispatch.c).
void EK_SYM(hessian_block_fill)(ek_kernel_table *t);
void EK_SYM(hessian_block_fill)(ek_kernel_table *t) {
  t->EK_FIELD(hessian_frame_block) = EK_SYM(hessian_frame_block);
  t->EK_FIELD(hessian_sum) = EK_SYM(hessian_sum);
}
