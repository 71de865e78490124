// Corotated linear elasticity (seed 000, "Corotated Linear Elasticity"):
//   psi(F) = psi_linear(R^T F) with R a given rotation (R^n of the previous
//   step), so P = R P_linear(R^T F) and dP = R dP_linear(R^T dF).
#include "model_ref.h"

double corot_linear_psi_ref(const ek_lame_ref *p, const double F[9], const double R[9]) {
  double G[9];
  m3_mul_tn(R, F, G);
  return linear_psi_ref(p, G, NULL);
}

void corot_linear_P_ref(const ek_lame_ref *p, const double F[9], const double R[9], double P[9]) {
  double G[9], PG[9];
  m3_mul_tn(R, F, G);
  linear_P_ref(p, G, NULL, PG);
  m3_mul(R, PG, P);
}

void corot_linear_dP_ref(const ek_lame_ref *p, const double F[9], const double R[9],
                         const double dF[9], double dP[9]) {
  double G[9], dG[9], dPG[9];
  m3_mul_tn(R, F, G);
  m3_mul_tn(R, dF, dG);
  linear_dP_ref(p, G, NULL, dG, dPG);
  m3_mul(R, dPG, dP);
}
