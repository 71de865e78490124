// ek simulation library (libek_sim, ek::sim): the simulation loop, and
// the library's umbrella header: it includes scene.h, frames.h, mesh.h and
// trimesh.h (and through them the kernel headers they use).
//
// The loop (ek_sim_*) is a simulation core shared by every integrator
// (state, lumped masses M, pinned and prescribed vertices, a friction-free
// ground: position projected onto the plane, normal velocity into the
// ground zeroed; energies, per-tet fields, timing) and one integrator, the
// scene's "integrator":
//   explicit  symplectic Euler with the FVM force of fvm.h (Teran et al.
//             2003, seed 004) and mass-proportional damping c:
//               v += dt M^-1 (f(x) + M g - c M v);  x += dt v
//   implicit  backward Euler solved by Newton's method with a line search
//             on the incremental potential, each Newton system by
//             matrix-free preconditioned CG on the projected element
//             Hessians (hessian.h); see ek_scene_implicit. The gradient is
//             double; the Hessian products run in the scene's precision.
//             Pinned and prescribed vertices take their position at
//             t_{n+1} before the solve; the ground is applied after it,
//             as in the explicit loop.
//   xpbd      XPBD (xpbd.h: the Hookean constraint of seed 001 on tets or
//             shape-matching clusters) in K substeps of h = dt / K, each
//             N solver sweeps from lambda = 0; see ek_scene_xpbd. Model
//             stvk (the seed's energy) only.
// Positions and velocities are kept in double; the force kernel runs in the
// scene's precision (f32 converts x to float once per force evaluation).
// Corotated linear refreshes R^n per tet from the positions at the start of
// every step (seed 000: R^n = polar(F^n)).
#ifndef EK_SIM_SIM_H
#define EK_SIM_SIM_H

#include <signal.h>
#include <stddef.h>

#include <ek/core.h>

#include "frames.h"
#include "mesh.h"
#include "scene.h"
#include "trimesh.h"

#ifdef __cplusplus
extern "C" {
#endif

// Return code of ek_sim_step when an element left the model's domain (J <= 0
// for neo-Hookean without clamp): the step is not applied, the message names
// the step, the number of inverted tets and the first one.
#define EK_SIM_EINVERTED (-10)
// Return code of ek_sim_step when the stop flag (ek_sim_set_stop_flag) was
// seen inside the step: the step is not applied.
#define EK_SIM_ESTOPPED (-11)
// Return code of ek_sim_step when the implicit loop's Newton solve stopped
// above newton_tol (max_newton, or a line search with no decrease) at a
// state that turns the body inside out (signed volume > 0 before, <= 0
// after): the step is not applied; the message names the step, the
// residual and the volumes. The state is finite: a failed solve, not a
// blow-up, and not an element outside the model's domain.
#define EK_SIM_EUNCONVERGED (-12)
// XPBD sweeps run between two looks at the stop flag (a slice of one
// substep's iterations; the sweeps are the same either way).
#define EK_SIM_STOP_SWEEPS 64

// ---------------------------------------------------------------- loop

typedef struct ek_sim ek_sim;

// Wall-clock seconds spent per phase, summed over steps. The force phases
// (deformation gradient, SVD/polar, P, scatter) come from the FVM kernel's
// phase-timed form (separate passes), used only when timing is requested;
// `forces` is the fused kernel's time otherwise. `integration` covers the
// velocity/position update, boundary conditions and ground; `polar_refresh`
// corotated linear's R^n.
//
// The implicit integrator's phases: `gradient` its fused energy + gradient
// + eigensystem passes (one per line-search trial; an accepted trial's
// pass is the next Newton iteration's gradient), of which `eigensystems`
// is the part that caches the Hessian (measured in phase-timed steps by a
// pass without it, 0 otherwise; `gradient_timed` is the caching passes'
// time in those steps); `matvec` the Hessian products (with the
// mass term and, for f32, the conversions); `preconditioner` the diagonal
// blocks, their inverses and their application; `cg_vectors` CG's other
// vector work; `line_search` the trial points and objective sums.
typedef struct {
  double deformation_gradient, svd_polar, pk1, scatter; // phase-timed steps only
  double forces;                                        // fused force kernel (all steps)
  double polar_refresh;                                 // corotated linear R^n
  double integration;
  long steps, phase_timed_steps;
  // Implicit integrator (0 otherwise).
  double gradient, eigensystems, gradient_timed, matvec, preconditioner, cg_vectors, line_search;
  long newton_iterations, cg_iterations, gradient_passes, matvecs, backtracks;
  long unconverged_steps; // stopped above newton_tol (max_newton or a stalled line search)
  double worst_residual;  // the largest final Newton residual of a step
  double last_residual;   // the last step's final residual
  // Assembled linear solvers ("amg", "direct": ek_scene_implicit): the
  // assembly of K and the system matrix, the solver's setup (AMG
  // hierarchy or Cholesky factorisation) and its solve.
  double assembly, solver_setup, solver_solve;
  // Across MPI ranks (ek-sim under mpirun): the sums over the ranks (the
  // gradient and energy; with "matrix_free" also the Hessian products and
  // the preconditioner's blocks), each rank's wait for the others included.
  double mpi_sum;
  // XPBD integrator (0 otherwise): `xpbd_solve` the solver sweeps; per sweep, measured once per
  // phase-timed step at the step's end (ek_xpbd_profile_*), summed over
  // xpbd_profiles: the deformation gradients (tet F or cluster F), the
  // constraint evaluation (W, P, grad C, dlambda) and the projection (the
  // position updates). The residual max_j |C_j + alpha~_j lambda_j| after
  // the last sweep of a step: the last step's, the worst step's.
  double xpbd_solve;
  double xpbd_sweep_F, xpbd_sweep_eval, xpbd_sweep_project;
  long xpbd_sweeps, xpbd_profiles;
  double xpbd_last_residual, xpbd_worst_residual, xpbd_last_cmax;
  // Cloth (phase-timed steps): the membrane and bending corner passes and
  // the per-vertex gather (cloth_force.h).
  double cloth_membrane, cloth_bending, cloth_gather;
} ek_sim_times;

typedef struct {
  double kinetic, elastic, potential; // potential: gravity, -sum m g.x
} ek_sim_energies;

// The implicit integrator's last step, iteration by iteration (tests and
// diagnostics): residual[k] and phi[k] at the k-th Newton iterate (k = 0 the
// start point, up to `iterations`), and for iteration k (0-based) its CG
// iterations, CG's final |r|_{M^-1} / |grad Phi|_{M^-1}, and the accepted
// alpha. Only the first EK_SIM_NEWTON_TRACE iterations are kept.
#define EK_SIM_NEWTON_TRACE 64
typedef struct {
  int iterations;
  double residual[EK_SIM_NEWTON_TRACE + 1], phi[EK_SIM_NEWTON_TRACE + 1];
  long cg_iterations[EK_SIM_NEWTON_TRACE];
  double cg_relative[EK_SIM_NEWTON_TRACE], alpha[EK_SIM_NEWTON_TRACE];
} ek_sim_newton_trace;

// Build the simulation of a scene on a mesh (the caller keeps the mesh alive
// and destroys it after the sim). NULL on failure (message in ek_last_error).
ek_sim *ek_sim_create(const ek_scene *scene, const ek_mesh *mesh);
// A cloth scene (scene->triangles) on its triangle mesh: the same loop with
// the cloth forces (cloth_force.h) in place of the FVM force.
ek_sim *ek_sim_create_cloth(const ek_scene *scene, const ek_trimesh *mesh);
int ek_sim_is_cloth(const ek_sim *sim);
// The scene's simulation whichever element kind it has: builds the mesh
// (ek_scene_mesh, or ek_scene_trimesh for a cloth) and the sim, which owns
// the mesh (ek_sim_destroy frees it). NULL on failure (message in
// ek_last_error: the mesh's or the sim's, as the calls above give it).
ek_sim *ek_sim_create_scene(const ek_scene *scene);
// The body's elements, for programs that write or print them without
// knowing their kind (frames.h: ek_frames_create_ex takes corners and the
// incidence): pointers valid while the sim lives.
typedef struct {
  const char *kind;         // "tets", "triangles"
  size_t count;             // elements
  int corners;              // vertices per element: 4, 3
  const int32_t *incidence; // count x corners, the caller's (mesh's) order
  size_t nverts;            // vertices
  const double *rest;       // nverts x 3 rest positions
  int has_smax;             // ek_sim_fields fills smax (triangles: s1)
  int oriented;             // J <= 0 is inverted (tets); triangles in 3D have no
                            // orientation: ek_sim_inverted_count is 0
} ek_sim_elements;
int ek_sim_elements_of(const ek_sim *sim, ek_sim_elements *e);
// One line naming the body's counts and model, for a run's header:
// "1296 tets, 8 colours, model stvk" or "800 triangles, 1160 hinges,
// membrane arap". Returns buf.
const char *ek_sim_describe(const ek_sim *sim, char *buf, size_t len);
// The force's phase split of the phase-timed steps (ek_sim_time_phases):
// up to max phases, each its name and its seconds summed so far (tets:
// deformation gradient, SVD/polar, P(F), scatter; triangles: membrane,
// bending, gather). Returns the count (<= EK_SIM_MAX_PHASES).
#define EK_SIM_MAX_PHASES 4
int ek_sim_force_phases(const ek_sim *sim, const char **names, double *seconds, int max);
// A condition the run goes on with, for the caller to report (the library
// prints nothing, core.h): an explicit dt above the CFL limit (set by
// ek_sim_create), the first step whose Newton loop stopped above
// newton_tol. Returns the pending warning once (valid until the next call
// on this sim); NULL when none is pending.
const char *ek_sim_warning(ek_sim *sim);
void ek_sim_destroy(ek_sim *sim);
// Advance one step with the scene's integrator. 0, EK_SIM_EINVERTED,
// EK_SIM_ESTOPPED, EK_SIM_EUNCONVERGED or < 0 (message in ek_last_error); on error the state
// is left as it was before the step. A step that leaves a position or a
// velocity that is not finite fails (EK_EINVAL, "non-finite state"), so the
// state is always finite.
int ek_sim_step(ek_sim *sim);
// A stop request the step looks at while it runs: *flag (e.g. set by the
// caller's SIGINT handler) non-zero makes the step return EK_SIM_ESTOPPED,
// state unchanged, at the next check: between XPBD substeps and slices of
// at most EK_SIM_STOP_SWEEPS sweeps, between Newton iterations, CG
// iterations and line-search trials. A step of any length thus ends within
// about one force evaluation (implicit, explicit) or EK_SIM_STOP_SWEEPS
// sweeps (XPBD). NULL (the default) checks nothing. The checks read the
// flag only: the results are the same bits with or without it.
void ek_sim_set_stop_flag(ek_sim *sim, const volatile sig_atomic_t *flag);
// Name of the integrator the sim steps with ("explicit").
const char *ek_sim_integrator_name(const ek_sim *sim);
// Tets with J <= 0 in the current state.
size_t ek_sim_inverted_count(const ek_sim *sim);
// The state check every loop reports (issue 25: no run turns a body inside
// out or writes NaN silently): ek-sim at every frame time, the advisor's
// trials and ek-bench's sim rows at their end.
//   elements   the body's elements
//   inverted   of them with J <= 0 (ek_sim_inverted_count; 0 for
//              triangles, which have no orientation in 3D)
//   nonfinite  NaN / inf entries of the positions and velocities (0 after a
//              successful ek_sim_step, which refuses a non-finite state;
//              ek-sim adds the frame fields' own count, ek_count_nonfinite)
//   extent     max_i |x_i - c| / L, c and L the rest bounding box's centre
//              and diagonal: scale-free, 0.5 at rest, ~1-10 for a body that
//              moved by its size
//   blown_up   nonfinite > 0 or extent > EK_SIM_BLOWUP_EXTENT: a finite
//              blow-up (positions of 1e10 m for a 1 m body) fails like NaN
//   allow_inverted, allow_nonfinite  the scene's "allow" key (scene.h),
//              copied for the caller's verdict
// and where, for the messages (indices 0-based, the mesh's order; the
// same passes as the counts):
//   first_inverted, first_inverted_J  the first inverted element and its
//              J (valid when inverted > 0)
//   first_nonfinite  the first vertex with a NaN / inf position or
//              velocity (valid when the state's count is not 0)
//   farthest   the vertex at `extent` (the first NaN / inf one if any)
#define EK_SIM_BLOWUP_EXTENT 1e6
typedef struct {
  size_t elements, inverted, nonfinite;
  double extent;
  int blown_up;
  int allow_inverted, allow_nonfinite;
  size_t first_inverted;
  double first_inverted_J;
  size_t first_nonfinite, farthest;
} ek_sim_health;
int ek_sim_check(const ek_sim *sim, ek_sim_health *h);
// Entries of a[0..n) that are NaN or inf (a may be NULL: 0).
size_t ek_count_nonfinite(const double *a, size_t n);
// Ask for the per-phase split on the next steps (costs extra passes).
void ek_sim_time_phases(ek_sim *sim, int on);
const ek_sim_times *ek_sim_timings(const ek_sim *sim);
double ek_sim_time(const ek_sim *sim);
long ek_sim_steps_done(const ek_sim *sim);
const double *ek_sim_positions(const ek_sim *sim); // nverts x 3, caller order
const double *ek_sim_velocities(const ek_sim *sim);
const double *ek_sim_masses(const ek_sim *sim); // nverts
// Replace the current state: positions x and, when v is not NULL,
// velocities (nverts x 3, caller order), for an initial state the scene's
// keys cannot express (ek-verify --extremes: a body crushed to a point
// with noise, Irving et al. 2004 sec. 7). Boundary conditions keep moving
// from the initial positions the scene gave. Rotations kept between steps
// (corotated linear's R^n, the "polar": "warm" force rotations) restart at
// the SVD polar of the new state. EK_EINVAL (nothing changed, message in
// ek_last_error) for a non-finite entry.
int ek_sim_set_state(ek_sim *sim, const double *x, const double *v);
// The last implicit step's Newton history (all zero for other integrators).
const ek_sim_newton_trace *ek_sim_last_newton(const ek_sim *sim);
// The XPBD integrator's constraints (tets or clusters; 0 for the other
// integrators).
size_t ek_sim_xpbd_constraints(const ek_sim *sim);
// Kinetic, elastic and gravity potential energy of the current state. The
// elastic energy is measured from the rest shape, E(x) - E(X)
// (ek_mesh_fvm_energy_ex_f64; corotated linear with the current R^n), as some
// models (stable neo-Hookean) are not 0 at rest.
int ek_sim_energy(const ek_sim *sim, ek_sim_energies *e);
void ek_sim_momentum(const ek_sim *sim, double p[3]);
// Sum of signed tet volumes of the current positions.
double ek_sim_volume(const ek_sim *sim);
// Largest step the explicit loop is stable at for the model linearised at
// rest: tets, 2 / omega_max by the element eigenvalue bound (each tet's
// linear-elastic stiffness against its lumped mass; a guaranteed bound,
// 0.64-0.82 of h_min / c on the shipped meshes); cloth, the CFL rule
// h_min / c with c the membrane's dilatational wave speed. Tets: computed
// scale-free (each element, lambda, mu and the density scaled by powers of
// two), so it is finite and > 0 for every mesh ek_mesh accepts (edges about
// 1e-102 to 1e102) and any density and moduli whose limit a double holds;
// +inf only for a material without stiffness.
double ek_sim_cfl_dt(const ek_sim *sim);
// Per-tet fields of the current state, caller tet order (any may be NULL):
// J = det F, smallest signed singular value of F, and the energy density
// measured from the rest shape, Psi(F) - Psi(F_rest) per unit rest volume
// (0 at rest for every model; sum_e V0_e psi_e is ek_sim_energy's elastic
// energy).
int ek_sim_tet_fields(const ek_sim *sim, double *J, double *smin, double *psi);
// Per-triangle fields of a cloth (any may be NULL): J = area ratio, the
// stretches s1 >= s2 (singular values of the 3x2 F) and the membrane energy
// density per unit rest area (per unit area of the sheet, Psi h). On a
// cloth, ek_sim_tet_fields gives (J, s2, psi) and ek_sim_volume the area.
int ek_sim_cloth_fields(const ek_sim *sim, double *J, double *s1, double *s2, double *psi);
// Per-element fields of the current state, whichever the kind (any may
// be NULL): as ek_sim_tet_fields for tets (smax not written), as
// ek_sim_cloth_fields for triangles (smin = s2, smax = s1);
// ek_sim_elements' has_smax says which.
int ek_sim_fields(const ek_sim *sim, double *J, double *smin, double *psi, double *smax);
// The velocity gradient L = D + W of every element in the current state
// (seed 003 eqs. 28-31, cloth.h): tets L = Fdot F^-1, triangles
// L = Fdot F^+ (the surface gradient of v); D, W nelems x 9 row-major and
// the principal strain rates nelems x 3 (any may be NULL): tets the
// eigenvalues of D, descending; triangles the two eigenvalues of D in the
// deformed plane (P D P, the membrane's rate of strain), descending, then
// 0. Eigenvalues of a symmetric 3x3 in closed form (Smith 1961, "Eigenvalues
// of a symmetric 3 x 3 matrix", CACM 4(4)).
int ek_sim_rate_fields(const ek_sim *sim, double *D, double *W, double *strain_rates);
// Per-vertex rotation field (nverts x 9 row-major, det +1): Kabsch
// (cloth.h's ek_kabsch_f64, seed 003 eqs. 21-27) over each vertex's
// one-ring (itself and the vertices sharing an element with it), rest
// positions to current ones, unweighted. The one-rings are built on the
// first call (the sim is not thread-safe during it).
int ek_sim_vertex_rotations(const ek_sim *sim, double *R);
// Number of vertices held by a boundary condition right now.
size_t ek_sim_constrained_count(const ek_sim *sim);

#ifdef __cplusplus
}
#endif
#endif
