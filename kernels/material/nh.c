// Neo-Hookean on registers (seed 000; issue 3's table; Bonet & Wood 2008,
// ch. 6): psi = mu/2 (I_C - 3) - mu log J + lambda/2 (log J)^2,
// defined for J > 0; outside, psi = +inf and P = dP = NaN (issue 3).
// In F (no SVD):  P = mu (F - F^-T) + lambda log J F^-T,
//   dP = mu dF + (mu - lambda log J) F^-T dF^T F^-T + lambda (F^-T:dF) F^-T.
// In singular values (clamp, projection), L = log J:
//   g_i = mu s_i + (lambda L - mu) / s_i
//   A_ii = mu + (mu + lambda - lambda L) / s_i^2, A_ij = lambda / (s_i s_j)
//   flip = mu + (mu - lambda L) / (s_i s_j), twist = mu + (lambda L - mu) /
//   (s_i s_j)  (derived from g as in Smith et al. 2019).
#define MODEL nh
#define MODEL_ID EK_MODEL_NEO_HOOKEAN
#define MODEL_NAME "nh"
#define MODEL_LONG_NAME "neo_hookean"
#define MODEL_NEEDS EK_NEEDS_J
#define MODEL_CLAMPABLE 1
#define MODEL_ISOTROPIC 1
#define MODEL_F_FORM 1
#define MODEL_READS_R 0
#define MODEL_WARM_POLAR 0
#define MODEL_J_DOMAIN 1
#define MODEL_VOLUME_TERM 1
#include "model.h"

#ifndef EK_MODEL_DESCRIPTOR

static inline vreal model_psi(const ek_material_lanes *m, const vreal F[9], const vreal R[9]) {
  (void)R;
  vreal C[9];
  vm3_cof(F, C);
  vreal J = vm3_det_cof(F, C), L = vlog(J);
  vreal half = vset((real)0.5);
  vreal psi = vmla(vmul(half, vset(m->mu)), vsub(vm3_ddot(F, F), vset(3)),
                   vmul(L, vsub(vmul(vmul(half, vset(m->lambda)), L), vset(m->mu))));
  return vsel(vgt(J, vzero()), psi, vset((real)INFINITY));
}

// F^-T = cof(F) / J, and L = log J; returns the domain mask J > 0.
static inline vmask nh_inverse(const vreal F[9], vreal G[9], vreal *L) {
  vreal C[9];
  vm3_cof(F, C);
  vreal J = vm3_det_cof(F, C), Jinv = vdiv(vset(1), J);
  for (int k = 0; k < 9; k++)
    G[k] = vmul(C[k], Jinv);
  *L = vlog(J);
  return vgt(J, vzero());
}

static inline void model_pk1(const ek_material_lanes *m, const vreal F[9], const vreal R[9],
                             vreal P[9]) {
  (void)R;
  vreal G[9], L;
  vmask ok = nh_inverse(F, G, &L);
  vreal mu = vset(m->mu), c = vsub(vmul(vset(m->lambda), L), mu), nan = vset((real)NAN);
  for (int k = 0; k < 9; k++)
    P[k] = vsel(ok, vmla(mu, F[k], vmul(c, G[k])), nan);
}

static inline void model_diff(const ek_material_lanes *m, const vreal F[9], const vreal R[9],
                              const vreal dF[9], vreal dP[9]) {
  (void)R;
  vreal G[9], L, T[9], GdFtG[9];
  vmask ok = nh_inverse(F, G, &L);
  vm3_mul_nt(G, dF, T);
  vm3_mul(T, G, GdFtG);
  vreal mu = vset(m->mu), lambda = vset(m->lambda), nan = vset((real)NAN);
  vreal c = vsub(mu, vmul(lambda, L)), tr = vmul(lambda, vm3_ddot(G, dF));
  for (int k = 0; k < 9; k++)
    dP[k] = vsel(ok, vmla(mu, dF[k], vmla(c, GdFtG[k], vmul(tr, G[k]))), nan);
}

// The gradient g alone (what P needs under the clamp, where J > 0).
static inline void model_sigma_grad(const ek_material_lanes *m, const vreal s[3], vreal g[3]) {
  vreal mu = vset(m->mu);
  vreal c = vsub(vmul(vset(m->lambda), vlog(vmul(s[0], vmul(s[1], s[2])))), mu);
  for (int i = 0; i < 3; i++)
    g[i] = vmla(mu, s[i], vdiv(c, s[i]));
}

static inline void model_sigma(const ek_material_lanes *m, const vreal s[3], mat_sigma_terms *t) {
  vreal mu = vset(m->mu), lambda = vset(m->lambda), half = vset((real)0.5), one = vset(1);
  vreal J = vmul(s[0], vmul(s[1], s[2])), L = vlog(J), lL = vmul(lambda, L);
  vreal c = vsub(lL, mu); // lambda L - mu
  vreal Ic = vmla(s[0], s[0], vmla(s[1], s[1], vmul(s[2], s[2])));
  t->psi = vmla(vmul(half, mu), vsub(Ic, vset(3)), vmul(L, vsub(vmul(half, lL), mu)));
  vreal inv[3];
  for (int i = 0; i < 3; i++) {
    inv[i] = vdiv(one, s[i]);
    t->g[i] = vmla(mu, s[i], vmul(c, inv[i]));
    t->A[i][i] = vmla(vsub(lambda, c), vmul(inv[i], inv[i]), mu);
  }
  for (int p = 0; p < 3; p++) {
    const int i = mat_pair_i[p], j = mat_pair_j[p];
    vreal x = vmul(inv[i], inv[j]);
    t->A[i][j] = t->A[j][i] = vmul(lambda, x);
    t->flip[p] = vsub(mu, vmul(c, x));
    t->twist[p] = vmla(c, x, mu);
  }
  // Outside the domain (J <= 0, only without clamp): NaN everywhere.
  vmask ok = vgt(J, vzero());
  vreal nan = vset((real)NAN);
  t->psi = vsel(ok, t->psi, vset((real)INFINITY));
  for (int i = 0; i < 3; i++) {
    t->g[i] = vsel(ok, t->g[i], nan);
    t->flip[i] = vsel(ok, t->flip[i], nan);
    t->twist[i] = vsel(ok, t->twist[i], nan);
    for (int j = 0; j < 3; j++)
      t->A[i][j] = vsel(ok, t->A[i][j], nan);
  }
}

#include "model_kernels.h"
#else

// Defined for J > 0 only without clamp (psi = +inf at J <= 0).
static const char *nh_excluded(const ek_model_run_stats *r, double clamp, double eps, char *why,
                               size_t len) {
  (void)eps;
  if (clamp <= 0 && r->min_J <= 0) {
    snprintf(why, len, "inverted (min J = %.3g): undefined at J <= 0 without clamp", r->min_J);
    return why;
  }
  return NULL;
}

const ek_model_desc ek_model_nh = {EK_MODEL_DESC_TRAITS, .linearise = ek_model_lame_same,
                                   .from_linear = ek_model_lame_same_inverse,
                                   .excluded = nh_excluded};
#endif
