// Scalar double reference of the cloth forces (include/ek/cloth_force.h),
// written in a different form from the kernels so it can catch their
// algorithmic errors: no 2D rest frame; the membrane energy from the rest
// and deformed metrics Gbar = E^T E and g = Ds^T Ds (E, Ds the 3x2 rest and
// deformed edge matrices), ARAP's singular values by LAPACK dgesvd of the
// 3x3 F3 = Ds Gbar^-1 E^T; the bending cotangents by atan2.
#ifndef EK_CLOTH_FORCE_REF_H
#define EK_CLOTH_FORCE_REF_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

// model: 0 StVK, 1 ARAP (as ek_membrane_model); mu, lambda per unit area,
// bending k_b.
typedef struct {
  int model;
  double mu, lambda, bending;
} cloth_ref_params;

// Area of a rest triangle.
double cloth_ref_area(const double *X0, const double *X1, const double *X2);
// Bergou et al. 2006 hinge coefficients k (Q = k k^T) of the hinge
// (x0, x1 edge; x2, x3 opposite) at rest X.
void cloth_ref_hinge_k(const double *X, const int32_t hinge[4], double k[4]);
// Membrane energy density and its gradient with respect to the deformed
// edges Ds = [x1-x0, x2-x0] (3x2 row-major), of a triangle with rest
// edges E; dPsi_dDs may be NULL.
double cloth_ref_membrane(const cloth_ref_params *p, const double E[6], const double Ds[6],
                          double dPsi_dDs[6]);
// Total energy and forces f = -dE/dx (f may be NULL) of a mesh with
// nhinges hinges (nhinges x 4, as ek_cloth_hinges) at rest X, positions x.
double cloth_ref_forces(const cloth_ref_params *p, size_t nverts, const double *X, size_t ntris,
                        const int32_t *tris, size_t nhinges, const int32_t *hinges, const double *x,
                        double *f);

#ifdef __cplusplus
}
#endif
#endif
