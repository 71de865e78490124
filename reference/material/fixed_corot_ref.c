// Fixed corotated (Stomakhin et al. 2012, "Energetically consistent
// invertible elasticity"):
//   psi = mu |F - R(F)|^2 + lambda/2 (J - 1)^2
//   P   = 2 mu (F - R) + lambda (J - 1) cof F            (cof F = J F^-T)
//   dP  = 2 mu (dF - dR) + lambda (cof F : dF) cof F + lambda (J - 1) dcof
// with dR the differential of the polar rotation (material_ref.c).
#include "model_ref.h"

double fixed_corot_psi_ref(const ek_lame_ref *p, const double F[9], const double R[9]) {
  (void)R;
  double Rf[9], D[9];
  ek_polar_rotation_ref(F, Rf);
  for (int k = 0; k < 9; k++)
    D[k] = F[k] - Rf[k];
  double Jm1 = m3_det(F) - 1;
  return p->mu * m3_ddot(D, D) + 0.5 * p->lambda * Jm1 * Jm1;
}

void fixed_corot_P_ref(const ek_lame_ref *p, const double F[9], const double R[9], double P[9]) {
  (void)R;
  double Rf[9], C[9];
  ek_polar_rotation_ref(F, Rf);
  m3_cof(F, C);
  double Jm1 = m3_det(F) - 1;
  for (int k = 0; k < 9; k++)
    P[k] = 2 * p->mu * (F[k] - Rf[k]) + p->lambda * Jm1 * C[k];
}

void fixed_corot_dP_ref(const ek_lame_ref *p, const double F[9], const double R[9],
                        const double dF[9], double dP[9]) {
  (void)R;
  double dR[9], C[9], dC[9];
  ek_polar_rotation_diff_ref(F, dF, dR);
  m3_cof(F, C);
  m3_cof_diff(F, dF, dC);
  double Jm1 = m3_det(F) - 1, dJ = m3_ddot(C, dF);
  for (int k = 0; k < 9; k++)
    dP[k] = 2 * p->mu * (dF[k] - dR[k]) + p->lambda * (dJ * C[k] + Jm1 * dC[k]);
}
