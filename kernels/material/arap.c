// As-rigid-as-possible (seed 000; Sorkine & Alexa 2007): fixed corotated
// with lambda = 0 (bodies in families.h): psi = mu sum (s_i - 1)^2,
// g_i = 2 mu (s_i - 1), A = 2 mu I, flip = 2 mu, twist = 2 mu - 4 mu /
// (s_i + s_j) (Smith et al. 2019; derived from g). With R given (the warm
// polar): P = 2 mu (F - R). No volume term: lambda is ignored.
#define MODEL arap
#define MODEL_ID EK_MODEL_ARAP
#define MODEL_NAME "arap"
#define MODEL_LONG_NAME "arap"
#define MODEL_NEEDS EK_NEEDS_POLAR
#define MODEL_CLAMPABLE 1
#define MODEL_ISOTROPIC 1
#define MODEL_F_FORM 0
#define MODEL_READS_R 0
#define MODEL_WARM_POLAR 1
#define MODEL_J_DOMAIN 0
#define MODEL_VOLUME_TERM 0
#include "model.h"

#ifndef EK_MODEL_DESCRIPTOR
#include "families.h"

static inline void model_sigma(const ek_material_lanes *m, const vreal s[3], mat_sigma_terms *t) {
  fixed_corot_sigma_l(m->mu, 0, s, t);
}

static inline void model_sigma_grad(const ek_material_lanes *m, const vreal s[3], vreal g[3]) {
  vreal two_mu = vset(2 * m->mu), one = vset(1);
  for (int i = 0; i < 3; i++)
    g[i] = vmul(two_mu, vsub(s[i], one));
}

static inline void model_pk1_rotation(const ek_material_lanes *m, const vreal F[9],
                                      const vreal R[9], vreal P[9]) {
  fixed_corot_pk1_R_l(m->mu, 0, F, R, P);
}

#include "model_kernels.h"
#else
#include <ek/cloth_force.h>

const ek_model_desc ek_model_arap = {
    EK_MODEL_DESC_TRAITS, .has_membrane = 1, .membrane = EK_MEMBRANE_ARAP,
    .linearise = ek_model_lame_no_volume, .from_linear = ek_model_lame_no_volume_inverse};
#endif
