// Corotated linear elasticity on registers (seed 000): psi(F) =
// psi_linear(R^T F) with the given rotation R, P = R P_linear(R^T F),
// dP = R dP_linear(R^T dF). The Hessian is the linear one rotated, PSD for
// valid parameters: project is a no-op.
#ifndef EK_MAT_COROT_LINEAR_H
#define EK_MAT_COROT_LINEAR_H
#include "linear.h"

static inline vreal corot_linear_psi(const ek_material_lanes *m, const vreal F[9],
                                     const vreal R[9]) {
  vreal G[9];
  vm3_mul_tn(R, F, G);
  return linear_psi(m, G);
}

static inline void corot_linear_pk1(const ek_material_lanes *m, const vreal F[9], const vreal R[9],
                                    vreal P[9]) {
  vreal G[9], PG[9];
  vm3_mul_tn(R, F, G);
  linear_pk1(m, G, PG);
  vm3_mul(R, PG, P);
}

static inline void corot_linear_diff(const ek_material_lanes *m, const vreal R[9],
                                     const vreal dF[9], vreal dP[9]) {
  vreal dG[9], dPG[9];
  vm3_mul_tn(R, dF, dG);
  linear_diff(m, dG, dPG);
  vm3_mul(R, dPG, dP);
}
#endif
