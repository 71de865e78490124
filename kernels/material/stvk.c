// St. Venant-Kirchhoff (Sifakis & Barbic 2012 course notes, ch. 3):
// psi = mu E:E + lambda/2 tr(E)^2, E = (F^T F - I)/2, P = F S,
// S = 2 mu E + lambda tr(E) I; dP = dF S + F dS (bodies in families.h,
// shared with Psi_R). In singular values (to project): E_i = (s_i^2 - 1)/2,
// g_i = s_i (2 mu E_i + lambda tr E), A_ii = 2 mu E_i + lambda tr E +
// s_i^2 (2 mu + lambda), A_ij = lambda s_i s_j, flip = mu (s_i^2 + s_i s_j
// + s_j^2 - 1) + lambda tr E, twist = mu (s_i^2 - s_i s_j + s_j^2 - 1) +
// lambda tr E. Its compressive stress peaks at sigma = 1/sqrt(3) and falls
// beyond (seed 004 names StVK's inversion failure).
#define MODEL stvk
#define MODEL_ID EK_MODEL_STVK
#define MODEL_NAME "stvk"
#define MODEL_LONG_NAME "stvk"
#define MODEL_NEEDS EK_NEEDS_NOTHING
#define MODEL_CLAMPABLE 0
#define MODEL_ISOTROPIC 1
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
  return stvk_psi_l(m->mu, m->lambda, F);
}

static inline void model_pk1(const ek_material_lanes *m, const vreal F[9], const vreal R[9],
                             vreal P[9]) {
  (void)R;
  stvk_pk1_l(m->mu, m->lambda, F, P);
}

static inline void model_diff(const ek_material_lanes *m, const vreal F[9], const vreal R[9],
                              const vreal dF[9], vreal dP[9]) {
  (void)R;
  stvk_diff_l(m->mu, m->lambda, F, dF, dP);
}

static inline void model_sigma(const ek_material_lanes *m, const vreal s[3], mat_sigma_terms *t) {
  stvk_sigma_l(m->mu, m->lambda, s, t);
}

#include "model_kernels.h"
#else
#include <ek/cloth_force.h>

const ek_model_desc ek_model_stvk = {EK_MODEL_DESC_TRAITS,
                                     .has_membrane = 1,
                                     .membrane = EK_MEMBRANE_STVK,
                                     .linearise = ek_model_lame_same,
                                     .from_linear = ek_model_lame_same_inverse,
                                     .excluded = ek_model_excluded_past_peak};
#endif
