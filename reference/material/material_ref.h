// Scalar double-precision reference of the material models of
// include/ek/material.h (issue 3): plain AoS, formulas written out in F
// (not in singular values), so it can catch the kernels' algorithmic
// errors. Depends on libc, libm and LAPACK (dsyev for the projection, the
// SVD reference for the polar decomposition and the clamp) only.
#ifndef EK_MATERIAL_REF_H
#define EK_MATERIAL_REF_H

#ifdef __cplusplus
extern "C" {
#endif

// model: an ek_model value (same numbering as include/ek/material.h).
typedef struct {
  int model;
  double mu, lambda, clamp;
} ek_material_ref;

// psi(F); +inf outside the domain (neo-Hookean, J <= 0, no clamp).
// The reference's own model table (material_ref.c, independent of the
// kernels' descriptors): how many models it has, and whether model m is
// evaluated through clamped singular values (-1 if m is not one).
int ek_material_ref_model_count(void);
int ek_material_ref_clampable(int m);
double ek_psi_ref(const ek_material_ref *m, const double F[9], const double R[9]);
// P(F) = dpsi/dF; NaN outside the domain.
void ek_pk1_ref(const ek_material_ref *m, const double F[9], const double R[9], double P[9]);
// dP = H : dF with H the 9x9 Hessian (projected to PSD when project != 0).
void ek_pk1_diff_ref(const ek_material_ref *m, const double F[9], const double R[9],
                     const double dF[9], double dP[9], int project);
// H[a*9 + b] = d P_a / d F_b, a = 3 i + j; projected when project != 0:
// LAPACK dsyev, negative eigenvalues set to zero (project 1) or to their
// absolute value (project 2: Chen et al. 2024), reassembled.
void ek_hessian_ref(const ek_material_ref *m, const double F[9], const double R[9], double H[81],
                    int project);

#ifdef __cplusplus
}
#endif
#endif
