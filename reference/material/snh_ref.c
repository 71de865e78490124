// Stable neo-Hookean (Smith, de Goes, Kim 2018, "Stable Neo-Hookean Flesh
// Simulation", sec. 3.4, with its log term):
//   psi = mu/2 (I_C - 3) + lambda/2 (J - a)^2 - mu/2 log(I_C + 1),
//   a = 1 + 3 mu / (4 lambda)
//   P   = mu (1 - 1/(I_C + 1)) F + lambda (J - a) cof F
//   dP  = mu (1 - 1/(I_C + 1)) dF + 2 mu (F:dF)/(I_C + 1)^2 F
//         + lambda (cof F : dF) cof F + lambda (J - a) dcof(F; dF)
#include "model_ref.h"

static double rest_shift(const ek_lame_ref *p) { return 1 + 0.75 * p->mu / p->lambda; }

double snh_psi_ref(const ek_lame_ref *p, const double F[9], const double R[9]) {
  (void)R;
  double Ic = m3_ddot(F, F), Jma = m3_det(F) - rest_shift(p);
  return 0.5 * p->mu * (Ic - 3) + 0.5 * p->lambda * Jma * Jma - 0.5 * p->mu * log(Ic + 1);
}

void snh_P_ref(const ek_lame_ref *p, const double F[9], const double R[9], double P[9]) {
  (void)R;
  double C[9], Ic = m3_ddot(F, F), Jma = m3_det(F) - rest_shift(p);
  m3_cof(F, C);
  double r = p->mu * (1 - 1 / (Ic + 1));
  for (int k = 0; k < 9; k++)
    P[k] = r * F[k] + p->lambda * Jma * C[k];
}

void snh_dP_ref(const ek_lame_ref *p, const double F[9], const double R[9], const double dF[9],
                double dP[9]) {
  (void)R;
  double C[9], dC[9], Ic = m3_ddot(F, F), Jma = m3_det(F) - rest_shift(p);
  m3_cof(F, C);
  m3_cof_diff(F, dF, dC);
  double r = p->mu * (1 - 1 / (Ic + 1));
  double s = 2 * p->mu * m3_ddot(F, dF) / ((Ic + 1) * (Ic + 1));
  double dJ = m3_ddot(C, dF);
  for (int k = 0; k < 9; k++)
    dP[k] = r * dF[k] + s * F[k] + p->lambda * (dJ * C[k] + Jma * dC[k]);
}
