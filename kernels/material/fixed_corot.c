// Fixed corotated (Stomakhin et al. 2012, "Energetically consistent
// invertible elasticity"), in singular values (R(F) = U V^T needs the SVD
// anyway; bodies in families.h, shared with ARAP):
//   psi = mu sum (s_i - 1)^2 + lambda/2 (J - 1)^2, J = s_0 s_1 s_2
//   g_i = 2 mu (s_i - 1) + lambda (J - 1) s_j s_k
//   A_ii = 2 mu + lambda (s_j s_k)^2, A_ij = lambda s_k (2 J - 1)
//   flip_ij  = 2 mu - lambda (J - 1) s_k
//   twist_ij = 2 mu - 4 mu / (s_i + s_j) + lambda (J - 1) s_k
// (the twist/flip pairs of Smith et al. 2019; closed forms derived here
// from g). twist is singular at s_i + s_j = 0, where R(F) is not
// differentiable. With R given (the warm-started polar): P = 2 mu (F - R)
// + lambda (J - 1) cof(F). Finite for every F (invertible).
#define MODEL fixed_corot
#define MODEL_ID EK_MODEL_FIXED_COROTATED
#define MODEL_NAME "fixed_corot"
#define MODEL_LONG_NAME "fixed_corotated"
#define MODEL_NEEDS EK_NEEDS_POLAR
#define MODEL_CLAMPABLE 1
#define MODEL_ISOTROPIC 1
#define MODEL_F_FORM 0
#define MODEL_READS_R 0
#define MODEL_WARM_POLAR 1
#define MODEL_J_DOMAIN 0
#define MODEL_VOLUME_TERM 1
#include "model.h"

#ifndef EK_MODEL_DESCRIPTOR
#include "families.h"

static inline void model_sigma(const ek_material_lanes *m, const vreal s[3], mat_sigma_terms *t) {
  fixed_corot_sigma_l(m->mu, m->lambda, s, t);
}

static inline void model_sigma_grad(const ek_material_lanes *m, const vreal s[3], vreal g[3]) {
  fixed_corot_sigma_grad_l(m->mu, m->lambda, s, g);
}

static inline void model_pk1_rotation(const ek_material_lanes *m, const vreal F[9],
                                      const vreal R[9], vreal P[9]) {
  fixed_corot_pk1_R_l(m->mu, m->lambda, F, R, P);
}

#include "model_kernels.h"
#else
const ek_model_desc ek_model_fixed_corot = {EK_MODEL_DESC_TRAITS, .linearise = ek_model_lame_same,
                                            .from_linear = ek_model_lame_same_inverse};
#endif
