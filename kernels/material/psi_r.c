// Psi_R (seed 000, "simplified models"): psi = mu/4 |C - I|^2 = mu E:E,
// i.e. StVK with lambda = 0 (bodies in families.h); P = mu F (C - I). No
// volume term: lambda is ignored. Like StVK it softens past sigma =
// 1/sqrt(3).
#define MODEL psi_r
#define MODEL_ID EK_MODEL_PSI_R
#define MODEL_NAME "psi_r"
#define MODEL_LONG_NAME "psi_r"
#define MODEL_NEEDS EK_NEEDS_NOTHING
#define MODEL_CLAMPABLE 0
#define MODEL_ISOTROPIC 1
#define MODEL_F_FORM 1
#define MODEL_READS_R 0
#define MODEL_WARM_POLAR 0
#define MODEL_J_DOMAIN 0
#define MODEL_VOLUME_TERM 0
#include "model.h"

#ifndef EK_MODEL_DESCRIPTOR
#include "families.h"

static inline vreal model_psi(const ek_material_lanes *m, const vreal F[9], const vreal R[9]) {
  (void)R;
  return stvk_psi_l(m->mu, 0, F);
}

static inline void model_pk1(const ek_material_lanes *m, const vreal F[9], const vreal R[9],
                             vreal P[9]) {
  (void)R;
  stvk_pk1_l(m->mu, 0, F, P);
}

static inline void model_diff(const ek_material_lanes *m, const vreal F[9], const vreal R[9],
                              const vreal dF[9], vreal dP[9]) {
  (void)R;
  stvk_diff_l(m->mu, 0, F, dF, dP);
}

static inline void model_sigma(const ek_material_lanes *m, const vreal s[3], mat_sigma_terms *t) {
  stvk_sigma_l(m->mu, 0, s, t);
}

#include "model_kernels.h"
#else
const ek_model_desc ek_model_psi_r = {EK_MODEL_DESC_TRAITS, .linearise = ek_model_lame_no_volume,
                                      .from_linear = ek_model_lame_no_volume_inverse,
                                      .excluded = ek_model_excluded_past_peak};
#endif
