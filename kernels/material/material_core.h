// Material models on registers: psi, P, dP and the element Hessian for one
// vector of EK_W elements, model chosen at run time (one switch per call,
// not per lane). Used by the material block kernels (kernels/material/
// <model>.c, through material_blocks below) and fused into other kernels
// (the FVM force kernel: gather -> F -> material_pk1 -> scatter, with no
// memory round trip). Include after simd/simd.h; needs kernels.h for the
// block loop's knobs.
//
// Which path a call takes (include/ek/material.h has the contract):
// - linear, corotated linear: formulas in F; the Hessian is always PSD.
// - StVK, Psi_R, neo-Hookean, stable neo-Hookean without clamp: formulas in
//   F, no SVD for psi and P (nor for dP unless project != 0).
// - fixed corotated, ARAP, and neo-Hookean / stable neo-Hookean with
//   clamp > 0: the SVD, sigma_hat = max(sigma, clamp), P = U diag(g) V^T
//   (Irving et al. 2004 sec. 5), dP by the U, V-frame eigensystem (Teran et
//   al. 2005), which is also how any isotropic model projects.
#ifndef EK_MATERIAL_CORE_H
#define EK_MATERIAL_CORE_H

#include "arap.h"
#include "corot_linear.h"
#include "fixed_corot.h"
#include "linear.h"
#include "material_math.h"
#include "nh.h"
#include "psi_r.h"
#include "snh.h"
#include "stvk.h"

// Parameters for the inline functions (svd: e.g. ek_svd3_default_knobs_f32()).
static inline ek_material_lanes material_lanes_make(int model, double mu, double lambda,
                                                    double clamp, const ek_svd3_knobs *svd) {
  ek_material_lanes m = {model, (real)mu, (real)lambda, (real)clamp, *svd};
  return m;
}

// 1 if psi and P go through singular values for these parameters.
static inline int material_uses_sigma(const ek_material_lanes *m) {
  switch (m->model) {
  case MAT_FIXED_COROT:
  case MAT_ARAP:
    return 1;
  case MAT_NH:
  case MAT_SNH:
    return m->clamp > 0;
  default:
    return 0;
  }
}

// 1 for the models with a singular-value form (all but the linear two).
static inline int material_isotropic(int model) {
  return model != MAT_LINEAR && model != MAT_COROT_LINEAR;
}

static inline void material_sigma_terms(const ek_material_lanes *m, const vreal s[3],
                                        mat_sigma_terms *t) {
  switch (m->model) {
  case MAT_STVK:
    stvk_sigma(m, s, t);
    break;
  case MAT_PSI_R:
    psi_r_sigma(m, s, t);
    break;
  case MAT_FIXED_COROT:
    fixed_corot_sigma(m, s, t);
    break;
  case MAT_ARAP:
    arap_sigma(m, s, t);
    break;
  case MAT_NH:
    nh_sigma(m, s, t);
    break;
  default:
    snh_sigma(m, s, t);
    break;
  }
}

// g = d psi_hat / d sigma alone, for the models P takes through singular
// values (fixed corotated, ARAP, and neo-Hookean / stable neo-Hookean under
// the clamp).
static inline void material_sigma_grad(const ek_material_lanes *m, const vreal s[3], vreal g[3]) {
  switch (m->model) {
  case MAT_FIXED_COROT:
    fixed_corot_sigma_grad(m, s, g);
    break;
  case MAT_ARAP:
    arap_sigma_grad(m, s, g);
    break;
  case MAT_NH:
    nh_sigma_grad(m, s, g);
    break;
  default:
    snh_sigma_grad(m, s, g);
    break;
  }
}

// P from a given SVD of F: U diag(g(sigma_hat)) V^T (Irving et al. 2004
// sec. 5), for the models with material_uses_sigma().
static inline void material_pk1_svd(const ek_material_lanes *m, const vreal U[9], const vreal S[3],
                                    const vreal V[9], vreal P[9]) {
  vreal Sh[3], g[3];
  mat_clamp_sigma(m, S, Sh);
  material_sigma_grad(m, Sh, g);
  mat_udvt(U, g, V, P);
}

// P(F). R is read only for corotated linear.
static inline void material_pk1(const ek_material_lanes *m, const vreal F[9], const vreal R[9],
                                vreal P[9]) {
  if (material_uses_sigma(m)) {
    vreal U[9], S[3], V[9];
    mat_svd(m, F, U, S, V);
    material_pk1_svd(m, U, S, V, P);
    return;
  }
  switch (m->model) {
  case MAT_LINEAR:
    linear_pk1(m, F, P);
    break;
  case MAT_COROT_LINEAR:
    corot_linear_pk1(m, F, R, P);
    break;
  case MAT_STVK:
    stvk_pk1(m, F, P);
    break;
  case MAT_PSI_R:
    psi_r_pk1(m, F, P);
    break;
  case MAT_NH:
    nh_pk1(m, F, P);
    break;
  default:
    snh_pk1(m, F, P);
    break;
  }
}

// psi(F); under the clamp extended to first order: psi_hat(sigma_hat) +
// sum_i g_i (sigma_i - sigma_hat_i) (= P(F_hat):(F - F_hat), material.h).
// psi from a given SVD of F (models with material_uses_sigma()).
static inline vreal material_psi_svd(const ek_material_lanes *m, const vreal S[3]) {
  vreal Sh[3];
  mat_sigma_terms t;
  mat_clamp_sigma(m, S, Sh);
  material_sigma_terms(m, Sh, &t);
  vreal psi = t.psi;
  if (m->clamp > 0)
    for (int i = 0; i < 3; i++)
      psi = vmla(t.g[i], vsub(S[i], Sh[i]), psi);
  return psi;
}

static inline vreal material_psi(const ek_material_lanes *m, const vreal F[9], const vreal R[9]) {
  if (material_uses_sigma(m)) {
    vreal U[9], S[3], V[9];
    mat_svd(m, F, U, S, V);
    return material_psi_svd(m, S);
  }
  switch (m->model) {
  case MAT_LINEAR:
    return linear_psi(m, F);
  case MAT_COROT_LINEAR:
    return corot_linear_psi(m, F, R);
  case MAT_STVK:
    return stvk_psi(m, F);
  case MAT_PSI_R:
    return psi_r_psi(m, F);
  case MAT_NH:
    return nh_psi(m, F);
  default:
    return snh_psi(m, F);
  }
}

// 1 if dP for these parameters goes through the U, V frame.
static inline int material_diff_uses_frame(const ek_material_lanes *m, int project) {
  return material_uses_sigma(m) || (project && material_isotropic(m->model));
}

// The U, V-frame operator from a given SVD of F (F itself is read for the
// neo-Hookean domain test).
static inline void material_frame_svd(const ek_material_lanes *m, const vreal F[9],
                                      const vreal U[9], const vreal S[3], const vreal V[9],
                                      int project, mat_frame *fr) {
  vreal Sh[3];
  mat_sigma_terms t;
  for (int i = 0; i < 9; i++)
    fr->U[i] = U[i], fr->V[i] = V[i];
  mat_clamp_sigma(m, S, Sh);
  material_sigma_terms(m, Sh, &t);
  mat_frame_prepare(fr, &t, project);
  if (m->model == MAT_NH && !(m->clamp > 0)) {
    // The domain is J = det F > 0, decided on F as in the F path (the
    // product of the computed singular values can differ in sign when J is
    // at rounding level, e.g. for a rank-1 F).
    vreal C[9], nan = vset((real)NAN);
    vm3_cof(F, C);
    vmask ok = vgt(vm3_det_cof(F, C), vzero());
    for (int i = 0; i < 3; i++) {
      fr->h[i] = vsel(ok, fr->h[i], nan);
      fr->q[i] = vsel(ok, fr->q[i], nan);
      for (int j = 0; j < 3; j++)
        fr->A[i][j] = vsel(ok, fr->A[i][j], nan);
    }
  }
}

static inline void material_frame(const ek_material_lanes *m, const vreal F[9], int project,
                                  mat_frame *fr) {
  vreal U[9], S[3], V[9];
  mat_svd(m, F, U, S, V);
  material_frame_svd(m, F, U, S, V, project, fr);
}

// dP in F for the models that have it (no SVD).
static inline void material_diff_direct(const ek_material_lanes *m, const vreal F[9],
                                        const vreal R[9], const vreal dF[9], vreal dP[9]) {
  switch (m->model) {
  case MAT_LINEAR:
    linear_diff(m, dF, dP);
    break;
  case MAT_COROT_LINEAR:
    corot_linear_diff(m, R, dF, dP);
    break;
  case MAT_STVK:
    stvk_diff(m, F, dF, dP);
    break;
  case MAT_PSI_R:
    psi_r_diff(m, F, dF, dP);
    break;
  case MAT_NH:
    nh_diff(m, F, dF, dP);
    break;
  default:
    snh_diff(m, F, dF, dP);
    break;
  }
}

// dP = H : dF, H projected to PSD when project != 0.
static inline void material_diff(const ek_material_lanes *m, const vreal F[9], const vreal R[9],
                                 const vreal dF[9], vreal dP[9], int project) {
  if (material_diff_uses_frame(m, project)) {
    mat_frame fr;
    material_frame(m, F, project, &fr);
    mat_frame_apply(&fr, dF, dP);
    return;
  }
  material_diff_direct(m, F, R, dF, dP);
}

// The 9x9 Hessian, H[a*9 + b] = d P_a / d F_b (symmetric), one column per
// unit dF.
static inline void material_hessian(const ek_material_lanes *m, const vreal F[9], const vreal R[9],
                                    vreal H[81], int project) {
  vreal zero = vzero(), one = vset(1), dF[9], dP[9];
  if (material_diff_uses_frame(m, project)) {
    mat_frame fr;
    material_frame(m, F, project, &fr);
    for (int b = 0; b < 9; b++) {
      for (int k = 0; k < 9; k++)
        dF[k] = k == b ? one : zero;
      mat_frame_apply(&fr, dF, dP);
      for (int a = 0; a < 9; a++)
        H[9 * a + b] = dP[a];
    }
    return;
  }
  for (int b = 0; b < 9; b++) {
    for (int k = 0; k < 9; k++)
      dF[k] = k == b ? one : zero;
    material_diff_direct(m, F, R, dF, dP);
    for (int a = 0; a < 9; a++)
      H[9 * a + b] = dP[a];
  }
}

// ---- Block loop over AoSoA data (layout of include/ek/batch.h) ----
// The op of ek_material_knobs (values of ek_material_op).
enum { MAT_OP_ENERGY, MAT_OP_PK1, MAT_OP_PK1_DIFF, MAT_OP_HESSIAN };

// Offset of vector j's entry 0 in a batch of `planes`-plane blocks.
static inline size_t material_vec_offset(size_t j, int planes) {
  return (j / EK_VPB) * (size_t)planes * EK_LANES + (j % EK_VPB) * EK_W;
}

// n vectors (n and exact compile-time constants at each call) through the
// SVD side by side (svd3_core_n: the Jacobi chains are latency bound, so two
// independent ones overlap, as in the SVD kernel), then each through the
// model.
EK_INLINE void material_vectors_svd(const ek_material_lanes *m, const ek_material_knobs *k, int n,
                                    size_t j0, const real *F, const real *dF, real *out, int nout,
                                    int exact) {
  vreal Fv[SVD3_MAX_N][9], U[SVD3_MAX_N][9], S[SVD3_MAX_N][3], V[SVD3_MAX_N][9], scale[SVD3_MAX_N];
  for (int j = 0; j < n; j++)
    for (int i = 0; i < 9; i++)
      Fv[j][i] = vload(F + material_vec_offset(j0 + (size_t)j, 9) + (size_t)i * EK_LANES);
  svd3_core_n(n, (const vreal(*)[9])Fv, U, S, V, scale, m->svd.sweeps, m->svd.refine, exact);
  for (int j = 0; j < n; j++)
    for (int i = 0; i < 3; i++)
      S[j][i] = vmul(S[j][i], scale[j]);
  for (int j = 0; j < n; j++) {
    real *o = out + material_vec_offset(j0 + (size_t)j, nout);
    vreal P[9], dFv[9], zero = vzero(), one = vset(1);
    mat_frame fr;
    switch (k->op) {
    case MAT_OP_ENERGY:
      vstore(o, material_psi_svd(m, S[j]));
      break;
    case MAT_OP_PK1:
      material_pk1_svd(m, U[j], S[j], V[j], P);
      for (int i = 0; i < 9; i++)
        vstore(o + (size_t)i * EK_LANES, P[i]);
      break;
    case MAT_OP_PK1_DIFF:
      material_frame_svd(m, Fv[j], U[j], S[j], V[j], k->project, &fr);
      for (int i = 0; i < 9; i++)
        dFv[i] = vload(dF + material_vec_offset(j0 + (size_t)j, 9) + (size_t)i * EK_LANES);
      mat_frame_apply(&fr, dFv, P);
      for (int i = 0; i < 9; i++)
        vstore(o + (size_t)i * EK_LANES, P[i]);
      break;
    default:
      material_frame_svd(m, Fv[j], U[j], S[j], V[j], k->project, &fr);
      for (int b = 0; b < 9; b++) {
        for (int i = 0; i < 9; i++)
          dFv[i] = i == b ? one : zero;
        mat_frame_apply(&fr, dFv, P);
        for (int a = 0; a < 9; a++)
          vstore(o + (size_t)(9 * a + b) * EK_LANES, P[a]);
      }
      break;
    }
  }
}

#define MATERIAL_SVD_IL 2
EK_INLINE void material_blocks_svd(const ek_material_lanes *m, const ek_material_knobs *k,
                                   size_t nblocks, const real *F, const real *dF, real *out,
                                   int nout, int exact) {
  size_t nvec = nblocks * EK_VPB, j = 0;
  for (; j + MATERIAL_SVD_IL <= nvec; j += MATERIAL_SVD_IL)
    material_vectors_svd(m, k, MATERIAL_SVD_IL, j, F, dF, out, nout, exact);
  for (; j < nvec; j++)
    material_vectors_svd(m, k, 1, j, F, dF, out, nout, exact);
}

// nblocks blocks of EK_LANES elements; F, R, dF 9 planes; out 1, 9 or 81
// planes by op. `model` is a constant in each per-model kernel, so the
// switches above fold away there.
static inline void material_blocks(int model, size_t nblocks, const real *F, const real *R,
                                   const real *dF, real *out, const ek_material_knobs *k) {
  ek_material_lanes m = material_lanes_make(model, k->mu, k->lambda, k->clamp, &k->svd);
  const int nout = k->op == MAT_OP_ENERGY ? 1 : k->op == MAT_OP_HESSIAN ? 81 : 9;
  const int svd = k->op == MAT_OP_ENERGY || k->op == MAT_OP_PK1
                      ? material_uses_sigma(&m)
                      : material_diff_uses_frame(&m, k->project);
  if (svd) {
    if (m.svd.exact_rsqrt)
      material_blocks_svd(&m, k, nblocks, F, dF, out, nout, 1);
    else
      material_blocks_svd(&m, k, nblocks, F, dF, out, nout, 0);
    return;
  }
  for (size_t b = 0; b < nblocks; b++)
    for (int v = 0; v < EK_VPB; v++) {
      const size_t in = b * 9 * EK_LANES + (size_t)v * EK_W;
      const size_t o = b * (size_t)nout * EK_LANES + (size_t)v * EK_W;
      vreal Fv[9], Rv[9], dFv[9], P[9];
      for (int i = 0; i < 9; i++) {
        Fv[i] = vload(F + in + (size_t)i * EK_LANES);
        Rv[i] = model == MAT_COROT_LINEAR ? vload(R + in + (size_t)i * EK_LANES) : vzero();
      }
      switch (k->op) {
      case MAT_OP_ENERGY:
        vstore(out + o, material_psi(&m, Fv, Rv));
        break;
      case MAT_OP_PK1:
        material_pk1(&m, Fv, Rv, P);
        for (int i = 0; i < 9; i++)
          vstore(out + o + (size_t)i * EK_LANES, P[i]);
        break;
      case MAT_OP_PK1_DIFF:
        for (int i = 0; i < 9; i++)
          dFv[i] = vload(dF + in + (size_t)i * EK_LANES);
        material_diff(&m, Fv, Rv, dFv, P, k->project);
        for (int i = 0; i < 9; i++)
          vstore(out + o + (size_t)i * EK_LANES, P[i]);
        break;
      default: {
        vreal H[81];
        material_hessian(&m, Fv, Rv, H, k->project);
        for (int i = 0; i < 81; i++)
          vstore(out + o + (size_t)i * EK_LANES, H[i]);
        break;
      }
      }
    }
}

#endif
