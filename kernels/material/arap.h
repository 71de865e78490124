// As-rigid-as-possible on registers (seed 000; Sorkine & Alexa 2007):
// fixed corotated with lambda = 0: psi = mu sum (s_i - 1)^2,
// g_i = 2 mu (s_i - 1), A = 2 mu I, flip = 2 mu,
// twist = 2 mu - 4 mu / (s_i + s_j) (Smith et al. 2019; derived from g).
#ifndef EK_MAT_ARAP_H
#define EK_MAT_ARAP_H
#include "fixed_corot.h"

static inline void arap_sigma(const ek_material_lanes *m, const vreal s[3], mat_sigma_terms *t) {
  fixed_corot_sigma_l(m->mu, 0, s, t);
}

static inline void arap_sigma_grad(const ek_material_lanes *m, const vreal s[3], vreal g[3]) {
  vreal two_mu = vset(2 * m->mu), one = vset(1);
  for (int i = 0; i < 3; i++)
    g[i] = vmul(two_mu, vsub(s[i], one));
}
#endif
