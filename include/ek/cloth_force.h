// Cloth forces: membrane and bending energies of a triangle mesh, their
// forces, and the (projected) Hessian product of the implicit loop.
//
// The element layer of a cloth (ek_cloth_create, from plain arrays): per
// triangle t = (x0, x1, x2) its rest frame, Dm^-1 (2x2, the inverse of the
// rest edges [X1-X0, X2-X0] written in the triangle's own orthonormal 2D
// rest frame) and rest area A; per interior edge (a "hinge": the two
// triangles sharing it) the bending coefficients below; AoSoA blocks of
// EK_LANES_F32 / EK_LANES_F64 triangles and hinges in the caller's order
// (padding lanes index -1); per vertex the list of triangle and hinge
// corners that touch it.
//
// Membrane (per unit rest area; a sim multiplies the 3D parameters by the
// thickness, sim.h): with the 3x2 deformation gradient
// F = [x1-x0, x2-x0] Dm^-1 (seed 003 eq. 2 in 3D) and C = F^T F,
//   StVK:  Psi = mu E:E + lambda/2 tr(E)^2,   E = (C - I)/2 (Green strain),
//          P = dPsi/dF = F S,  S = 2 mu E + lambda tr(E) I;
//   ARAP:  Psi = mu |F - R|^2,   R the 3x2 polar factor of F (F = R Uc,
//          Uc = sqrt(C), seed 003 eqs. 15-20),  P = 2 mu (F - R)
//          (R maximises tr(R^T F), so its variation drops out).
// The triangle's energy is A Psi(F), its forces h = -A P Dm^-T (3x2): h's
// columns act on x1 and x2, -(h1 + h2) on x0 (Teran et al. 2003 sec. 4 on a
// triangle; the forces sum to zero, so momentum is kept).
//
// Bending: the quadratic model of Bergou, Wardetzky, Harmon, Zorin,
// Grinspun 2006 ("A quadratic bending model for inextensible surfaces",
// sec. 4), for a flat rest shape: per hinge with shared edge (x0, x1) and
// opposite vertices x2 (in the first triangle) and x3 (in the second),
//   K = (c03 + c04, c01 + c02, -c01 - c03, -c02 - c04)
// with c0j = cot of the rest angle at x0 between edge e0 = x1 - x0 and
// e1 = x2 - x0 (j = 1) or e2 = x3 - x0 (j = 2), and c0j for j = 3, 4 the
// cot at x1 between -e0 and x2 - x1, x3 - x1; Q = 3 / (A0 + A1) K K^T and
//   E_bend = k_b / 2 sum_ij Q_ij <x_i, x_j> = 3 k_b / (2 (A0 + A1)) |sum_i K_i x_i|^2.
// K sums to zero and sum_i K_i X_i = 0 for a flat hinge (the cotangent
// Laplacian of a planar patch), so a flat cloth has no bending energy and
// no bending force, and the Hessian k_b Q (x) I3 is constant and PSD. The
// stored coefficient per hinge is k_i = sqrt(3 / (A0 + A1)) K_i, so
// Q = k k^T. A rest shape that is not flat is bent, in this model, from
// flat: the model says so, it does not hide it.
//
// Hessian product (implicit loop): q = H p with H the Hessian of the total
// energy. `project`: StVK's Hessian is dF S + F dS (dF = dDs Dm^-1,
// dS = 2 mu dE + lambda tr(dE) I, dE = sym(F^T dF)); its second term is
// PSD for mu > 0 and lambda >= 0, the first is PSD when S is. Projected,
// S's negative eigenvalues (a compressed membrane) are set to 0 in the
// first term: PSD always, exact where the membrane is stretched. ARAP's
// projected Hessian is 2 mu (I - dR) with dR the polar factor's
// differential, projected by dropping its negative twist mode (below).
// The bending Hessian is PSD as it is.
//
// Determinism: each triangle (hinge) writes its corners into a buffer, and
// each vertex sums the corners that touch it in a fixed order (the order of
// the triangles, then of the hinges): any thread count gives the same bits.
// The corner and energy buffers belong to the ek_cloth: one force, energy
// or Hessian call at a time per cloth (calls on different cloths may run
// concurrently).
#ifndef EK_CLOTH_FORCE_H
#define EK_CLOTH_FORCE_H

#include <stddef.h>
#include <stdint.h>

#include "core.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ek_cloth ek_cloth;

typedef enum {
  EK_MEMBRANE_STVK = 0, // Green strain, Saint Venant-Kirchhoff
  EK_MEMBRANE_ARAP,     // |F - R|^2 with R the polar factor of the 3x2 F
  EK_MEMBRANE_COUNT
} ek_membrane_model;

// Parameters per unit rest area: mu, lambda in N/m (the 3D Lame
// parameters times the thickness, in plane stress: see sim.h), k_b in N m
// (0: no bending). mu > 0, lambda >= 0 (lambda is ignored by ARAP), k_b >= 0,
// all finite, else EK_EINVAL.
typedef struct {
  ek_membrane_model model;
  double mu, lambda;
  double bending;
} ek_cloth_params;

// Rest triangles with 2 A <= EK_CLOTH_DEGENERATE_REL (longest edge)^2 are
// refused, naming the triangle (the rule of cloth.h's
// EK_TRI_DEGENERATE_REL, and of mesh.h's for tets).
#define EK_CLOTH_DEGENERATE_REL 1e-12

// Budgets checked by tests/test_cloth_force.c and ek-verify (the test
// scenarios' own tolerances are in verify/test_tolerances.h).
// Kernel forces against the double reference, max |f - f_ref| / max |f_ref|.
#define EK_CLOTH_FORCE_TOL_F32 1e-4
#define EK_CLOTH_FORCE_TOL_F64 1e-11
// The vector energy and Hessian product (ek_cloth_energy_ex_*,
// ek_cloth_hessian_apply_ex_*) against the double paths (norms above).
#define EK_CLOTH_MEMBRANE_TOL_F32 1e-4
#define EK_CLOTH_MEMBRANE_TOL_F64 1e-11
// A flat cloth at rest: max |f| relative to the force scale mu h + k_b / h
// (h the longest rest edge): rounding of F = I in that precision.
#define EK_CLOTH_FORCE_REST_TOL_F32 1e-5
#define EK_CLOTH_FORCE_REST_TOL_F64 1e-13

// Build the element layer of a triangle mesh: X nverts x 3, tris ntris x 3
// (0-based). NULL (message in ek_last_error, naming the triangle and the
// value) for an index out of range, a repeated index, a non-finite
// coordinate or a degenerate (zero-area) rest triangle. Edges shared by
// more than two triangles (non-manifold) get no bending hinge.
ek_cloth *ek_cloth_create(size_t nverts, const double *X, size_t ntris, const int32_t *tris);
void ek_cloth_destroy(ek_cloth *cl);

size_t ek_cloth_nverts(const ek_cloth *cl);
size_t ek_cloth_ntris(const ek_cloth *cl);
size_t ek_cloth_nhinges(const ek_cloth *cl);
const int32_t *ek_cloth_tris(const ek_cloth *cl);      // ntris x 3
const double *ek_cloth_rest_areas(const ek_cloth *cl); // ntris
const double *ek_cloth_dm_inv(const ek_cloth *cl);     // ntris x 4, row-major 2x2
const int32_t *ek_cloth_hinges(const ek_cloth *cl);    // nhinges x 4: x0 x1 (edge), x2, x3
const double *ek_cloth_hinge_k(const ek_cloth *cl);    // nhinges x 4: Q = k k^T
// Per vertex: a third of the rest area of each incident triangle.
const double *ek_cloth_lumped_area(const ek_cloth *cl);

// Wall-clock seconds of the phases of one force call (separate passes).
typedef struct {
  double membrane, bending, gather;
} ek_cloth_phase_times;

typedef struct {
  ek_isa isa;                        // kernel target (AUTO: dispatch)
  ek_cloth_phase_times *phase_times; // accumulate into it when set
} ek_cloth_force_opts;

// f = -dE/dx (membrane + bending), x and f nverts x 3, f overwritten.
// 0, or < 0 with ek_last_error. A non-finite x gives non-finite forces at
// its neighbours, nothing else.
int ek_cloth_forces_f32(const ek_cloth *cl, const ek_cloth_params *p, const float *x, float *f,
                        const ek_cloth_force_opts *opts);
int ek_cloth_forces_f64(const ek_cloth *cl, const ek_cloth_params *p, const double *x, double *f,
                        const ek_cloth_force_opts *opts);
// E(x) = sum_t A_t Psi(F_t) + E_bend(x), summed in a fixed order: in
// double, the triangles' energies in triangle order, then the hinges' in
// hinge order (one sum; the implicit loop's line search compares these).
double ek_cloth_energy_f64(const ek_cloth *cl, const ek_cloth_params *p, const double *x);
// q = H(x) p (nverts x 3 each), projected to PSD when `project` (above).
int ek_cloth_hessian_apply_f64(const ek_cloth *cl, const ek_cloth_params *p, const double *x,
                               int project, const double *dx, double *q);
// Vector forms (every ISA x precision, opts->isa; phase_times unused):
// the membrane's energy and Hessian product run as vector kernels
// (kernels/cloth_force/cloth_membrane_block.c, ARAP through the vectorised
// 3x2 polar of ek_polar32), the bending and the sums as above; the energy
// is summed in double (E receives it): _f64 in the order above; _f32 in
// blocks of 256 (EK_CLOTH_ENERGY_BLOCK_F32: triangles 0-255, 256-511, ...,
// then hinges the same),
// each block's energies summed in element order from 0, then the block
// sums in order, the triangles' blocks then the hinges' (so 2 threads
// share the adds; the same bits at any thread count, though not those of
// one ordered sum). They equal the double paths above
// to EK_CLOTH_MEMBRANE_TOL_F32/_F64 (max |q - q_ref| / max |q_ref|, and
// |E - E_ref| / sum_t A_t |Psi_t| for the energy), checked against the
// double reference by tests/test_cloth_force.c and ek-verify. The default
// ek_cloth_energy_f64 / ek_cloth_hessian_apply_f64 run them for StVK (the
// kernels follow the double path's operation order without fused
// operations: the same bits as before on every ISA); for ARAP, and for
// the diagonal blocks and fields, they stay scalar double (the vector
// polar rounds differently, and those bits are every ARAP scene's).
int ek_cloth_energy_ex_f32(const ek_cloth *cl, const ek_cloth_params *p, const float *x, double *E,
                           const ek_cloth_force_opts *opts);
int ek_cloth_energy_ex_f64(const ek_cloth *cl, const ek_cloth_params *p, const double *x, double *E,
                           const ek_cloth_force_opts *opts);
int ek_cloth_hessian_apply_ex_f32(const ek_cloth *cl, const ek_cloth_params *p, const float *x,
                                  int project, const float *dx, float *q,
                                  const ek_cloth_force_opts *opts);
int ek_cloth_hessian_apply_ex_f64(const ek_cloth *cl, const ek_cloth_params *p, const double *x,
                                  int project, const double *dx, double *q,
                                  const ek_cloth_force_opts *opts);
// 3x3 diagonal blocks of the projected Hessian per vertex (nverts x 9), for
// a block-Jacobi preconditioner.
int ek_cloth_hessian_diagonal_f64(const ek_cloth *cl, const ek_cloth_params *p, const double *x,
                                  double *blocks);
// Per-triangle fields (any may be NULL): J = area ratio s1 s2 (det of the
// 3x2 F in the polar sense), the stretches s1 >= s2 >= 0 (singular values
// of F), and the membrane energy density Psi(F) per unit rest area.
int ek_cloth_fields_f64(const ek_cloth *cl, const ek_cloth_params *p, const double *x, double *J,
                        double *s1, double *s2, double *psi);

// XPBD (Macklin et al. 2016) for cloth, scalar double
// (kernels/xpbd/cloth_xpbd.c): one membrane constraint per triangle
// in the form of the tets' (xpbd.h, seed 001), C = sqrt(2 W / k) with
// compliance 1 / (A k), W = Psi per unit area, k = the sheet's Young's
// modulus per unit area (E h), so C^2 / (2 alpha) = A Psi: the membrane
// energy (StVK or ARAP); per hinge C = |sum_i k_i x_i| with compliance
// 1 / k_b: the quadratic bending energy. Coloured Gauss-Seidel (no two
// constraints of a colour share a vertex), a colour in parallel: the same
// bits at any thread count. Constraints with C <= EK_CLOTH_XPBD_C_MIN
// (rounding of a rest element) are skipped.
#define EK_CLOTH_XPBD_C_MIN 1e-12
typedef struct ek_cloth_xpbd ek_cloth_xpbd;
ek_cloth_xpbd *ek_cloth_xpbd_create(const ek_cloth *cl, const ek_cloth_params *p, double k);
void ek_cloth_xpbd_destroy(ek_cloth_xpbd *x);
size_t ek_cloth_xpbd_count(const ek_cloth_xpbd *x); // triangles + hinges (0 without bending)
int ek_cloth_xpbd_colors(const ek_cloth_xpbd *x);
// A substep of h: inverse masses w (0 holds a vertex), lambda = 0.
int ek_cloth_xpbd_begin(ek_cloth_xpbd *x, const double *w, double h);
// `sweeps` Gauss-Seidel sweeps on x (nverts x 3) in place.
int ek_cloth_xpbd_iterate(ek_cloth_xpbd *x, double *pos, int sweeps);
// max_j |C_j + alpha~_j lambda_j| and max_j C_j at x.
int ek_cloth_xpbd_residual(const ek_cloth_xpbd *x, const double *pos, double *residual,
                           double *cmax);

#ifdef __cplusplus
}
#endif
#endif
