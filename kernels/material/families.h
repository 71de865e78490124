// Formula bodies that two models share, in (mu, lambda): linear
// elasticity (corotated linear is it in R^T F), StVK (Psi_R is StVK with
// lambda = 0) and fixed corotated in singular values (ARAP is it with
// lambda = 0). Each model's own file (kernels/material/<name>.c) holds its
// entries and cites its formulas; these are the bodies they call. Include
// after material_math.h.
#ifndef EK_MATERIAL_FAMILIES_H
#define EK_MATERIAL_FAMILIES_H
#include "material_math.h"

// ---- Linear elasticity (seed 000; Sifakis & Barbic 2012 course notes,
// ch. 3): psi = mu e:e + lambda/2 tr(e)^2, e = sym(F) - I,
// P = 2 mu e + lambda tr(e) I, dP = mu (dF + dF^T) + lambda tr(dF) I.
static inline void linear_strain(const vreal F[9], vreal e[9]) {
  vreal half = vset((real)0.5), one = vset(1);
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      e[3 * i + j] = i == j ? vsub(F[4 * i], one) : vmul(half, vadd(F[3 * i + j], F[3 * j + i]));
}

static inline vreal linear_psi_l(real mu, real lambda, const vreal F[9]) {
  vreal e[9];
  linear_strain(F, e);
  vreal tr = vadd(e[0], vadd(e[4], e[8]));
  return vmla(vset(mu), vm3_ddot(e, e), vmul(vset((real)0.5 * lambda), vmul(tr, tr)));
}

static inline void linear_pk1_l(real mu, real lambda, const vreal F[9], vreal P[9]) {
  vreal e[9];
  linear_strain(F, e);
  vreal tr = vadd(e[0], vadd(e[4], e[8]));
  vreal two_mu = vset(2 * mu), lt = vmul(vset(lambda), tr);
  for (int k = 0; k < 9; k++)
    P[k] = k % 4 == 0 ? vmla(two_mu, e[k], lt) : vmul(two_mu, e[k]);
}

static inline void linear_diff_l(real mu_, real lambda, const vreal dF[9], vreal dP[9]) {
  vreal mu = vset(mu_), lt = vmul(vset(lambda), vadd(dF[0], vadd(dF[4], dF[8])));
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++) {
      vreal s = vmul(mu, vadd(dF[3 * i + j], dF[3 * j + i]));
      dP[3 * i + j] = i == j ? vadd(s, lt) : s;
    }
}

// ---- St. Venant-Kirchhoff (Sifakis & Barbic 2012 course notes, ch. 3):
// psi = mu E:E + lambda/2 tr(E)^2, E = (F^T F - I)/2, P = F S,
// S = 2 mu E + lambda tr(E) I; dP = dF S + F dS.
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

// ---- Fixed corotated in singular values (Stomakhin et al. 2012):
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

#endif
