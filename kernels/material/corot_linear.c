// Corotated linear elasticity (seed 000): psi(F) = psi_linear(R^T F) with
// the given rotation R (R^n, refreshed from the positions at the start of
// each step), P = R P_linear(R^T F), dP = R dP_linear(R^T dF). The Hessian
// is the linear one rotated, PSD for valid parameters: project is a no-op.
// Valid for small strains and small rotations per step (R^n lags the step).
#define MODEL corot_linear
#define MODEL_ID EK_MODEL_COROTATED_LINEAR
#define MODEL_NAME "corot_linear"
#define MODEL_LONG_NAME "corotated_linear"
#define MODEL_NEEDS EK_NEEDS_R_INPUT
#define MODEL_CLAMPABLE 0
#define MODEL_ISOTROPIC 0
#define MODEL_F_FORM 1
#define MODEL_READS_R 1
#define MODEL_WARM_POLAR 0
#define MODEL_J_DOMAIN 0
#define MODEL_VOLUME_TERM 1
#include "model.h"

#ifndef EK_MODEL_DESCRIPTOR
#include "families.h"

static inline vreal model_psi(const ek_material_lanes *m, const vreal F[9], const vreal R[9]) {
  vreal G[9];
  vm3_mul_tn(R, F, G);
  return linear_psi_l(m->mu, m->lambda, G);
}

static inline void model_pk1(const ek_material_lanes *m, const vreal F[9], const vreal R[9],
                             vreal P[9]) {
  vreal G[9], PG[9];
  vm3_mul_tn(R, F, G);
  linear_pk1_l(m->mu, m->lambda, G, PG);
  vm3_mul(R, PG, P);
}

static inline void model_diff(const ek_material_lanes *m, const vreal F[9], const vreal R[9],
                              const vreal dF[9], vreal dP[9]) {
  vreal dG[9], dPG[9];
  (void)F;
  vm3_mul_tn(R, dF, dG);
  linear_diff_l(m->mu, m->lambda, dG, dPG);
  vm3_mul(R, dPG, dP);
}

#include "model_kernels.h"
#else

// Linear about R^n, the rotation at the step's start (seed 000; Muller and
// Gross 2004, "Interactive Virtual Materials", sec. 4): small strain, and
// the rotation within one step small enough that its ghost strain
// 1 - cos(dtheta) stays within half of the bound.
static const char *corot_linear_excluded(const ek_model_run_stats *r, double clamp, double eps,
                                         char *why, size_t len) {
  (void)clamp;
  if (r->max_strain > eps)
    snprintf(why, len, "large strain: max |F^T F - I| = %.3g > %g (small-strain model)",
             r->max_strain, eps);
  else if (1 - cos(r->max_rotation_step) > eps / 2)
    snprintf(why, len, "rotation per step %.3g rad: ghost strain %.3g > %g (R^n lags the step)",
             r->max_rotation_step, 1 - cos(r->max_rotation_step), eps / 2);
  else
    return NULL;
  return why;
}

const ek_model_desc ek_model_corot_linear = {EK_MODEL_DESC_TRAITS, .linearise = ek_model_lame_same,
                                             .from_linear = ek_model_lame_same_inverse,
                                             .excluded = corot_linear_excluded};
#endif
