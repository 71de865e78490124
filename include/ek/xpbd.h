// XPBD with the Hookean constraint of seed 001 (Macklin, Mueller,
// Chentanez 2016, "XPBD: position-based simulation of compliant
// constrained dynamics") or the stable neo-Hookean constraint pair
// (Macklin & Mueller 2021, below), vectorised over AoSoA constraint blocks.
//
// The constraint (seed 001): per element j, with the StVK energy density
// W(F) = mu e:e + lambda/2 tr(e)^2, e = (F^T F - I)/2 (the "Hookean" energy
// of the seed; ek's stvk model) and Young's modulus E,
//   C_j = sqrt(2 W(F_j) / E),  alpha_j = 1 / (V_j E),
// so that C_j^2 / (2 alpha_j) = V_j W(F_j): the constraint energy is the
// elastic energy the implicit loop minimises with StVK.
//   grad_i C_j = (1 / (E C_j)) dW/dF : dF/dx_i,  dW/dF = P = F S,
// S = 2 mu e + lambda tr(e) I: the first Piola-Kirchhoff stress. (The seed
// writes S F, which differs from F S unless F and S commute; F S is the
// derivative, checked by finite differences in tests/test_xpbd.c.)
//
// Elements: every element's F is linear in its members' positions,
//   F = sum_{k>=1} (x_k - x_0) b_k^T,
// so grad_k C = P b_k / (E C) for k >= 1 and grad_0 C = -sum_{k>=1} grad_k C
// (the gradients sum to zero: the momentum of the members is kept).
//   tets:     members the 4 corners, b_k row k of Dm^-1 (F = Ds Dm^-1,
//             Teran et al. 2003; seed 004), V_j the rest volume;
//   clusters: shape matching (seed 001; Mueller et al. 2005): one cluster
//             per vertex j, its members j (member 0) and the vertices that
//             share a tet with it (ascending), F = (sum_k m_k r_k rbar_k^T)
//             Q^-1, Q = sum_k m_k rbar_k rbar_k^T, r and rbar relative to
//             the current and rest centres of mass; the centre-of-mass
//             terms cancel (sum_k m_k rbar_k = 0), so b_k = m_k Q^-1 rbar_k
//             (the seed's dF/dx_k = m_k Q^-T rbar_k). V_j is the vertex's
//             share of the mesh volume (a quarter of each incident tet's),
//             so the V_j sum to the mesh volume. A cluster whose Q is
//             singular (members coplanar, or massless) is refused at
//             creation, naming the vertex: det Q < 1e-12 (tr Q / 3)^3, a
//             test relative to Q's own scale, so any length and mass the
//             precision holds are accepted (tested at 1e+-30 m in f64).
//
// The projection (Macklin 2016 eqs. 18, 17): per constraint,
//   dlambda_j = (-C_j - alpha~_j lambda_j) / (sum_i w_i |grad_i C_j|^2
//               + alpha~_j),  alpha~_j = alpha_j / h^2,
//   lambda_j += dlambda_j,  x_i += w_i grad_i C_j dlambda_j,
// w_i = 1 / m_i (0 pins a vertex), h the substep. At rest C_j = 0 and
// grad C_j is 0/0: a constraint with C_j <= EK_XPBD_C_MIN_F32 / _F64 (its
// strain is at the rounding level of F in that precision) is skipped, its
// lambda and members untouched.
//
// Solvers:
//   GAUSS_SEIDEL: constraints of one colour share no vertex, so a colour's
//     constraints are projected together (one AoSoA block at a time, and
//     by threads in parallel); colours run in sequence. Tets use the
//     element layer's coloured order (elements.h: chunk colours, chunks,
//     tet colours); clusters are coloured greedily here.
//   JACOBI: every constraint from the same positions; the corrections of a
//     vertex are summed in a fixed order (constraint order), then applied.
//     Averaging (Macklin et al. 2014, "Unified particle physics") in its
//     consistent form: vertex i's mass counts n_i times in every
//     dlambda's denominator (n_i the constraints on vertex i), i.e.
//     sum_i n_i w_i |grad_i C_j|^2: each correction is about 1/n_i of the
//     Gauss-Seidel one, and the multipliers move with the positions, so
//     the fixed point is Gauss-Seidel's and the linearised iteration
//     converges (J W J^T <= its diagonal scaled by n).
// Both give the same bits for any thread count.
//
// The dropped primal residual: XPBD keeps x - x~ = W sum over its
// projections of grad C(x_then) dlambda, not W grad C(x)^T lambda (Macklin
// 2016 eq. 8 with g = 0), so its fixed point is not backward Euler's. With
// this constraint the gap is large: C is a norm of the strain, so grad C
// turns wherever the strain changes its shape. In a cube stretched by 10%
// (h = 1e-2 s, E = 1e6, 200 converged Gauss-Seidel sweeps) the "primal
// correction" x = x~ + W grad C(x)^T lambda moved x by 0.063 m against
// |x - x~| = 0.037 m, and interleaving it with the sweeps (the variant that
// would converge to backward Euler) diverged on the cantilever at every
// setting tried, clamped multipliers included; so no such variant is
// offered. tests/test_sim_xpbd.c measures the gap against the implicit loop.
//
// Stable neo-Hookean (mat->model EK_MODEL_STABLE_NEO_HOOKEAN): the
// constraint-based stable neo-Hookean of Macklin & Mueller 2021 ("A
// Constraint-based Formulation of Stable Neo-Hookean Materials", MIG '21):
// per element a deviatoric constraint C_D with compliance alpha_D = 1 /
// (V mu) and a hydrostatic one C_H = det F - gamma with alpha_H = 1 /
// (V lambda), projected together by the paper's coupled 2x2 solve (its
// remedy for the bias of solving them one after the other):
//   [grad C_D W grad C_D^T + alpha~_D, grad C_D W grad C_H^T     ] dl_D
//   [grad C_H W grad C_D^T,     grad C_H W grad C_H^T + alpha~_H ] dl_H
//     = -[C_D + alpha~_D lambda_D; C_H + alpha~_H lambda_H],
// x_i += w_i (grad_i C_D dl_D + grad_i C_H dl_H). The paper takes C_D =
// sqrt(tr F^T F) and gamma = 1 + mu / lambda: the energy mu/2 I_C +
// lambda/2 (J - gamma)^2, Smith et al. 2018's without its log term. ek's
// stable neo-Hookean psi (kernels/material/snh.c) keeps the log term and
// a = 1 + 3 mu / (4 lambda), so here, with the same mu and lambda as the
// material (no re-parametrisation):
//   C_D = sqrt(I_C - log(1 + I_C)),  dC_D/dF = I_C / ((1 + I_C) C_D) F,
//   C_H = J - a,                     dC_H/dF = cof F,
// and C_D^2 / (2 alpha_D) + C_H^2 / (2 alpha_H) = V (psi(F) + 3 mu / 2):
// ek's psi up to a constant (tests/test_xpbd_snh.c checks it), so the
// implicit loop with "snh" minimises the same energy. I_C - log(1 + I_C)
// is >= 0 and 0 only at F = 0, where grad C_D is 0/0 and is dropped (C_D
// <= EK_XPBD_C_MIN_*); C_H has no singularity, so no element is skipped.
// Both constraints vanish nowhere near rest (C_D(I) = sqrt(3 - log 4)),
// yet their forces do: P(I) = 0 (rest stability, Smith et al. 2018), and
// the gradients resist inversion (C_H's pushes J back to a > 0). The
// residual is the larger of the pair's |C + alpha~ lambda|; cmax is max
// |C_H| (C_D is not 0 at rest). The stiff planes hold V (k = V mu h^2,
// V lambda h^2); E is not used. Because C_D and C_H are not 0 at rest,
// their multipliers are O(k) even for small strains (a pre-stress whose two
// forces cancel), so the dropped primal residual below costs more than
// with StVK: a bar hanging at rest lands 1.8e-2 off the implicit loop at 20
// substeps (converged sweeps; StVK 8.5e-4), 1.5e-3 at 80 (it shrinks about
// as h^2), and in f32 the cancelling terms round at ~C, not at the strain
// (tests/test_sim_xpbd.c).
//
// Precision: the f32 functions iterate in float, the f64 ones in double;
// with a base (ek_xpbd_iterate_*) the updates round to the displacements'
// size, which is how the XPBD loop calls the f32 ones (sim/xpbd.c).
// Constraint data (b_k, V_j) is computed in double and rounded once.
#ifndef EK_XPBD_H
#define EK_XPBD_H

#include <stddef.h>
#include <stdint.h>

#include "core.h"
#include "elements.h"
#include "material.h"

#ifdef __cplusplus
extern "C" {
#endif

// Below this C the constraint is skipped (see above): f32 F has absolute
// rounding ~1e-7, f64 ~1e-16, and C is of the order of the strain.
#define EK_XPBD_C_MIN_F32 1e-6
#define EK_XPBD_C_MIN_F64 1e-12

// Error budgets of the kernels against the double reference
// (reference/xpbd/xpbd_ref.c; tests/test_xpbd.c): positions after
// iterations, max_i |x_i - x_ref,i| / the mesh's bounding-box diagonal.
#define EK_XPBD_TOL_F32 1e-5
#define EK_XPBD_TOL_F64 1e-12

typedef enum { EK_XPBD_GAUSS_SEIDEL = 0, EK_XPBD_JACOBI, EK_XPBD_SOLVER_COUNT } ek_xpbd_solver;
typedef enum { EK_XPBD_TETS = 0, EK_XPBD_CLUSTERS, EK_XPBD_ELEMENTS_COUNT } ek_xpbd_elements;

// "gauss_seidel", "jacobi"; "tets", "clusters"; "invalid" for others.
const char *ek_xpbd_solver_name(ek_xpbd_solver s);
const char *ek_xpbd_elements_name(ek_xpbd_elements e);

// Options; zero means default (tets, Gauss-Seidel, best ISA, f64).
typedef struct {
  ek_xpbd_elements elements;
  ek_xpbd_solver solver;
  ek_isa isa;
  int precision; // 32 or 64 (0 = 64)
} ek_xpbd_opts;

typedef struct ek_xpbd ek_xpbd;

// The default model, whose energy the Hookean constraint is (seed 001).
#define EK_XPBD_MODEL EK_MODEL_STVK

// 1 for the models XPBD has constraints for (EK_XPBD_MODEL and
// EK_MODEL_STABLE_NEO_HOOKEAN), else 0.
int ek_xpbd_supports(ek_model model);

// Constraints over the element layer's mesh. mat: StVK (EK_XPBD_MODEL; mu,
// lambda) or stable neo-Hookean (mu > 0, lambda > 0), young: E > 0 (StVK's
// constraint's scale and compliance; unused by stable neo-Hookean). mass: nverts masses m_i >= 0,
// read for clusters (the shape matching weights; may be NULL for tets). NULL with ek_last_error on
// a bad argument, a singular cluster or no memory. Keeps a pointer to el.
ek_xpbd *ek_xpbd_create(const ek_tets *el, const ek_material *mat, double young, const double *mass,
                        const ek_xpbd_opts *opts);
void ek_xpbd_destroy(ek_xpbd *xp);

// Constraints (tets, or vertices for clusters), colours, and the largest
// cluster (4 for tets).
size_t ek_xpbd_count(const ek_xpbd *xp);
int ek_xpbd_ncolors(const ek_xpbd *xp);
int ek_xpbd_max_members(const ek_xpbd *xp);
// Constraint j's members (caller vertex indices, member 0 first) and
// b_1..b_{K-1} (3 each, double), K returned; members/b may be NULL to ask
// for K only. For tests and the reference.
int ek_xpbd_members(const ek_xpbd *xp, size_t j, int32_t *members, double *b);
// The order in which Gauss-Seidel projects the constraints (ek_xpbd_count
// ids). Constraints of one colour share no vertex, so projecting them in
// this order one at a time gives what the kernel gives.
int ek_xpbd_order(const ek_xpbd *xp, int32_t *order);

// Inverse masses w_i (nverts; 0 = pinned) for the iterations that follow;
// may change between substeps (boundary conditions released, damping).
int ek_xpbd_set_weights(ek_xpbd *xp, const double *w);
// Start a substep of length h > 0: lambda = 0, alpha~_j = 1 / (V_j E h^2).
int ek_xpbd_begin(ek_xpbd *xp, double h);
// `iterations` sweeps of the solver over every constraint, x (nverts x 3)
// updated in place; the precision must be the opts'. x_base NULL: x holds
// the positions. Otherwise the positions are x_base + x and x holds
// displacements from x_base (e.g. x~): the updates then round to the
// displacements' size, not the coordinates' (f32: a body 100 m from the
// origin would otherwise move in steps of 4e-6 m).
int ek_xpbd_iterate_f32(ek_xpbd *xp, const float *x_base, float *x, int iterations);
int ek_xpbd_iterate_f64(ek_xpbd *xp, const double *x_base, double *x, int iterations);
// max_j |C_j(x) + alpha~_j lambda_j| over the constraints not skipped (the
// dual residual after the iterations so far), and optionally max_j C_j.
// Positions x_base + x as above.
int ek_xpbd_residual_f32(const ek_xpbd *xp, const float *x_base, const float *x, double *residual,
                         double *cmax);
int ek_xpbd_residual_f64(const ek_xpbd *xp, const double *x_base, const double *x, double *residual,
                         double *cmax);
// The multipliers (ek_xpbd_count, constraint order) in double: StVK's,
// or stable neo-Hookean's deviatoric ones (lambda_D); ek_xpbd_lambda_h the
// hydrostatic ones (lambda_H; 0 for StVK).
int ek_xpbd_lambda(const ek_xpbd *xp, double *lambda);
int ek_xpbd_lambda_h(const ek_xpbd *xp, double *lambda);
// The model of the constraints (mat->model at creation).
ek_model ek_xpbd_model(const ek_xpbd *xp);

// Phase split of one sweep at x (x and lambda untouched): seconds[0] the
// elements' deformation gradients alone, seconds[1] the same plus the
// constraint evaluation (W, P, grad C, dlambda), seconds[2] a whole sweep
// on a copy of x (adds the projection: the position updates).
int ek_xpbd_profile_f32(ek_xpbd *xp, const float *x_base, const float *x, double seconds[3]);
int ek_xpbd_profile_f64(ek_xpbd *xp, const double *x_base, const double *x, double seconds[3]);

#ifdef __cplusplus
}
#endif
#endif
