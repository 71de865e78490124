// Psi_R on registers (seed 000, "simplified models"): psi = mu/4 |C - I|^2
// = mu E:E, i.e. StVK with lambda = 0; P = mu F (C - I).
#ifndef EK_MAT_PSI_R_H
#define EK_MAT_PSI_R_H
#include "stvk.h"

static inline vreal psi_r_psi(const ek_material_lanes *m, const vreal F[9]) {
  return stvk_psi_l(m->mu, 0, F);
}
static inline void psi_r_pk1(const ek_material_lanes *m, const vreal F[9], vreal P[9]) {
  stvk_pk1_l(m->mu, 0, F, P);
}
static inline void psi_r_diff(const ek_material_lanes *m, const vreal F[9], const vreal dF[9],
                              vreal dP[9]) {
  stvk_diff_l(m->mu, 0, F, dF, dP);
}
static inline void psi_r_sigma(const ek_material_lanes *m, const vreal s[3], mat_sigma_terms *t) {
  stvk_sigma_l(m->mu, 0, s, t);
}
#endif
