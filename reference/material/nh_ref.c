// Neo-Hookean (seed 000; issue 3's table; Bonet & Wood 2008, ch. 6):
//   psi = mu/2 (I_C - 3) - mu log J + lambda/2 (log J)^2, J > 0
//   P   = mu (F - F^-T) + lambda log J F^-T
//   dP  = mu dF + (mu - lambda log J) F^-T dF^T F^-T + lambda (F^-T : dF) F^-T
// (d F^-T = -F^-T dF^T F^-T). Outside the domain (J <= 0): psi = +inf,
// P = dP = NaN (issue 3).
#include "model_ref.h"

double nh_psi_ref(const ek_lame_ref *p, const double F[9], const double R[9]) {
  (void)R;
  double J = m3_det(F);
  if (!(J > 0))
    return INFINITY;
  double logJ = log(J);
  return 0.5 * p->mu * (m3_ddot(F, F) - 3) - p->mu * logJ + 0.5 * p->lambda * logJ * logJ;
}

// F^-T = cof(F) / J.
static void inverse_transpose(const double F[9], double J, double Finv_t[9]) {
  m3_cof(F, Finv_t);
  for (int k = 0; k < 9; k++)
    Finv_t[k] /= J;
}

void nh_P_ref(const ek_lame_ref *p, const double F[9], const double R[9], double P[9]) {
  (void)R;
  double J = m3_det(F);
  if (!(J > 0)) {
    for (int k = 0; k < 9; k++)
      P[k] = NAN;
    return;
  }
  double G[9], logJ = log(J);
  inverse_transpose(F, J, G);
  for (int k = 0; k < 9; k++)
    P[k] = p->mu * (F[k] - G[k]) + p->lambda * logJ * G[k];
}

void nh_dP_ref(const ek_lame_ref *p, const double F[9], const double R[9], const double dF[9],
               double dP[9]) {
  (void)R;
  double J = m3_det(F);
  if (!(J > 0)) {
    for (int k = 0; k < 9; k++)
      dP[k] = NAN;
    return;
  }
  double G[9], T[9], GdFtG[9], logJ = log(J);
  inverse_transpose(F, J, G);
  m3_mul_nt(G, dF, T); // G dF^T
  m3_mul(T, G, GdFtG);
  double GdF = m3_ddot(G, dF);
  for (int k = 0; k < 9; k++)
    dP[k] = p->mu * dF[k] + (p->mu - p->lambda * logJ) * GdFtG[k] + p->lambda * GdF * G[k];
}
