// Fixed corotated on registers (Stomakhin et al. 2012, "Energetically
// consistent invertible elasticity"), in singular values (R(F) =
// U V^T needs the SVD anyway):
//   psi = mu sum (s_i - 1)^2 + lambda/2 (J - 1)^2, J = s_0 s_1 s_2
//   g_i = 2 mu (s_i - 1) + lambda (J - 1) s_j s_k
//   A_ii = 2 mu + lambda (s_j s_k)^2, A_ij = lambda s_k (2 J - 1)
//   flip_ij  = 2 mu - lambda (J - 1) s_k
//   twist_ij = 2 mu - 4 mu / (s_i + s_j) + lambda (J - 1) s_k
// (the twist/flip pairs of Smith et al. 2019; closed forms derived here from g). twist is
// singular at s_i + s_j = 0, where R(F) is not differentiable.
#ifndef EK_MAT_FIXED_COROT_H
#define EK_MAT_FIXED_COROT_H
#include "material_math.h"

static inline void fixed_corot_sigma_l(real mu_, real lambda_, const vreal s[3],
                                       mat_sigma_terms *t) {
  vreal mu = vset(mu_), lambda = vset(lambda_), one = vset(1), two_mu = vset(2 * mu_);
  vreal pair[3] = {vmul(s[1], s[2]), vmul(s[0], s[2]), vmul(s[0], s[1])}; // J / s_i
  vreal J = vmul(pair[0], s[0]), Jm1 = vsub(J, one), lJm1 = vmul(lambda, Jm1);
  vreal d[3] = {vsub(s[0], one), vsub(s[1], one), vsub(s[2], one)};
  t->psi = vmla(mu, vmla(d[0], d[0], vmla(d[1], d[1], vmul(d[2], d[2]))),
                vmul(vset((real)0.5 * lambda_), vmul(Jm1, Jm1)));
  for (int i = 0; i < 3; i++) {
    t->g[i] = vmla(two_mu, d[i], vmul(lJm1, pair[i]));
    t->A[i][i] = vmla(lambda, vmul(pair[i], pair[i]), two_mu);
  }
  vreal two_J_m1 = vsub(vadd(J, J), one);
  for (int p = 0; p < 3; p++) {
    const int i = mat_pair_i[p], j = mat_pair_j[p], k = mat_pair_k[p];
    t->A[i][j] = t->A[j][i] = vmul(lambda, vmul(s[k], two_J_m1));
    vreal c = vmul(lJm1, s[k]);
    t->flip[p] = vsub(two_mu, c);
    t->twist[p] = vadd(vsub(two_mu, vdiv(vset(4 * mu_), vadd(s[i], s[j]))), c);
  }
  (void)mu;
}

// The gradient g alone (what P needs).
static inline void fixed_corot_sigma_grad_l(real mu, real lambda, const vreal s[3], vreal g[3]) {
  vreal one = vset(1), two_mu = vset(2 * mu);
  vreal pair[3] = {vmul(s[1], s[2]), vmul(s[0], s[2]), vmul(s[0], s[1])}; // J / s_i
  vreal lJm1 = vmul(vset(lambda), vsub(vmul(pair[0], s[0]), one));
  for (int i = 0; i < 3; i++)
    g[i] = vmla(two_mu, vsub(s[i], one), vmul(lJm1, pair[i]));
}

static inline void fixed_corot_sigma_grad(const ek_material_lanes *m, const vreal s[3],
                                          vreal g[3]) {
  fixed_corot_sigma_grad_l(m->mu, m->lambda, s, g);
}

// P from F and its rotation R = polar(F) (the warm-started polar's path,
// kernels/polar/polar_warm_core.h; no SVD): U diag(g) V^T with the g above
// is 2 mu (F - R) + lambda (J - 1) cof(F), cof(F) = J F^-T = U diag(s_j s_k)
// V^T (Stomakhin et al. 2012, eq. 1's derivative).
static inline void fixed_corot_pk1_R_l(real mu, real lambda, const vreal F[9], const vreal R[9],
                                       vreal P[9]) {
  vreal two_mu = vset(2 * mu);
  for (int i = 0; i < 9; i++)
    P[i] = vmul(two_mu, vsub(F[i], R[i]));
  if (lambda != 0) {
    vreal C[9];
    vm3_cof(F, C);
    vreal lJm1 = vmul(vset(lambda), vsub(vm3_det_cof(F, C), vset(1)));
    for (int i = 0; i < 9; i++)
      P[i] = vmla(lJm1, C[i], P[i]);
  }
}

static inline void fixed_corot_sigma(const ek_material_lanes *m, const vreal s[3],
                                     mat_sigma_terms *t) {
  fixed_corot_sigma_l(m->mu, m->lambda, s, t);
}
#endif
