// The Hessian kernels of one model (contract in hessian_kernel.h; API in
// include/ek/hessian.h), instantiated by model_kernels.h in the model's
// file, as the force kernel is (fvm_model.h), so each model gets its own
// loops.
//   gradient: the force kernel's steps with G = +V0 P Dm^-T, V0 psi, and
//             the cache: for the isotropic models the U, V-frame
//             eigensystem of the SVD (material_frame_svd: Teran et al.
//             2005, Smith et al. 2019), projected to PSD unless asked not
//             to; R for corotated linear;
//   apply, diagonal: dP in F for the models linear in F's rotation
//             (linear, corotated linear); the isotropic models' read only
//             the cached eigensystem and share one kernel
//             (hessian_block.c), which the driver calls for them.
#ifndef EK_HESSIAN_MODEL_H
#define EK_HESSIAN_MODEL_H

#include "../material/material_core.h"
#include "hessian_vec.h"

#if !MODEL_ISOTROPIC
// ---- Product and diagonal blocks of the models linear in F's rotation
// (linear, corotated linear: dP in F); the isotropic models' are the
// shared frame kernels of hessian_block.c ----

// ---- Product: K p ----
EK_INLINE void apply_blocks(const hess_args *a, size_t b0, size_t b1) {
  _Alignas(64) real hb[12 * L];
  const ek_material_lanes mp =
      material_lanes_make(a->mat->mu, a->mat->lambda, a->mat->clamp, a->svd);
  for (size_t b = b0; b < b1; b++) {
    const real *dmi = a->dm_inv + b * 9 * L,
               *c = MODEL_CACHE_PLANES == 0 ? NULL : cache_block(a, b);
    real *dst = a->corner ? a->corner + b * 12 * L : hb;
    for (int o = 0; o < L; o += EK_W) {
      vreal dF[9], dP[9];
      tet_gradient(a->x, a->idx + b * 4 * L, dmi, o, 0, dF);
      if (MODEL_CACHE_PLANES == 0) {
        material_diff_direct(&mp, dF, dF, dF, dP);
      } else {
        vreal R[9];
        for (int k = 0; k < 9; k++)
          R[k] = vload(c + k * L + o);
        material_diff_direct(&mp, dF, R, dF, dP);
      }
      tet_corner_values(dP, dmi, vload(a->v0 + b * L + o), o, dst);
    }
    if (!a->corner)
      hess_scatter_block(a, b, hb, 3);
  }
}

EK_INLINE void diag_blocks(const hess_args *a, size_t b0, size_t b1) {
  _Alignas(64) real hb[24 * L];
  const ek_material_lanes mp =
      material_lanes_make(a->mat->mu, a->mat->lambda, a->mat->clamp, a->svd);
  for (size_t b = b0; b < b1; b++) {
    const real *dmi = a->dm_inv + b * 9 * L,
               *cb = MODEL_CACHE_PLANES == 0 ? NULL : cache_block(a, b);
    real *dst = a->corner ? a->corner + b * 24 * L : hb;
    for (int o = 0; o < L; o += EK_W) {
      vreal Dmi[9], g[4][3], B[9], v0 = vload(a->v0 + b * L + o);
      for (int k = 0; k < 9; k++)
        Dmi[k] = vload(dmi + k * L + o);
      corner_dirs(Dmi, g);
      vreal R[9], zero = vzero();
      for (int k = 0; k < 9; k++)
        R[k] = MODEL_READS_R ? vload(cb + k * L + o) : zero;
      for (int c = 0; c < 4; c++) {
        for (int k = 0; k < 3; k++) {
          // Column k: dF = e_k g_c^T, B[:, k] = V0 dP g_c.
          vreal dF[9], dP[9];
          for (int i = 0; i < 9; i++)
            dF[i] = i / 3 == k ? g[c][i % 3] : zero;
          material_diff_direct(&mp, dF, R, dF, dP);
          for (int i = 0; i < 3; i++)
            B[3 * i + k] =
                vmul(v0, vmla(dP[3 * i], g[c][0],
                              vmla(dP[3 * i + 1], g[c][1], vmul(dP[3 * i + 2], g[c][2]))));
        }
        store_block6(B, c, o, dst);
      }
    }
    if (!a->corner)
      hess_scatter_block(a, b, hb, 6);
  }
}

// ---- Element Hessians (HESS_ELEMENT: hessian_vec.h, elem_store) ----
EK_INLINE void element_blocks(const hess_args *a, size_t b0, size_t b1) {
  const ek_material_lanes mp =
      material_lanes_make(a->mat->mu, a->mat->lambda, a->mat->clamp, a->svd);
  for (size_t b = b0; b < b1; b++) {
    const real *dmi = a->dm_inv + b * 9 * L,
               *cb = MODEL_CACHE_PLANES == 0 ? NULL : cache_block(a, b);
    for (int o = 0; o < L; o += EK_W) {
      vreal Dmi[9], g[4][3], H[144], R[9], v0 = vload(a->v0 + b * L + o), zero = vzero();
      for (int k = 0; k < 9; k++)
        Dmi[k] = vload(dmi + k * L + o);
      corner_dirs(Dmi, g);
      for (int k = 0; k < 9; k++)
        R[k] = MODEL_READS_R ? vload(cb + k * L + o) : zero;
      for (int c = 1; c < 4; c++)
        for (int k = 0; k < 3; k++) {
          vreal dF[9], dP[9];
          for (int i = 0; i < 9; i++)
            dF[i] = i / 3 == k ? g[c][i % 3] : zero;
          material_diff_direct(&mp, dF, R, dF, dP);
          elem_column(dP, g, v0, 3 * c + k, H);
        }
      elem_store(H, (size_t)o, a->corner + (b - b0) * 144 * L);
    }
  }
}

#endif

#if defined(EK_REAL_F64)
// ---- Gradient (double only: ek_fvm_hessian_gradient_f64) ----

// Plane k of the cache for the vector at offset o of block b: in double
// (this kernel's layout) or rounded to float (the float layout, by slot).
static inline void cache_store(const hess_args *a, size_t b, int o, int k, vreal v) {
  if (a->cache_out_f32) {
    _Alignas(64) double t[EK_W];
    vstore(t, v);
    const size_t s0 = b * L + (size_t)o, P = (size_t)a->planes;
    float *d =
        a->cache_out_f32 + ((s0 / EK_LANES_F32) * P + (size_t)k) * EK_LANES_F32 + s0 % EK_LANES_F32;
    for (int l = 0; l < EK_W; l++)
      d[l] = (float)t[l];
  } else if (a->cache_out) {
    vstore(a->cache_out + (b * (size_t)a->planes + (size_t)k) * L + (size_t)o, v);
  }
}

// Unit quaternion of a rotation M (Shepperd 1978, "Quaternion from
// rotation matrix": the largest of 4w^2, 4x^2, 4y^2, 4z^2 is the pivot, so
// no division by a small number), normalised.
static inline void matrix_to_quat(const vreal M[9], vreal q[4]) {
  vreal one = vset(1);
  vreal t[4] = {vadd(one, vadd(M[0], vadd(M[4], M[8]))), vadd(one, vsub(M[0], vadd(M[4], M[8]))),
                vadd(one, vsub(M[4], vadd(M[0], M[8]))), vadd(one, vsub(M[8], vadd(M[0], M[4])))};
  // Off-diagonal sums and differences: 4 w x, 4 w y, 4 w z, 4 x y, 4 x z, 4 y z.
  vreal wx = vsub(M[7], M[5]), wy = vsub(M[2], M[6]), wz = vsub(M[3], M[1]);
  vreal xy = vadd(M[1], M[3]), xz = vadd(M[2], M[6]), yz = vadd(M[5], M[7]);
  vmask m1 = vmand(vgt(t[1], t[0]), vmand(vge(t[1], t[2]), vge(t[1], t[3])));
  vmask m2 = vmand(vmnot(m1), vmand(vgt(t[2], t[0]), vge(t[2], t[3])));
  vmask m3 = vmand(vmnot(vmor(m1, m2)), vgt(t[3], t[0]));
  // Pivot p: 4 p^2 = t_p; the others are (their 4 p c term) / (4 p).
  vreal tp = vsel(m1, t[1], vsel(m2, t[2], vsel(m3, t[3], t[0])));
  vreal r = vsqrt(tp), inv = vdiv(vset((real)0.5), r); // p = r / 2, 1 / (4 p) = 0.5 / r
  vreal half = vmul(vset((real)0.5), r);               // the pivot component
  vreal w = vsel(m1, vmul(wx, inv), vsel(m2, vmul(wy, inv), vsel(m3, vmul(wz, inv), half)));
  vreal x = vsel(m1, half, vsel(m2, vmul(xy, inv), vsel(m3, vmul(xz, inv), vmul(wx, inv))));
  vreal y = vsel(m1, vmul(xy, inv), vsel(m2, half, vsel(m3, vmul(yz, inv), vmul(wy, inv))));
  vreal z = vsel(m1, vmul(xz, inv), vsel(m2, vmul(yz, inv), vsel(m3, half, vmul(wz, inv))));
  vreal n = vrsqrt(vmla(w, w, vmla(x, x, vmla(y, y, vmul(z, z)))));
  q[0] = vmul(w, n);
  q[1] = vmul(x, n);
  q[2] = vmul(y, n);
  q[3] = vmul(z, n);
}

static inline void store_frame(const hess_args *a, size_t b, int o, const mat_frame *fr) {
  static const int ai[6] = {0, 0, 0, 1, 1, 2}, aj[6] = {0, 1, 2, 1, 2, 2};
  vreal qu[4], qv[4];
  matrix_to_quat(fr->U, qu);
  matrix_to_quat(fr->V, qv);
  for (int k = 0; k < 4; k++) {
    cache_store(a, b, o, k, qu[k]);
    cache_store(a, b, o, 4 + k, qv[k]);
  }
  for (int k = 0; k < 6; k++)
    cache_store(a, b, o, 8 + k, fr->A[ai[k]][aj[k]]);
  for (int p = 0; p < 3; p++) {
    cache_store(a, b, o, 14 + p, fr->h[p]);
    cache_store(a, b, o, 17 + p, fr->q[p]);
  }
}

// Corotated linear's R^n for block b's lanes (identity in padding lanes).
static inline void hess_gather_R(const hess_args *a, size_t b, real *Rb) {
  for (int l = 0; l < L; l++) {
    int32_t t = a->slot_tet[b * L + l];
    size_t s = t >= 0 ? (size_t)a->morton_slot[t] : 0;
    for (int k = 0; k < 9; k++)
      Rb[k * L + l] =
          t >= 0 ? a->R_planes[(s / EK_LANES_F64 * 9 + (size_t)k) * EK_LANES_F64 + s % EK_LANES_F64]
                 : (real)(k % 4 == 0);
  }
}

EK_INLINE void gradient_blocks(int exact, const hess_args *a, size_t b0, size_t b1) {
  _Alignas(64) real Rb[GROUP_BLOCKS][9 * L];
  _Alignas(64) real hb[GROUP_BLOCKS][12 * L];
  const ek_material_lanes mp =
      material_lanes_make(a->mat->mu, a->mat->lambda, a->mat->clamp, a->svd);
  const int iso = MODEL_ISOTROPIC;
  const int sigma = material_uses_sigma(&mp);
  const int cache = a->cache_out || a->cache_out_f32;
  for (size_t b = b0; b < b1; b += GROUP_BLOCKS) {
    const int nb = b1 - b < GROUP_BLOCKS ? (int)(b1 - b) : GROUP_BLOCKS;
    if (MODEL_READS_R)
      for (int g = 0; g < nb; g++)
        hess_gather_R(a, b + (size_t)g, Rb[g]);
    for (int v = 0; v < nb * EK_VPB; v += 2) {
      const int nv = nb * EK_VPB - v < 2 ? 1 : 2;
      vreal F[2][9], P[2][9], psi[2];
      int og[2];
      size_t bg[2];
      for (int j = 0; j < nv; j++) {
        bg[j] = b + (size_t)((v + j) / EK_VPB);
        og[j] = (v + j) % EK_VPB * EK_W;
        tet_gradient(a->x, a->idx + bg[j] * 4 * L, a->dm_inv + bg[j] * 9 * L, og[j], 1, F[j]);
      }
      if (iso && (sigma || cache)) {
        // The SVD of both vectors side by side; P and psi from it or in F
        // (as the force kernel would), the frame from it.
        vreal U[2][9], S[2][3], V[2][9];
        // Inline here, unlike the force kernels: this double pass keeps
        // more live across the SVD, and the call through memory cost it
        // 7-12% (measured, AVX-512 f64); it is built for f64 only.
        svd3_core_pair(nv, (const vreal(*)[9])F, U, S, V, mp.svd.sweeps, mp.svd.refine, exact);
        for (int j = 0; j < nv; j++) {
          if (sigma) {
            material_pk1_svd(&mp, U[j], S[j], V[j], P[j]);
            psi[j] = material_psi_svd(&mp, S[j]);
          } else {
            material_pk1(&mp, F[j], F[j], P[j]);
            psi[j] = material_psi(&mp, F[j], F[j]);
          }
          if (cache) {
            mat_frame fr;
            material_frame_svd(&mp, F[j], U[j], S[j], V[j], a->project, &fr);
            store_frame(a, bg[j], og[j], &fr);
          }
        }
      } else {
        for (int j = 0; j < nv; j++) {
          vreal R[9];
          const int g = (v + j) / EK_VPB;
          for (int k = 0; k < 9; k++) {
            R[k] = MODEL_READS_R ? vload(Rb[g] + k * L + og[j]) : F[j][k];
            if (MODEL_READS_R && cache)
              cache_store(a, bg[j], og[j], k, R[k]);
          }
          material_pk1(&mp, F[j], R, P[j]);
          psi[j] = material_psi(&mp, F[j], R);
        }
      }
      for (int j = 0; j < nv; j++) {
        const int g = (v + j) / EK_VPB;
        vreal v0 = vload(a->v0 + bg[j] * L + og[j]);
        vstore(a->energy + bg[j] * L + og[j], vmul(v0, psi[j]));
        tet_corner_values(P[j], a->dm_inv + bg[j] * 9 * L, v0, og[j],
                          a->corner ? a->corner + bg[j] * 12 * L : hb[g]);
      }
    }
    if (!a->corner)
      for (int g = 0; g < nb; g++)
        hess_scatter_block(a, b + (size_t)g, hb[g], 3);
  }
}

// The rsqrt mode as a run-time value: one inlined SVD per model and ISA
// (a predictable branch at each rsqrt), not one per mode.
EK_INLINE void gradient_blocks_iso(const hess_args *a, size_t b0, size_t b1) {
  gradient_blocks(a->svd->exact_rsqrt != 0, a, b0, b1);
}
#endif

// The model's entry: every op.
EK_INLINE void hess_model_blocks(const hess_args *a, size_t b0, size_t b1) {
  (void)b0, (void)b1; // an isotropic model's float entry has nothing to run
  switch (a->op) {
  case HESS_GRADIENT:
#if defined(EK_REAL_F64)
    if (MODEL_ISOTROPIC)
      gradient_blocks_iso(a, b0, b1);
    else
      gradient_blocks(0, a, b0, b1);
#endif
    break;
  case HESS_APPLY:
  case HESS_DIAG:
  case HESS_ELEMENT:
#if MODEL_ISOTROPIC
    // Not reached: the driver (hessian.c) runs the shared frame kernel.
#else
    if (a->op == HESS_APPLY)
      apply_blocks(a, b0, b1);
    else if (a->op == HESS_ELEMENT)
      element_blocks(a, b0, b1);
    else
      diag_blocks(a, b0, b1);
#endif
    break;
  }
}

#endif
