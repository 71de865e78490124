// St. Venant-Kirchhoff (Sifakis & Barbic 2012 course notes, ch. 3):
//   psi = mu E:E + lambda/2 tr(E)^2, E = (F^T F - I)/2
//   P   = F S, S = 2 mu E + lambda tr(E) I (second Piola-Kirchhoff stress)
//   dP  = dF S + F dS, dE = (dF^T F + F^T dF)/2, dS = 2 mu dE + lambda tr(dE) I
#include "model_ref.h"

static void green_strain(const double F[9], double E[9]) {
  m3_mul_tn(F, F, E);
  for (int k = 0; k < 9; k++)
    E[k] = 0.5 * (E[k] - (k % 4 == 0));
}

static void second_pk(const ek_lame_ref *p, const double E[9], double S[9]) {
  double tr = m3_trace(E);
  for (int k = 0; k < 9; k++)
    S[k] = 2 * p->mu * E[k] + (k % 4 == 0 ? p->lambda * tr : 0);
}

double stvk_psi_ref(const ek_lame_ref *p, const double F[9], const double R[9]) {
  (void)R;
  double E[9];
  green_strain(F, E);
  double tr = m3_trace(E);
  return p->mu * m3_ddot(E, E) + 0.5 * p->lambda * tr * tr;
}

void stvk_P_ref(const ek_lame_ref *p, const double F[9], const double R[9], double P[9]) {
  (void)R;
  double E[9], S[9];
  green_strain(F, E);
  second_pk(p, E, S);
  m3_mul(F, S, P);
}

void stvk_dP_ref(const ek_lame_ref *p, const double F[9], const double R[9], const double dF[9],
                 double dP[9]) {
  (void)R;
  double E[9], S[9], FtdF[9], dE[9], dS[9], a[9], b[9];
  green_strain(F, E);
  second_pk(p, E, S);
  m3_mul_tn(F, dF, FtdF);
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      dE[3 * i + j] = 0.5 * (FtdF[3 * i + j] + FtdF[3 * j + i]);
  second_pk(p, dE, dS);
  m3_mul(dF, S, a);
  m3_mul(F, dS, b);
  for (int k = 0; k < 9; k++)
    dP[k] = a[k] + b[k];
}
