// Scalar double-precision reference of the finite-volume force (Teran et
// al. 2003 sec. 4, seed 004): plain AoS arrays, recomputes Dm^-1 and V0
// from the rest positions itself (so it can catch errors in the mesh
// precompute), no reordering, no colouring. Depends on the material
// reference only.
#ifndef EK_FVM_REF_H
#define EK_FVM_REF_H

#include <stddef.h>
#include <stdint.h>

#include "material/material_ref.h"

#ifdef __cplusplus
extern "C" {
#endif

// X: rest positions, x: current positions (nverts x 3); tets ntets x 4;
// R: ntets x 9 rotations (corotated linear only, else may be NULL).
// f (nverts x 3) is overwritten with f = -dE/dx. fscale (nverts x 3, may be
// NULL) receives, per component, the sum of the absolute values of the
// contributions (the cancellation-free size the error budgets divide by).
void ek_fvm_forces_ref(size_t nverts, const double *X, size_t ntets, const int32_t *tets,
                       const ek_material_ref *m, const double *R, const double *x, double *f,
                       double *fscale);

// E = sum_e V0_e psi(F_e), V0 = |det Dm| / 6.
double ek_fvm_energy_ref(size_t nverts, const double *X, size_t ntets, const int32_t *tets,
                         const ek_material_ref *m, const double *R, const double *x);

// F of one tet: Ds Dm^-1 (Teran et al. 2003 sec. 4); returns V0.
double ek_fvm_tet_F_ref(const double *X, const double *x, const int32_t tet[4], double F[9],
                        double Dm_inv[9]);

// y = K p, K = d(grad E)/dx = -df/dx at x, each element's 9x9 Hessian in F
// projected to PSD when project != 0 (ek_hessian_ref's 1 clamp, 2 abs): per tet dF =
// [p1-p0, p2-p0, p3-p0] Dm^-1, dP = H : dF, V0 dP Dm^-T to corners 1..3 and
// minus their sum to corner 0 (reference/fvm/hessian_ref.c). yscale (may
// be NULL): per component, the sum of the contributions' absolute values.
void ek_fvm_hessian_apply_ref(size_t nverts, const double *X, size_t ntets, const int32_t *tets,
                              const ek_material_ref *m, const double *R, const double *x,
                              const double *p, int project, double *y, double *yscale);

// The assembled Hessian K (dense, 3 nverts rows of 3 nverts, row-major),
// each tet's 12x12 Hessian from the same H : dF, added plainly
// (reference/fvm/hessian_ref.c); Kscale (may be NULL): per entry the sum
// of the contributions' absolute values.
void ek_fvm_hessian_assemble_ref(size_t nverts, const double *X, size_t ntets, const int32_t *tets,
                                 const ek_material_ref *m, const double *R, const double *x,
                                 int project, double *K, double *Kscale);

#ifdef __cplusplus
}
#endif
#endif
