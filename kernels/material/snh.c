// Stable neo-Hookean on registers (Smith, de Goes, Kim 2018, "Stable
// Neo-Hookean Flesh Simulation", sec. 3.4, with its log term):
//   psi = mu/2 (I_C - 3) + lambda/2 (J - a)^2 - mu/2 log(I_C + 1),
//   a = 1 + 3 mu / (4 lambda). With r = mu (1 - 1/(I_C + 1)):
// In F (no SVD): P = r F + lambda (J - a) cof F,
//   dP = r dF + 2 mu (F:dF)/(I_C + 1)^2 F + lambda (cof F:dF) cof F
//        + lambda (J - a) dcof(F; dF).
// In singular values: g_i = r s_i + lambda (J - a) s_j s_k,
//   A_ii = r + 2 mu s_i^2/(I_C + 1)^2 + lambda (s_j s_k)^2,
//   A_ij = 2 mu s_i s_j/(I_C + 1)^2 + lambda s_k (2 J - a),
//   flip = r - lambda (J - a) s_k, twist = r + lambda (J - a) s_k.
// At F = I its dP is linear elasticity with (3 mu / 4, lambda - 5 mu / 8)
// (ek takes mu and lambda as given; Smith et al. 2018 sec. 3.4 instead
// re-parametrise so that the two match). Finite for every F.
#define MODEL snh
#define MODEL_ID EK_MODEL_STABLE_NEO_HOOKEAN
#define MODEL_NAME "snh"
#define MODEL_LONG_NAME "stable_neo_hookean"
#define MODEL_NEEDS EK_NEEDS_J
#define MODEL_CLAMPABLE 1
#define MODEL_ISOTROPIC 1
#define MODEL_F_FORM 1
#define MODEL_READS_R 0
#define MODEL_WARM_POLAR 0
#define MODEL_J_DOMAIN 0
#define MODEL_VOLUME_TERM 1
#include "model.h"

#ifndef EK_MODEL_DESCRIPTOR

static inline real snh_rest_shift(const ek_material_lanes *m) {
  return 1 + (real)0.75 * m->mu / m->lambda;
}

static inline vreal model_psi(const ek_material_lanes *m, const vreal F[9], const vreal R[9]) {
  (void)R;
  vreal C[9], half = vset((real)0.5);
  vm3_cof(F, C);
  vreal Jma = vsub(vm3_det_cof(F, C), vset(snh_rest_shift(m)));
  vreal Ic = vm3_ddot(F, F);
  vreal hmu = vmul(half, vset(m->mu));
  return vmla(hmu, vsub(vsub(Ic, vset(3)), vlog(vadd(Ic, vset(1)))),
              vmul(vmul(half, vset(m->lambda)), vmul(Jma, Jma)));
}

static inline void model_pk1(const ek_material_lanes *m, const vreal F[9], const vreal R[9],
                             vreal P[9]) {
  (void)R;
  vreal C[9], one = vset(1);
  vm3_cof(F, C);
  vreal Jma = vsub(vm3_det_cof(F, C), vset(snh_rest_shift(m)));
  vreal Ic = vm3_ddot(F, F);
  vreal r = vmul(vset(m->mu), vsub(one, vdiv(one, vadd(Ic, one))));
  vreal c = vmul(vset(m->lambda), Jma);
  for (int k = 0; k < 9; k++)
    P[k] = vmla(r, F[k], vmul(c, C[k]));
}

static inline void model_diff(const ek_material_lanes *m, const vreal F[9], const vreal R[9],
                              const vreal dF[9], vreal dP[9]) {
  (void)R;
  vreal C[9], dC[9], one = vset(1), lambda = vset(m->lambda);
  vm3_cof(F, C);
  vm3_cof_diff(F, dF, dC);
  vreal Jma = vsub(vm3_det_cof(F, C), vset(snh_rest_shift(m)));
  vreal Ic1 = vadd(vm3_ddot(F, F), one), inv = vdiv(one, Ic1);
  vreal r = vmul(vset(m->mu), vsub(one, inv));
  vreal s = vmul(vmul(vset(2 * m->mu), vm3_ddot(F, dF)), vmul(inv, inv));
  vreal dJ = vmul(lambda, vm3_ddot(C, dF)), c = vmul(lambda, Jma);
  for (int k = 0; k < 9; k++)
    dP[k] = vmla(r, dF[k], vmla(s, F[k], vmla(dJ, C[k], vmul(c, dC[k]))));
}

// The gradient g alone (what P needs).
static inline void model_sigma_grad(const ek_material_lanes *m, const vreal s[3], vreal g[3]) {
  vreal one = vset(1);
  vreal pair[3] = {vmul(s[1], s[2]), vmul(s[0], s[2]), vmul(s[0], s[1])}; // J / s_i
  vreal lJma = vmul(vset(m->lambda), vsub(vmul(pair[0], s[0]), vset(snh_rest_shift(m))));
  vreal Ic1 = vadd(vmla(s[0], s[0], vmla(s[1], s[1], vmul(s[2], s[2]))), one);
  vreal r = vmul(vset(m->mu), vsub(one, vdiv(one, Ic1)));
  for (int i = 0; i < 3; i++)
    g[i] = vmla(r, s[i], vmul(lJma, pair[i]));
}

static inline void model_sigma(const ek_material_lanes *m, const vreal s[3], mat_sigma_terms *t) {
  vreal mu = vset(m->mu), lambda = vset(m->lambda), half = vset((real)0.5), one = vset(1);
  vreal a = vset(snh_rest_shift(m));
  vreal pair[3] = {vmul(s[1], s[2]), vmul(s[0], s[2]), vmul(s[0], s[1])}; // J / s_i
  vreal J = vmul(pair[0], s[0]), Jma = vsub(J, a), lJma = vmul(lambda, Jma);
  vreal Ic = vmla(s[0], s[0], vmla(s[1], s[1], vmul(s[2], s[2]))), Ic1 = vadd(Ic, one);
  vreal inv = vdiv(one, Ic1), r = vmul(mu, vsub(one, inv));
  vreal w = vmul(vadd(mu, mu), vmul(inv, inv)); // 2 mu / (I_C + 1)^2
  t->psi = vmla(vmul(half, mu), vsub(vsub(Ic, vset(3)), vlog(Ic1)),
                vmul(vmul(half, lambda), vmul(Jma, Jma)));
  for (int i = 0; i < 3; i++) {
    t->g[i] = vmla(r, s[i], vmul(lJma, pair[i]));
    t->A[i][i] = vadd(vmla(w, vmul(s[i], s[i]), r), vmul(lambda, vmul(pair[i], pair[i])));
  }
  vreal two_J_a = vsub(vadd(J, J), a);
  for (int p = 0; p < 3; p++) {
    const int i = mat_pair_i[p], j = mat_pair_j[p], k = mat_pair_k[p];
    t->A[i][j] = t->A[j][i] = vmla(w, vmul(s[i], s[j]), vmul(lambda, vmul(s[k], two_J_a)));
    vreal c = vmul(lJma, s[k]);
    t->flip[p] = vsub(r, c);
    t->twist[p] = vadd(r, c);
  }
}

#include "model_kernels.h"
#else

// a = 1 + 3 mu / (4 lambda) needs lambda != 0.
static const char *snh_param_error(double mu, double lambda) {
  (void)mu;
  return lambda == 0 ? "stable neo-Hookean needs lambda != 0 (a = 1 + 3 mu / (4 lambda))" : NULL;
}

static void snh_linearise(double mu, double lambda, double *mu_lin, double *lambda_lin) {
  *mu_lin = 0.75 * mu, *lambda_lin = lambda - 0.625 * mu;
}

// The inverse of (3 mu / 4, lambda - 5 mu / 8).
static int snh_from_linear(double mu_lin, double lambda_lin, double *mu, double *lambda, char *why,
                           size_t len) {
  *mu = mu_lin / 0.75;
  *lambda = lambda_lin + 0.625 * *mu;
  if (*lambda == 0) {
    snprintf(why, len, "stable neo-Hookean needs lambda != 0 (material.h)");
    return EK_EINVAL;
  }
  return EK_OK;
}

const ek_model_desc ek_model_snh = {EK_MODEL_DESC_TRAITS, .param_error = snh_param_error,
                                    .linearise = snh_linearise, .from_linear = snh_from_linear};
#endif
