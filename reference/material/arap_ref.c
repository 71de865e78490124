// As-rigid-as-possible (seed 000, eq. "simplified models"; Sorkine & Alexa
// 2007): psi = mu |F - R(F)|^2 = mu sum_i (sigma_i - 1)^2,
//   P = 2 mu (F - R), dP = 2 mu (dF - dR).
#include "model_ref.h"

double arap_psi_ref(const ek_lame_ref *p, const double F[9], const double R[9]) {
  (void)R;
  double Rf[9], D[9];
  ek_polar_rotation_ref(F, Rf);
  for (int k = 0; k < 9; k++)
    D[k] = F[k] - Rf[k];
  return p->mu * m3_ddot(D, D);
}

void arap_P_ref(const ek_lame_ref *p, const double F[9], const double R[9], double P[9]) {
  (void)R;
  double Rf[9];
  ek_polar_rotation_ref(F, Rf);
  for (int k = 0; k < 9; k++)
    P[k] = 2 * p->mu * (F[k] - Rf[k]);
}

void arap_dP_ref(const ek_lame_ref *p, const double F[9], const double R[9], const double dF[9],
                 double dP[9]) {
  (void)R;
  double dR[9];
  ek_polar_rotation_diff_ref(F, dF, dR);
  for (int k = 0; k < 9; k++)
    dP[k] = 2 * p->mu * (dF[k] - dR[k]);
}
