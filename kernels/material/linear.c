// Linear elasticity (seed 000; Sifakis & Barbic 2012 course notes, ch. 3):
// psi = mu e:e + lambda/2 tr(e)^2, e = sym(F) - I, P = 2 mu e + lambda
// tr(e) I, dP = mu (dF + dF^T) + lambda tr(dF) I (bodies in families.h,
// shared with corotated linear). The Hessian is constant with eigenvalues
// 2 mu (x5), 2 mu + 3 lambda and 0 (x3, the skew directions), all >= 0 for
// valid parameters: project is a no-op. Valid for small strains and small
// rotations only (not rotation invariant).
#define MODEL linear
#define MODEL_ID EK_MODEL_LINEAR
#define MODEL_NAME "linear"
#define MODEL_LONG_NAME "linear"
#define MODEL_NEEDS EK_NEEDS_NOTHING
#define MODEL_CLAMPABLE 0
#define MODEL_ISOTROPIC 0
#define MODEL_F_FORM 1
#define MODEL_READS_R 0
#define MODEL_WARM_POLAR 0
#define MODEL_J_DOMAIN 0
#define MODEL_VOLUME_TERM 1
#include "model.h"

#ifndef EK_MODEL_DESCRIPTOR
#include "families.h"

static inline vreal model_psi(const ek_material_lanes *m, const vreal F[9], const vreal R[9]) {
  (void)R;
  return linear_psi_l(m->mu, m->lambda, F);
}

static inline void model_pk1(const ek_material_lanes *m, const vreal F[9], const vreal R[9],
                             vreal P[9]) {
  (void)R;
  linear_pk1_l(m->mu, m->lambda, F, P);
}

static inline void model_diff(const ek_material_lanes *m, const vreal F[9], const vreal R[9],
                              const vreal dF[9], vreal dP[9]) {
  (void)F, (void)R;
  linear_diff_l(m->mu, m->lambda, dF, dP);
}

#include "model_kernels.h"
#else

// Small strain (the bound, advise.h EK_ADVISE_SMALL_STRAIN: the dropped
// quadratic strain term) and small rotation (its ghost strain 1 - cos
// theta within half of the bound).
static const char *linear_excluded(const ek_model_run_stats *r, double clamp, double eps, char *why,
                                   size_t len) {
  (void)clamp;
  if (r->max_strain > eps)
    snprintf(why, len, "large strain: max |F^T F - I| = %.3g > %g (small-strain model)",
             r->max_strain, eps);
  else if (1 - cos(r->max_rotation) > eps / 2)
    snprintf(why, len,
             "large rotation: %.3g rad, ghost strain 1 - cos = %.3g > %g (not rotation "
             "invariant)",
             r->max_rotation, 1 - cos(r->max_rotation), eps / 2);
  else
    return NULL;
  return why;
}

const ek_model_desc ek_model_linear = {EK_MODEL_DESC_TRAITS, .linearise = ek_model_lame_same,
                                       .from_linear = ek_model_lame_same_inverse,
                                       .excluded = linear_excluded};
#endif
