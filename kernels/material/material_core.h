// Material models on registers: psi, P, dP and the element Hessian for one
// vector of EK_W elements. Every function takes the model in
// ek_material_lanes; callers pass a compile-time constant (the block kernels
// of material_block.c, the FVM kernel instantiated per model), so the
// switches and table look-ups (models.h) fold away and each model gets its
// own straight-line code. Used by the material block kernels (through
// material_blocks below) and fused into other kernels (the FVM force
// kernel: gather -> F -> material_pk1 -> scatter, with no memory round
// trip). Include after simd/simd.h.
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
EK_INLINE ek_material_lanes material_lanes_make(ek_model model, double mu, double lambda,
                                                double clamp, const ek_svd3_knobs *svd) {
  ek_material_lanes m = {model, (real)mu, (real)lambda, (real)clamp, *svd};
  return m;
}

// 1 if psi and P go through singular values for these parameters.
EK_INLINE int material_uses_sigma(const ek_material_lanes *m) {
  return ek_model_row_uses_sigma(m->model, m->clamp);
}

// The switches below list every model and have no default (kernels are
// built with -Werror=switch, models.h). A model without the form a switch
// selects never reaches it: the table sends it another way, and its case
// says which.

// The singular-value form (isotropic models).
EK_INLINE void material_sigma_terms(const ek_material_lanes *m, const vreal s[3],
                                    mat_sigma_terms *t) {
  switch (m->model) {
  case EK_MODEL_LINEAR:
  case EK_MODEL_COROTATED_LINEAR:
    break; // not isotropic: dP in F only
  case EK_MODEL_STVK:
    stvk_sigma(m, s, t);
    break;
  case EK_MODEL_PSI_R:
    psi_r_sigma(m, s, t);
    break;
  case EK_MODEL_FIXED_COROTATED:
    fixed_corot_sigma(m, s, t);
    break;
  case EK_MODEL_ARAP:
    arap_sigma(m, s, t);
    break;
  case EK_MODEL_NEO_HOOKEAN:
    nh_sigma(m, s, t);
    break;
  case EK_MODEL_STABLE_NEO_HOOKEAN:
    snh_sigma(m, s, t);
    break;
  }
}

// g = d psi_hat / d sigma alone, for the models P takes through singular
// values (fixed corotated, ARAP, and neo-Hookean / stable neo-Hookean under
// the clamp).
EK_INLINE void material_sigma_grad(const ek_material_lanes *m, const vreal s[3], vreal g[3]) {
  switch (m->model) {
  case EK_MODEL_LINEAR:
  case EK_MODEL_COROTATED_LINEAR:
  case EK_MODEL_STVK:
  case EK_MODEL_PSI_R:
    // Not clampable: P in F only (the table never sends these here; the
    // block loop is compiled for every op, so say what it would get).
    for (int i = 0; i < 3; i++)
      g[i] = vset((real)NAN);
    break;
  case EK_MODEL_FIXED_COROTATED:
    fixed_corot_sigma_grad(m, s, g);
    break;
  case EK_MODEL_ARAP:
    arap_sigma_grad(m, s, g);
    break;
  case EK_MODEL_NEO_HOOKEAN:
    nh_sigma_grad(m, s, g);
    break;
  case EK_MODEL_STABLE_NEO_HOOKEAN:
    snh_sigma_grad(m, s, g);
    break;
  }
}

// P from a given SVD of F: U diag(g(sigma_hat)) V^T (Irving et al. 2004
// sec. 5), for the models with material_uses_sigma().
EK_INLINE void material_pk1_svd(const ek_material_lanes *m, const vreal U[9], const vreal S[3],
                                const vreal V[9], vreal P[9]) {
  vreal Sh[3], g[3];
  mat_clamp_sigma(m, S, Sh);
  material_sigma_grad(m, Sh, g);
  mat_udvt(U, g, V, P);
}

// P(F) from F and R = polar(F) given (the warm-started polar), for fixed
// corotated and ARAP without clamp: 2 mu (F - R) + lambda (J - 1) cof(F),
// lambda = 0 for ARAP (fixed_corot.h).
EK_INLINE void material_pk1_rotation(const ek_material_lanes *m, const vreal F[9], const vreal R[9],
                                     vreal P[9]) {
  fixed_corot_pk1_R_l(m->mu, m->model == EK_MODEL_ARAP ? 0 : m->lambda, F, R, P);
}

// P(F) in F, for the parameters without material_uses_sigma() (those go
// through an SVD of their caller's, material_pk1_svd). R is read only for
// corotated linear.
EK_INLINE void material_pk1(const ek_material_lanes *m, const vreal F[9], const vreal R[9],
                            vreal P[9]) {
  switch (m->model) {
  case EK_MODEL_LINEAR:
    linear_pk1(m, F, P);
    break;
  case EK_MODEL_COROTATED_LINEAR:
    corot_linear_pk1(m, F, R, P);
    break;
  case EK_MODEL_STVK:
    stvk_pk1(m, F, P);
    break;
  case EK_MODEL_PSI_R:
    psi_r_pk1(m, F, P);
    break;
  case EK_MODEL_NEO_HOOKEAN:
    nh_pk1(m, F, P);
    break;
  case EK_MODEL_STABLE_NEO_HOOKEAN:
    snh_pk1(m, F, P);
    break;
  case EK_MODEL_FIXED_COROTATED:
  case EK_MODEL_ARAP:
    break; // need the polar decomposition: material_pk1_svd
  }
}

// psi(F); under the clamp extended to first order: psi_hat(sigma_hat) +
// sum_i g_i (sigma_i - sigma_hat_i) (= P(F_hat):(F - F_hat), material.h).
// psi from a given SVD of F (models with material_uses_sigma()).
EK_INLINE vreal material_psi_svd(const ek_material_lanes *m, const vreal S[3]) {
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

// psi(F) in F (parameters without material_uses_sigma()).
EK_INLINE vreal material_psi(const ek_material_lanes *m, const vreal F[9], const vreal R[9]) {
  switch (m->model) {
  case EK_MODEL_LINEAR:
    return linear_psi(m, F);
  case EK_MODEL_COROTATED_LINEAR:
    return corot_linear_psi(m, F, R);
  case EK_MODEL_STVK:
    return stvk_psi(m, F);
  case EK_MODEL_PSI_R:
    return psi_r_psi(m, F);
  case EK_MODEL_NEO_HOOKEAN:
    return nh_psi(m, F);
  case EK_MODEL_STABLE_NEO_HOOKEAN:
    return snh_psi(m, F);
  case EK_MODEL_FIXED_COROTATED:
  case EK_MODEL_ARAP:
    break; // need the polar decomposition: material_psi_svd
  }
  return vset((real)NAN);
}

// 1 if dP for these parameters goes through the U, V frame.
EK_INLINE int material_diff_uses_frame(const ek_material_lanes *m, int project) {
  return material_uses_sigma(m) || (project && ek_model_rows[m->model].isotropic);
}

// The U, V-frame operator from a given SVD of F (F itself is read for the
// neo-Hookean domain test).
EK_INLINE void material_frame_svd(const ek_material_lanes *m, const vreal F[9], const vreal U[9],
                                  const vreal S[3], const vreal V[9], int project, mat_frame *fr) {
  vreal Sh[3];
  mat_sigma_terms t;
  for (int i = 0; i < 9; i++)
    fr->U[i] = U[i], fr->V[i] = V[i];
  mat_clamp_sigma(m, S, Sh);
  material_sigma_terms(m, Sh, &t);
  mat_frame_prepare(fr, &t, project);
  if (m->model == EK_MODEL_NEO_HOOKEAN && !(m->clamp > 0)) {
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

// dP in F for the models that have it (no SVD; parameters without
// material_diff_uses_frame()).
EK_INLINE void material_diff_direct(const ek_material_lanes *m, const vreal F[9], const vreal R[9],
                                    const vreal dF[9], vreal dP[9]) {
  switch (m->model) {
  case EK_MODEL_LINEAR:
    linear_diff(m, dF, dP);
    break;
  case EK_MODEL_COROTATED_LINEAR:
    corot_linear_diff(m, R, dF, dP);
    break;
  case EK_MODEL_STVK:
    stvk_diff(m, F, dF, dP);
    break;
  case EK_MODEL_PSI_R:
    psi_r_diff(m, F, dF, dP);
    break;
  case EK_MODEL_NEO_HOOKEAN:
    nh_diff(m, F, dF, dP);
    break;
  case EK_MODEL_STABLE_NEO_HOOKEAN:
    snh_diff(m, F, dF, dP);
    break;
  case EK_MODEL_FIXED_COROTATED:
  case EK_MODEL_ARAP:
    break; // need the polar decomposition: through the U, V frame
  }
}

// The 9x9 Hessian in F (parameters without material_diff_uses_frame()),
// H[a*9 + b] = d P_a / d F_b (symmetric), one column per unit dF.
EK_INLINE void material_hessian(const ek_material_lanes *m, const vreal F[9], const vreal R[9],
                                vreal H[81]) {
  vreal zero = vzero(), one = vset(1), dF[9], dP[9];
  for (int b = 0; b < 9; b++) {
    for (int k = 0; k < 9; k++)
      dF[k] = k == b ? one : zero;
    material_diff_direct(m, F, R, dF, dP);
    for (int a = 0; a < 9; a++)
      H[9 * a + b] = dP[a];
  }
}

// ---- Block loop over AoSoA data (layout of include/ek/batch.h) ----

// Offset of vector j's entry 0 in a batch of `planes`-plane blocks.
EK_INLINE size_t material_vec_offset(size_t j, int planes) {
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
    case EK_MAT_ENERGY:
      vstore(o, material_psi_svd(m, S[j]));
      break;
    case EK_MAT_PK1:
      material_pk1_svd(m, U[j], S[j], V[j], P);
      for (int i = 0; i < 9; i++)
        vstore(o + (size_t)i * EK_LANES, P[i]);
      break;
    case EK_MAT_PK1_DIFF:
      material_frame_svd(m, Fv[j], U[j], S[j], V[j], k->project, &fr);
      for (int i = 0; i < 9; i++)
        dFv[i] = vload(dF + material_vec_offset(j0 + (size_t)j, 9) + (size_t)i * EK_LANES);
      mat_frame_apply(&fr, dFv, P);
      for (int i = 0; i < 9; i++)
        vstore(o + (size_t)i * EK_LANES, P[i]);
      break;
    case EK_MAT_HESSIAN:
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
EK_INLINE void material_blocks(ek_model model, size_t nblocks, const real *F, const real *R,
                               const real *dF, real *out, const ek_material_knobs *k) {
  ek_material_lanes m = material_lanes_make(model, k->mu, k->lambda, k->clamp, &k->svd);
  const int nout = k->op == EK_MAT_ENERGY ? 1 : k->op == EK_MAT_HESSIAN ? 81 : 9;
  const int svd = k->op == EK_MAT_ENERGY || k->op == EK_MAT_PK1
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
        Rv[i] = model == EK_MODEL_COROTATED_LINEAR ? vload(R + in + (size_t)i * EK_LANES) : vzero();
      }
      switch (k->op) {
      case EK_MAT_ENERGY:
        vstore(out + o, material_psi(&m, Fv, Rv));
        break;
      case EK_MAT_PK1:
        material_pk1(&m, Fv, Rv, P);
        for (int i = 0; i < 9; i++)
          vstore(out + o + (size_t)i * EK_LANES, P[i]);
        break;
      case EK_MAT_PK1_DIFF:
        for (int i = 0; i < 9; i++)
          dFv[i] = vload(dF + in + (size_t)i * EK_LANES);
        material_diff_direct(&m, Fv, Rv, dFv, P);
        for (int i = 0; i < 9; i++)
          vstore(out + o + (size_t)i * EK_LANES, P[i]);
        break;
      case EK_MAT_HESSIAN: {
        vreal H[81];
        material_hessian(&m, Fv, Rv, H);
        for (int i = 0; i < 81; i++)
          vstore(out + o + (size_t)i * EK_LANES, H[i]);
        break;
      }
      }
    }
}

#endif
