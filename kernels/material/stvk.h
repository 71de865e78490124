// St. Venant-Kirchhoff on registers (Sifakis & Barbic 2012 course notes,
// ch. 3): psi = mu E:E + lambda/2 tr(E)^2, E = (F^T F - I)/2,
// P = F S, S = 2 mu E + lambda tr(E) I; dP = dF S + F dS. Psi_R (seed 000)
// is this model with lambda = 0 (mu/4 |C - I|^2 = mu E:E), so psi_r.h
// reuses these functions with its own parameters.
#ifndef EK_MAT_STVK_H
#define EK_MAT_STVK_H
#include "material_math.h"

// S = 2 mu E + lambda tr(E) I from E (symmetric).
static inline void stvk_second_pk(real mu, real lambda, const vreal E[9], vreal S[9]) {
  vreal two_mu = vset(2 * mu), lt = vmul(vset(lambda), vadd(E[0], vadd(E[4], E[8])));
  for (int k = 0; k < 9; k++)
    S[k] = k % 4 == 0 ? vmla(two_mu, E[k], lt) : vmul(two_mu, E[k]);
}

static inline void stvk_green(const vreal F[9], vreal E[9]) {
  vreal C[9], half = vset((real)0.5), one = vset(1);
  vm3_mul_tn(F, F, C);
  for (int k = 0; k < 9; k++)
    E[k] = k % 4 == 0 ? vmul(half, vsub(C[k], one)) : vmul(half, C[k]);
}

static inline vreal stvk_psi_l(real mu, real lambda, const vreal F[9]) {
  vreal E[9];
  stvk_green(F, E);
  vreal tr = vadd(E[0], vadd(E[4], E[8]));
  return vmla(vset(mu), vm3_ddot(E, E), vmul(vset((real)0.5 * lambda), vmul(tr, tr)));
}

static inline void stvk_pk1_l(real mu, real lambda, const vreal F[9], vreal P[9]) {
  vreal E[9], S[9];
  stvk_green(F, E);
  stvk_second_pk(mu, lambda, E, S);
  vm3_mul(F, S, P);
}

static inline void stvk_diff_l(real mu, real lambda, const vreal F[9], const vreal dF[9],
                               vreal dP[9]) {
  vreal E[9], S[9], T[9], dE[9], dS[9], a[9], half = vset((real)0.5);
  stvk_green(F, E);
  stvk_second_pk(mu, lambda, E, S);
  vm3_mul_tn(F, dF, T);
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      dE[3 * i + j] = vmul(half, vadd(T[3 * i + j], T[3 * j + i]));
  stvk_second_pk(mu, lambda, dE, dS);
  vm3_mul(dF, S, a);
  vm3_mul(F, dS, T);
  for (int k = 0; k < 9; k++)
    dP[k] = vadd(a[k], T[k]);
}

// Singular-value form: E_i = (s_i^2 - 1)/2, g_i = s_i (2 mu E_i + lambda
// tr E), A_ii = 2 mu E_i + lambda tr E + s_i^2 (2 mu + lambda),
// A_ij = lambda s_i s_j, flip = mu (s_i^2 + s_i s_j + s_j^2 - 1) + lambda
// tr E, twist = mu (s_i^2 - s_i s_j + s_j^2 - 1) + lambda tr E.
static inline void stvk_sigma_l(real mu_, real lambda_, const vreal s[3], mat_sigma_terms *t) {
  vreal mu = vset(mu_), lambda = vset(lambda_), half = vset((real)0.5), one = vset(1);
  vreal E[3], ss[3];
  for (int i = 0; i < 3; i++) {
    ss[i] = vmul(s[i], s[i]);
    E[i] = vmul(half, vsub(ss[i], one));
  }
  vreal trE = vadd(E[0], vadd(E[1], E[2])), ltr = vmul(lambda, trE);
  vreal two_mu = vadd(mu, mu);
  t->psi = vmla(mu, vmla(E[0], E[0], vmla(E[1], E[1], vmul(E[2], E[2]))),
                vmul(vmul(half, lambda), vmul(trE, trE)));
  for (int i = 0; i < 3; i++) {
    t->g[i] = vmul(s[i], vmla(two_mu, E[i], ltr));
    t->A[i][i] = vmla(two_mu, E[i], vmla(ss[i], vadd(two_mu, lambda), ltr));
  }
  for (int p = 0; p < 3; p++) {
    const int i = mat_pair_i[p], j = mat_pair_j[p];
    t->A[i][j] = t->A[j][i] = vmul(lambda, vmul(s[i], s[j]));
    vreal sq = vsub(vadd(ss[i], ss[j]), one), x = vmul(s[i], s[j]);
    t->flip[p] = vmla(mu, vadd(sq, x), ltr);
    t->twist[p] = vmla(mu, vsub(sq, x), ltr);
  }
}

static inline vreal stvk_psi(const ek_material_lanes *m, const vreal F[9]) {
  return stvk_psi_l(m->mu, m->lambda, F);
}
static inline void stvk_pk1(const ek_material_lanes *m, const vreal F[9], vreal P[9]) {
  stvk_pk1_l(m->mu, m->lambda, F, P);
}
static inline void stvk_diff(const ek_material_lanes *m, const vreal F[9], const vreal dF[9],
                             vreal dP[9]) {
  stvk_diff_l(m->mu, m->lambda, F, dF, dP);
}
static inline void stvk_sigma(const ek_material_lanes *m, const vreal s[3], mat_sigma_terms *t) {
  stvk_sigma_l(m->mu, m->lambda, s, t);
}
#endif
