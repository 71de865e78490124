// Linear elasticity (seed 000; Sifakis & Barbic 2012 course notes, ch. 3):
//   psi = mu e:e + lambda/2 tr(e)^2, e = (F + F^T)/2 - I
//   P   = 2 mu e + lambda tr(e) I
//   dP  = mu (dF + dF^T) + lambda tr(dF) I
#include "model_ref.h"

static void strain(const double F[9], double e[9]) {
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      e[3 * i + j] = 0.5 * (F[3 * i + j] + F[3 * j + i]) - (i == j);
}

double linear_psi_ref(const ek_lame_ref *p, const double F[9], const double R[9]) {
  (void)R;
  double e[9];
  strain(F, e);
  double tr = m3_trace(e);
  return p->mu * m3_ddot(e, e) + 0.5 * p->lambda * tr * tr;
}

void linear_P_ref(const ek_lame_ref *p, const double F[9], const double R[9], double P[9]) {
  (void)R;
  double e[9];
  strain(F, e);
  double tr = m3_trace(e);
  for (int k = 0; k < 9; k++)
    P[k] = 2 * p->mu * e[k] + (k % 4 == 0 ? p->lambda * tr : 0);
}

void linear_dP_ref(const ek_lame_ref *p, const double F[9], const double R[9], const double dF[9],
                   double dP[9]) {
  (void)F, (void)R;
  double tr = m3_trace(dF);
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      dP[3 * i + j] = p->mu * (dF[3 * i + j] + dF[3 * j + i]) + (i == j ? p->lambda * tr : 0);
}
