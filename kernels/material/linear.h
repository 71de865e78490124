// Linear elasticity on registers (seed 000; Sifakis & Barbic 2012 course
// notes, ch. 3): psi = mu e:e + lambda/2 tr(e)^2, e = sym(F) - I,
// P = 2 mu e + lambda tr(e) I, dP = mu (dF + dF^T) + lambda tr(dF) I.
// The Hessian is constant with eigenvalues 2 mu (x5), 2 mu + 3 lambda and 0
// (x3, the skew directions), all >= 0 for valid parameters: project is a
// no-op.
#ifndef EK_MAT_LINEAR_H
#define EK_MAT_LINEAR_H
#include "material_math.h"

static inline void linear_strain(const vreal F[9], vreal e[9]) {
  vreal half = vset((real)0.5), one = vset(1);
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      e[3 * i + j] = i == j ? vsub(F[4 * i], one) : vmul(half, vadd(F[3 * i + j], F[3 * j + i]));
}

static inline vreal linear_psi(const ek_material_lanes *m, const vreal F[9]) {
  vreal e[9];
  linear_strain(F, e);
  vreal tr = vadd(e[0], vadd(e[4], e[8]));
  return vmla(vset(m->mu), vm3_ddot(e, e), vmul(vset((real)0.5 * m->lambda), vmul(tr, tr)));
}

static inline void linear_pk1(const ek_material_lanes *m, const vreal F[9], vreal P[9]) {
  vreal e[9];
  linear_strain(F, e);
  vreal tr = vadd(e[0], vadd(e[4], e[8]));
  vreal two_mu = vset(2 * m->mu), lt = vmul(vset(m->lambda), tr);
  for (int k = 0; k < 9; k++)
    P[k] = k % 4 == 0 ? vmla(two_mu, e[k], lt) : vmul(two_mu, e[k]);
}

static inline void linear_diff(const ek_material_lanes *m, const vreal dF[9], vreal dP[9]) {
  vreal mu = vset(m->mu), lt = vmul(vset(m->lambda), vadd(dF[0], vadd(dF[4], dF[8])));
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++) {
      vreal s = vmul(mu, vadd(dF[3 * i + j], dF[3 * j + i]));
      dP[3 * i + j] = i == j ? vadd(s, lt) : s;
    }
}
#endif
