// Psi_R (seed 000, eq. "simplified models"): the StVK mu-term alone,
//   psi = mu/4 |C - I|^2, C = F^T F
//   P   = mu F (C - I)
//   dP  = mu (dF (C - I) + F dC), dC = dF^T F + F^T dF
#include "model_ref.h"

static void c_minus_i(const double F[9], double G[9]) {
  m3_mul_tn(F, F, G);
  for (int k = 0; k < 9; k += 4)
    G[k] -= 1;
}

double psi_r_psi_ref(const ek_lame_ref *p, const double F[9], const double R[9]) {
  (void)R;
  double G[9];
  c_minus_i(F, G);
  return 0.25 * p->mu * m3_ddot(G, G);
}

void psi_r_P_ref(const ek_lame_ref *p, const double F[9], const double R[9], double P[9]) {
  (void)R;
  double G[9];
  c_minus_i(F, G);
  m3_mul(F, G, P);
  for (int k = 0; k < 9; k++)
    P[k] *= p->mu;
}

void psi_r_dP_ref(const ek_lame_ref *p, const double F[9], const double R[9], const double dF[9],
                  double dP[9]) {
  (void)R;
  double G[9], FtdF[9], dC[9], a[9], b[9];
  c_minus_i(F, G);
  m3_mul_tn(F, dF, FtdF);
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      dC[3 * i + j] = FtdF[3 * i + j] + FtdF[3 * j + i];
  m3_mul(dF, G, a);
  m3_mul(F, dC, b);
  for (int k = 0; k < 9; k++)
    dP[k] = p->mu * (a[k] + b[k]);
}
