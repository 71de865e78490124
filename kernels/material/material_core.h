// The material stages of one model on registers: psi, P, dP and the
// element Hessian for one vector of EK_W elements, from the model file's
// traits and model_* functions (models.h), so each model gets its own
// straight-line code. Included once per model file through
// model_kernels.h: the material block kernels (material_blocks below) and
// the fused FVM and Hessian kernels (gather -> F -> P -> scatter, with no
// memory round trip) use it.
//
// Which path a call takes (include/ek/material.h has the contract):
// - linear, corotated linear: formulas in F; the Hessian is always PSD.
// - StVK, Psi_R, neo-Hookean, stable neo-Hookean without clamp: formulas in
//   F, no SVD for psi and P (nor for dP unless project != 0).
// - fixed corotated, ARAP, and neo-Hookean / stable neo-Hookean with
//   clamp > 0: the SVD, sigma_hat = max(sigma, clamp), P = U diag(g) V^T
//   (Irving et al. 2004 sec. 5), dP by the U, V-frame eigensystem (Teran et
//   al. 2005), which is also how any isotropic model projects.
// A stage a model has no form for is never reached (the traits send the
// call another way); it is still compiled, so it says what it would give.
#ifndef EK_MATERIAL_CORE_H
#define EK_MATERIAL_CORE_H

#include "material_math.h"

// Parameters for the inline functions (svd: e.g. ek_svd3_default_knobs_f32()).
EK_INLINE ek_material_lanes material_lanes_make(double mu, double lambda, double clamp,
                                                const ek_svd3_knobs *svd) {
  ek_material_lanes m = {(real)mu, (real)lambda, (real)clamp, *svd};
  return m;
}

// 1 if psi and P go through singular values for these parameters.
// (ek_model_row_uses_sigma from the traits.)
EK_INLINE int material_uses_sigma_at(double clamp) {
  return MODEL_NEEDS == EK_NEEDS_POLAR || MODEL_NEEDS == EK_NEEDS_SVD ||
         (MODEL_CLAMPABLE && clamp > 0);
}
EK_INLINE int material_uses_sigma(const ek_material_lanes *m) {
  return material_uses_sigma_at(m->clamp);
}

// sigma_hat = max(sigma, clamp) when clamp > 0 (Irving et al. 2004 sec. 5),
// for the models evaluated through singular values; StVK and Psi_R go
// through singular values only to project, and ignore the clamp.
EK_INLINE void mat_clamp_sigma(const ek_material_lanes *m, const vreal S[3], vreal Sh[3]) {
  int clamped = MODEL_CLAMPABLE && m->clamp > 0;
  for (int i = 0; i < 3; i++)
    Sh[i] = clamped ? vmax(vset(m->clamp), S[i]) : S[i];
}

// The singular-value form (isotropic models).
EK_INLINE void material_sigma_terms(const ek_material_lanes *m, const vreal s[3],
                                    mat_sigma_terms *t) {
#if MODEL_ISOTROPIC
  model_sigma(m, s, t);
#else
  (void)m, (void)s, (void)t; // not isotropic: dP in F only
#endif
}

// g = d psi_hat / d sigma alone, for the models P takes through singular
// values (fixed corotated, ARAP, and neo-Hookean / stable neo-Hookean under
// the clamp).
EK_INLINE void material_sigma_grad(const ek_material_lanes *m, const vreal s[3], vreal g[3]) {
#if MODEL_CLAMPABLE || MODEL_WARM_POLAR
  model_sigma_grad(m, s, g);
#else
  (void)m, (void)s;          // P in F only
  for (int i = 0; i < 3; i++)
    g[i] = vset((real)NAN);
#endif
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
// lambda = 0 for ARAP (fixed_corot.c, arap.c).
EK_INLINE void material_pk1_rotation(const ek_material_lanes *m, const vreal F[9], const vreal R[9],
                                     vreal P[9]) {
#if MODEL_WARM_POLAR
  model_pk1_rotation(m, F, R, P);
#else
  (void)m, (void)F, (void)R; // P needs no rotation of F's
  for (int i = 0; i < 9; i++)
    P[i] = vset((real)NAN);
#endif
}

// P(F) in F, for the parameters without material_uses_sigma() (those go
// through an SVD of their caller's, material_pk1_svd). R is read only for
// corotated linear.
EK_INLINE void material_pk1(const ek_material_lanes *m, const vreal F[9], const vreal R[9],
                            vreal P[9]) {
#if MODEL_F_FORM
  model_pk1(m, F, R, P);
#else
  (void)m, (void)F, (void)R; // needs the polar decomposition: material_pk1_svd
  for (int i = 0; i < 9; i++)
    P[i] = vset((real)NAN);
#endif
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
#if MODEL_F_FORM
  return model_psi(m, F, R);
#else
  (void)m, (void)F, (void)R; // needs the polar decomposition: material_psi_svd
  return vset((real)NAN);
#endif
}

// 1 if dP for these parameters goes through the U, V frame.
EK_INLINE int material_diff_uses_frame(const ek_material_lanes *m, int project) {
  return material_uses_sigma(m) || (project && MODEL_ISOTROPIC);
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
  if (MODEL_J_DOMAIN && !(m->clamp > 0)) {
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
#if MODEL_F_FORM
  model_diff(m, F, R, dF, dP);
#else
  (void)m, (void)F, (void)R, (void)dF; // needs the polar decomposition: the U, V frame
  for (int i = 0; i < 9; i++)
    dP[i] = vset((real)NAN);
#endif
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

// The lanes whose F (and R, for a model that reads one) is finite: a NaN or
// an infinity in an input gives NaN in every output entry of its lane, for
// every op (include/ek/material.h), as the SVD does for its factors; the
// formulas alone would leave some entries finite (P of linear at F = inf).
EK_INLINE vmask material_finite_lanes(const vreal F[9], const vreal R[9]) {
  const vreal inf = vset((real)INFINITY);
  vmask ok = vlt(vabs(F[0]), inf);
  for (int i = 1; i < 9; i++)
    ok = vmand(ok, vlt(vabs(F[i]), inf));
  if (MODEL_READS_R)
    for (int i = 0; i < 9; i++)
      ok = vmand(ok, vlt(vabs(R[i]), inf));
  return ok;
}

// Store n output planes; lanes outside `ok` get NaN (material_finite_lanes).
EK_INLINE void material_store(real *o, const vreal *v, int n, vmask ok) {
  if (vall(ok)) {
    for (int i = 0; i < n; i++)
      vstore(o + (size_t)i * EK_LANES, v[i]);
    return;
  }
  const vreal nan = vset((real)NAN);
  for (int i = 0; i < n; i++)
    vstore(o + (size_t)i * EK_LANES, vsel(ok, v[i], nan));
}

// Offset of vector j's entry 0 in a batch of `planes`-plane blocks.
EK_INLINE size_t material_vec_offset(size_t j, int planes) {
  return (j / EK_VPB) * (size_t)planes * EK_LANES + (j % EK_VPB) * EK_W;
}

// n vectors (n and exact compile-time constants at each call) through the
// SVD side by side (svd3_pair: the Jacobi chains are latency bound, so two
// independent ones overlap, as in the SVD kernel), then each through the
// model.
EK_INLINE void material_vectors_svd(const ek_material_lanes *m, const ek_material_knobs *k, int n,
                                    size_t j0, const real *F, const real *dF, real *out, int nout,
                                    int exact) {
  vreal Fv[2][9], U[2][9], S[2][3], V[2][9];
  for (int j = 0; j < n; j++)
    for (int i = 0; i < 9; i++)
      Fv[j][i] = vload(F + material_vec_offset(j0 + (size_t)j, 9) + (size_t)i * EK_LANES);
  svd3_pair(n, (const vreal(*)[9])Fv, U, S, V, m->svd.sweeps, m->svd.refine, exact);
  for (int j = 0; j < n; j++) {
    real *o = out + material_vec_offset(j0 + (size_t)j, nout);
    vreal P[9], dFv[9], zero = vzero(), one = vset(1);
    const vmask ok = material_finite_lanes(Fv[j], Fv[j]);
    mat_frame fr;
    switch (k->op) {
    case EK_MAT_ENERGY:
      P[0] = material_psi_svd(m, S[j]);
      material_store(o, P, 1, ok);
      break;
    case EK_MAT_PK1:
      material_pk1_svd(m, U[j], S[j], V[j], P);
      material_store(o, P, 9, ok);
      break;
    case EK_MAT_PK1_DIFF:
      material_frame_svd(m, Fv[j], U[j], S[j], V[j], k->project, &fr);
      for (int i = 0; i < 9; i++)
        dFv[i] = vload(dF + material_vec_offset(j0 + (size_t)j, 9) + (size_t)i * EK_LANES);
      mat_frame_apply(&fr, dFv, P);
      material_store(o, P, 9, ok);
      break;
    case EK_MAT_HESSIAN: {
      vreal H[81];
      material_frame_svd(m, Fv[j], U[j], S[j], V[j], k->project, &fr);
      for (int b = 0; b < 9; b++) {
        for (int i = 0; i < 9; i++)
          dFv[i] = i == b ? one : zero;
        mat_frame_apply(&fr, dFv, P);
        for (int a = 0; a < 9; a++)
          H[9 * a + b] = P[a];
      }
      material_store(o, H, 81, ok);
      break;
    }
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
// planes by op.
EK_INLINE void material_blocks(size_t nblocks, const real *F, const real *R, const real *dF,
                               real *out, const ek_material_knobs *k) {
  ek_material_lanes m = material_lanes_make(k->mu, k->lambda, k->clamp, &k->svd);
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
        Rv[i] = MODEL_READS_R ? vload(R + in + (size_t)i * EK_LANES) : vzero();
      }
      const vmask ok = material_finite_lanes(Fv, Rv);
      switch (k->op) {
      case EK_MAT_ENERGY:
        P[0] = material_psi(&m, Fv, Rv);
        material_store(out + o, P, 1, ok);
        break;
      case EK_MAT_PK1:
        material_pk1(&m, Fv, Rv, P);
        material_store(out + o, P, 9, ok);
        break;
      case EK_MAT_PK1_DIFF:
        for (int i = 0; i < 9; i++)
          dFv[i] = vload(dF + in + (size_t)i * EK_LANES);
        material_diff_direct(&m, Fv, Rv, dFv, P);
        material_store(out + o, P, 9, ok);
        break;
      case EK_MAT_HESSIAN: {
        vreal H[81];
        material_hessian(&m, Fv, Rv, H);
        material_store(out + o, H, 81, ok);
        break;
      }
      }
    }
}

#endif
