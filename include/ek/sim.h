// ek simulation: scene files, the simulation loop and HDF5 frames.
//
// A scene (JSON, parsed by ek_scene_load) names a mesh (file or box
// generator), a material, the precision of the force kernel, the SVD knobs,
// boundary conditions, gravity, a ground plane, damping, the time step, the
// integrator and the output. Axes: z is up; the ground is the plane
// z = height.
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
//
// Scene file keys (required ones marked *; every other key is an error):
//   description   free text
//   mesh*         {"file": PATH} (TetGen/Gmsh, relative to the scene file;
//                 "fix_orientation": bool) or {"box": [nx,ny,nz],
//                 "size": [lx,ly,lz]} (ek_mesh_box, origin at 0);
//                 cloth (triangles, trimesh.h): {"file": PATH.obj} or
//                 {"file": PATH.msh, "kind": "triangles"} or {"grid":
//                 [nx,ny], "size": [lx,ly], "plane": "xy" | "xz"}
//   cloth         triangle meshes only: {"thickness"*: h (m),
//                 "bending_stiffness": k_b (N m, default E h^3 / (12 (1 -
//                 nu^2)))}; material.model stvk or arap (membranes,
//                 cloth_force.h) with mu h and the plane-stress
//                 2 mu lambda / (lambda + 2 mu) h per unit area, areal
//                 density = density h
//   initial       {"scale": [3], "translate": [3], "velocity": [3]}
//   material*     {"model": NAME, "E", "nu" | "mu", "lambda", "density"*,
//                 "clamp"}; NAME one of linear, stvk, corotated_linear,
//                 fixed_corotated, arap, psi_r, neo_hookean,
//                 stable_neo_hookean (or ek_model_name's short names)
//   precision     "f32" | "f64" (default f64)
//   isa           "auto" | "scalar" | "avx2" | "avx512" (all kernels)
//   scatter       "auto" | "colored" | "thread_buffers" | "gather" | "atomic"
//   svd           {"sweeps": 0..8, "rsqrt": "default"|"exact"|"approximate",
//                 "refine": 0..3 (exact one-sided sweeps; 0 = none, i.e.
//                 McAdams et al. 2011 as published; absent = default)}
//   polar         "svd" (default) | "warm": how fixed corotated and ARAP
//                 take the rotation of F in the force (and corotated
//                 linear its R^n refresh): the SVD polar, or the
//                 warm-started polar (polar.h) from each tet's rotation of
//                 the step before, kept per element (the SVD polar at the
//                 first step). The implicit loop's gradient and Hessian
//                 still take the SVD (they need the singular values);
//                 other models, and a clamp > 0, ignore the key.
//   boundary      [{"type": "pin"|"twist"|"stretch", "region": {"min": [3],
//                 "max": [3]}, twist: "axis", "center", "rate"; stretch:
//                 "velocity"; both: "until", "release"}]
//   gravity       [3], m/s^2 (default 0)
//   ground        {"height": z}
//   damping       c >= 0, 1/s (default 0)
//   dt*, steps*   seconds, count
//   integrator    {"type": "explicit"} (default) or {"type": "implicit",
//                 "newton_tol", "max_newton", "cg_tol", "max_cg",
//                 "preconditioner": "jacobi" | "block_jacobi",
//                 "projection": "clamp" | "abs"}
//                 (ek_scene_implicit: meanings and defaults) or
//                 {"type": "xpbd", "iterations", "substeps", "solver":
//                 "gauss_seidel" | "jacobi", "elements": "tets" |
//                 "clusters"} (ek_scene_xpbd)
//   output        {"file": PATH.h5 (relative to the working directory),
//                 "every": N (default 1)}
//
// Frames (ek_frames_*): one HDF5 file with the rest mesh once and, per
// output frame, positions and per-tet fields (J, smallest singular value,
// energy density measured from the rest shape) and the time, committed
// whole every frame, plus an XDMF file beside it (same name, extension
// .xmf) so ParaView and meshio open the time series.
#ifndef EK_SIM_H
#define EK_SIM_H

#include <signal.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "cloth_force.h"
#include "core.h"
#include "fvm.h"
#include "hessian.h"
#include "material.h"
#include "mesh.h"
#include "svd3.h"
#include "trimesh.h"
#include "xpbd.h"

#ifdef __cplusplus
extern "C" {
#endif

#define EK_SCENE_PATH_MAX 1024
#define EK_SCENE_MAX_BC 16

// Invariants checked by tests/test_sim_explicit.c (named here, never
// literals in test bodies).
//
// Undamped, unpinned, gravity-free body, 1000 steps at dt = 0.02 h_min / c:
// max_t |E(t) - E(0)| / E(0), E = kinetic + elastic (from the rest shape,
// see ek_sim_energy).
// Symplectic Euler conserves a modified energy; for a harmonic mode of
// frequency omega the difference is (dt/2) omega^2 |x v| <= (dt omega / 2) E
// (Hairer, Lubich, Wanner, Geometric Numerical Integration, sec. IX.3), so
// the error is bounded, not drifting. With the CFL estimate of the fastest
// mode, omega_max = 2 c / h_min (dt_crit = 2 / omega_max = h_min / c), the
// bound is dt c / h_min = 0.02.
#define EK_SIM_ENERGY_TOL 2e-2
#define EK_SIM_ENERGY_DT_CFL 0.02
// Same run: |sum m v(t) - sum m v(0)| / sum m |v|(0 or t, the larger):
// internal forces sum to zero per tet, so momentum is kept to rounding.
#define EK_SIM_MOMENTUM_TOL_F64 1e-10
// Cantilever under gravity, damped to rest: |delta - delta_EB| / delta_EB,
// delta_EB = q L^4 / (8 E I) (Euler-Bernoulli, uniform load q).
#define EK_SIM_CANTILEVER_TOL 0.05
// Crushed and released cube (invertible model): |V - V0| / V0 at rest.
#define EK_SIM_VOLUME_TOL 0.01
// Checked by tests/test_sim_core.c: the frames' energy density
// (ek_sim_tet_fields, measured from the rest shape) against rounding. At
// rest, max_e |psi_e| / (mu + |lambda|) (a stress scale); after steps,
// |sum_e V0_e psi_e - elastic| / sum_e V0_e (|Psi(F_e)| + |Psi(F_rest,e)|)
// (the cancellation-free size of the sum), elastic from ek_sim_energy. Both
// sides evaluate the same Psi per tet; only the order of the sums differs.
#define EK_SIM_ENERGY_FIELD_TOL 1e-12

// Return code of ek_sim_step when an element left the model's domain (J <= 0
// for neo-Hookean without clamp): the step is not applied, the message names
// the step, the number of inverted tets and the first one.
#define EK_SIM_EINVERTED (-10)
// Return code of ek_sim_step when the stop flag (ek_sim_set_stop_flag) was
// seen inside the step: the step is not applied.
#define EK_SIM_ESTOPPED (-11)
// XPBD sweeps run between two looks at the stop flag (a slice of one
// substep's iterations; the sweeps are the same either way).
#define EK_SIM_STOP_SWEEPS 64

// ---------------------------------------------------------------- scenes

// Time integrators, the scene's "integrator": {"type": NAME}.
typedef enum {
  EK_INTEGRATOR_EXPLICIT = 0, // "explicit": symplectic Euler (sim/explicit.c)
  EK_INTEGRATOR_IMPLICIT,     // "implicit": backward Euler by Newton + PCG (sim/implicit.c)
  EK_INTEGRATOR_XPBD,         // "xpbd": XPBD, seed 001's constraint (sim/xpbd.c)
  EK_INTEGRATOR_COUNT
} ek_integrator_type;

// Preconditioners of the implicit loop's conjugate gradient.
typedef enum {
  EK_PRECOND_BLOCK_JACOBI = 0, // "block_jacobi": the inverse 3x3 vertex blocks
  EK_PRECOND_JACOBI,           // "jacobi": the inverse diagonal
} ek_preconditioner;

// The implicit integrator's knobs, the scene's "integrator": {"type":
// "implicit", ...} (defaults in brackets). Each step minimises
//   Phi(x) = 1/(2 dt^2) |x - x~|_M^2 + E(x) - x.M g + c/(2 dt) |x - x_n|_M^2,
//   x~ = x_n + dt v_n, over the free vertices (backward Euler as an
//   optimisation problem: Martin et al. 2011; Gast et al. 2015), then
//   v_{n+1} = (x_{n+1} - x_n) / dt.
// newton_tol [1e-6]: Newton stops when the residual
//     r = dt^2 sqrt(sum_free |grad_i Phi|^2 / m_i / sum_free m_i) / L
//   is at most newton_tol, L the rest mesh's bounding-box diagonal. r is
//   the mass-weighted RMS of dt^2 M^-1 grad Phi relative to the body's
//   size; as the Hessian is at least M / dt^2, it bounds the mass-weighted
//   RMS of the remaining Newton step (the position error) from above.
// max_newton [50]: iterations per step; a step that stops above
//   newton_tol is counted and reported (ek_sim_times.unconverged_steps,
//   worst_residual), not hidden; its state is still used.
// cg_tol [1e-4]: CG stops when |r_k|_{M^-1} <= cg_tol |grad Phi|_{M^-1}.
// max_cg [1000]: CG iterations per Newton iteration (the last iterate is
//   used: with x_0 = 0 every PCG iterate is a descent direction).
// preconditioner ["block_jacobi"]: or "jacobi".
// projection ["clamp"]: how element Hessians are made PSD (hessian.h,
//   ek_projection): "clamp" (negative eigenvalues to 0) or "abs" (to their
//   absolute value, Chen et al. 2024).
// Line search: on Phi (Armijo) for every model without a clamp. A clamped
// model's stress (Irving et al. 2004: P = U diag(g(sigma_hat)) V^T) is not
// the gradient of an energy where sigma is clamped, so there Phi and its
// "gradient" disagree and an Armijo test on Phi can fail for every alpha;
// for clamp > 0 the line search asks instead that the residual decrease,
// r(x + alpha dx) <= (1 - 1e-4 alpha) r(x).
typedef struct {
  double newton_tol;
  long max_newton;
  double cg_tol;
  long max_cg;
  ek_preconditioner preconditioner;
  ek_projection projection;
} ek_scene_implicit;

// The XPBD integrator's knobs, the scene's "integrator": {"type": "xpbd",
// ...} (defaults in brackets). Per substep of h = dt / substeps
// (Macklin et al. 2016, alg. 1; Macklin et al. 2019, "Small steps"):
//   x~ = x + h (v + h g) / (1 + c h), w_i = 1 / (m_i (1 + c h))
// (pinned and prescribed vertices: their position at the substep's end,
// w = 0), lambda = 0, `iterations` sweeps of the solver from x = x~, then
// v = (x - x_start) / h and the ground as in the other loops. With damping
// c = 0 this is the seed's x~ = x + h v + h^2 g; with c > 0 it is the
// incremental potential of the implicit loop (ek_scene_implicit) with M
// scaled by (1 + c h) and x~ moved, so both loops solve the same problem.
// iterations [5]: solver sweeps per substep (1..100000).
// substeps [20]: substeps per step (1..100000). Small steps beat many
//   sweeps at equal cost (Macklin et al. 2019): a bar hanging at rest
//   (tests/test_sim_xpbd.c, dt = 1/30 s) against the implicit loop is off
//   by 35% at 10 x 1 (substeps x sweeps), 0.67% at 10 x 10, 0.085% at
//   20 x 5 and 0.036% at 50 x 2; stiff bodies need more (the cantilever's
//   table in README).
// solver ["gauss_seidel"]: or "jacobi" (xpbd.h).
// elements ["tets"]: or "clusters" (one-ring shape matching, xpbd.h).
// XPBD drops the primal residual g = M (x - x~) - grad C^T lambda
// (Macklin 2016 eq. 8, the g = 0 approximation), so even fully iterated it
// lands near, not on, backward Euler; xpbd.h says why no variant keeps it.
typedef struct {
  long iterations, substeps;
  ek_xpbd_solver solver;
  ek_xpbd_elements elements;
} ek_scene_xpbd;

// The scene's "polar" key.
typedef enum { EK_POLAR_SVD = 0, EK_POLAR_WARM } ek_polar_method;

// tests/test_polar_warm.c: the cantilever and twist scenes (fixed
// corotated) with "polar": "warm" against "svd" after 300 steps. The warm
// polar's rotations are within EK_POLAR_WARM_TOL_* of the SVD's, far below
// the f32 force's own rounding, so in f32 the two runs may differ by no
// more than FACTOR x the distance between the f32 and f64 SVD runs
// (max |dx| over vertices), and in f64 by TOL x the body's length.
#define EK_POLAR_WARM_LOOP_F32_FACTOR 2
#define EK_POLAR_WARM_LOOP_TOL_F64 1e-12

typedef enum {
  EK_BC_PIN,     // held at the initial position
  EK_BC_TWIST,   // rotated about an axis at `rate` rad/s
  EK_BC_STRETCH, // moved at a constant `velocity`
} ek_bc_kind;

// A boundary condition on the vertices whose rest position lies in the
// axis-aligned box [box_min, box_max] (inclusive, with a tolerance of 1e-9
// of the mesh's bounding-box diagonal). Motions start from the initial
// positions and run while t < until; afterwards the vertices are held where
// the motion left them, or released (free) when `release` is set.
typedef struct {
  ek_bc_kind kind;
  double box_min[3], box_max[3];
  double axis[3];     // twist: unit axis direction
  double center[3];   // twist: a point on the axis
  double rate;        // twist: angular velocity, rad/s
  double velocity[3]; // stretch: m/s
  double until;       // seconds; INFINITY = for the whole run
  int release;
} ek_scene_bc;

typedef struct {
  char path[EK_SCENE_PATH_MAX]; // the scene file as given
  // Mesh: a file (resolved relative to the scene's directory), or the box
  // generator when mesh_file is empty.
  char mesh_file[EK_SCENE_PATH_MAX];
  int box_cells[3];
  double box_size[3];
  int fix_orientation;
  // Cloth: a triangle mesh (mesh.grid, an .obj, or mesh.kind "triangles"),
  // its grid (cells, size, plane "xy" | "xz"), the thickness (m) and the
  // bending stiffness k_b (N m) of the "cloth" key.
  int triangles;
  int grid_cells[2];
  double grid_size[2];
  char grid_plane[4];
  double thickness, bending_stiffness;
  // Initial state from the rest shape: scaled about the bounding-box centre,
  // then translated; uniform initial velocity.
  double init_scale[3], init_translate[3], init_velocity[3];
  // Material.
  char model_name[32];
  ek_material material;  // mu, lambda (from E, nu when given so), clamp
  double density;        // kg/m^3
  double young, poisson; // as given, NAN when mu, lambda were given
  // Kernels.
  int precision;    // 32 or 64
  ek_svd3_opts svd; // svd.isa is the scene's "isa": every kernel's target
  ek_scatter scatter;
  ek_polar_method polar; // "polar": "svd" (default) or "warm"
  // Loads and constraints.
  int nbc;
  ek_scene_bc bc[EK_SCENE_MAX_BC];
  double gravity[3];
  int has_ground;
  double ground_height;
  double damping; // c of the mass-proportional damping force -c m v, 1/s
  double dt;
  long steps;
  ek_integrator_type integrator;
  ek_scene_implicit implicit; // integrator.type "implicit" only
  ek_scene_xpbd xpbd;         // integrator.type "xpbd" only
  // Output ("" = none): frames every output_every steps (and the first).
  char output_file[EK_SCENE_PATH_MAX];
  long output_every;
} ek_scene;

// Parse a scene file. 0 on success; < 0 with err naming the file, the key
// path and the value ("scenes/beam.json: material.nu = 0.5: Poisson ratio
// must be < 0.5"). Unknown keys are errors. *scene is fully written on
// success and left unspecified on error.
int ek_scene_load(const char *path, ek_scene *scene, char *err, size_t errlen);
// Same from text in memory; `name` is used in messages, `base_dir` resolves a
// relative mesh file ("." when NULL).
int ek_scene_parse(const char *text, const char *name, const char *base_dir, ek_scene *scene,
                   char *err, size_t errlen);
// Build (generate or load) the scene's mesh. NULL with err on failure.
// A tet scene has an ek_mesh, a cloth scene (scene->triangles) an
// ek_trimesh; asking for the other kind is an error.
ek_mesh *ek_scene_mesh(const ek_scene *scene, char *err, size_t errlen);
ek_trimesh *ek_scene_trimesh(const ek_scene *scene, char *err, size_t errlen);
// "fixed_corotated" etc. <-> ek_model; NULL / -1 if unknown.
const char *ek_scene_model_name(ek_model model);
int ek_scene_model_from_name(const char *name, ek_model *model);
// "explicit" etc. and a one-line description of an integrator; NULL if
// unknown.
const char *ek_scene_integrator_name(ek_integrator_type type);
const char *ek_scene_integrator_description(ek_integrator_type type);
// Print the scene integrator's part of the per-step pipeline (ek-sim
// --explain) as lines numbered from `number`; returns the next number.
int ek_scene_integrator_explain(const ek_scene *scene, FILE *out, int number);

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
// and destroys it after the sim). NULL with err on failure.
ek_sim *ek_sim_create(const ek_scene *scene, const ek_mesh *mesh, char *err, size_t errlen);
// A cloth scene (scene->triangles) on its triangle mesh: the same loop with
// the cloth forces (cloth_force.h) in place of the FVM force.
ek_sim *ek_sim_create_cloth(const ek_scene *scene, const ek_trimesh *mesh, char *err,
                            size_t errlen);
int ek_sim_is_cloth(const ek_sim *sim);
// A condition the run goes on with, for the caller to report (the library
// prints nothing, core.h): an explicit dt above the CFL limit (set by
// ek_sim_create), the first step whose Newton loop stopped above
// newton_tol. Copies the pending warning into buf and returns buf, once;
// NULL when none is pending.
const char *ek_sim_warning(ek_sim *sim, char *buf, size_t len);
void ek_sim_destroy(ek_sim *sim);
// Advance one step with the scene's integrator. 0, EK_SIM_EINVERTED,
// EK_SIM_ESTOPPED or < 0 (message in ek_sim_last_error); on error the state
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
const char *ek_sim_last_error(const ek_sim *sim);
// Name of the integrator the sim steps with ("explicit").
const char *ek_sim_integrator_name(const ek_sim *sim);
// Tets with J <= 0 in the current state.
size_t ek_sim_inverted_count(const ek_sim *sim);
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
// ek_sim_last_error) for a non-finite entry.
int ek_sim_set_state(ek_sim *sim, const double *x, const double *v);
// The last implicit step's Newton history (all zero for other integrators).
const ek_sim_newton_trace *ek_sim_last_newton(const ek_sim *sim);
// The XPBD integrator's constraints (tets or clusters; 0 for the other
// integrators).
size_t ek_sim_xpbd_constraints(const ek_sim *sim);
// Kinetic, elastic and gravity potential energy of the current state. The
// elastic energy is measured from the rest shape, E(x) - E(X)
// (ek_fvm_energy_ex_f64; corotated linear with the current R^n), as some
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

// ---------------------------------------------------------------- frames

typedef struct ek_frames ek_frames;

// Create `path` (HDF5) and its XDMF companion and write the rest mesh.
// Refuses (NULL, err) if either exists unless `force`; even with `force`
// if either, or a scratch or swap name below, is anything but a regular
// file (a directory, device, FIFO, socket or symbolic link: the commits
// rename over these names and would replace it); or if the XDMF cannot
// name the file (its base name holds a colon, a control character,
// bytes that are not UTF-8 or a leading/trailing blank). Layout:
//   /mesh/vertices   nverts x 3 double     /mesh/tets  ntets x 4 int32
//   /frames/time     nframes double        /frames/step nframes int64
//   /frames/positions/NNNNNN               nverts x 3 double
//   /frames/J/NNNNNN, /frames/smin/NNNNNN  ntets double
//   /frames/energy_density_from_rest/NNNNNN ntets double
// with NNNNNN the frame index (0-based, at least 6 digits); every field of
// ek_frame_fields has its group; each group and mesh dataset has the string
// attributes "units" and "description", the root "ek_version" and
// "element" (docs/outputs.md lists them all). The XDMF (3.0)
// is a temporal collection of one grid per frame whose data items are
// these whole datasets, the positions also as a point vector "positions";
// it names the HDF5 file by its base name, XML-escaped. The energy density
// is the `psi` ek_frames_write is given; ek-sim writes ek_sim_tet_fields'
// (from the rest shape: 0 at rest, and it sums to the elastic energy).
// `path` is always a closed, whole HDF5 file: each frame is written into a
// scratch copy (`path`.scratch, one frame behind) that then swaps names
// with `path` atomically, so a writer killed at any moment leaves every
// frame it completed readable with plain read-only access. The XDMF is
// appended to after each commit (it may lack the last frame after a kill).
// A write that fails (a full disk) is reported and the file keeps its
// frames; with HDF5 before 1.14.1 the failed close leaves an ID that
// HDF5's own exit handler then crashes on, so a program that may hit a full
// disk calls H5dont_atexit() before its first HDF5 call (ek-sim does).
ek_frames *ek_frames_create(const char *path, int force, size_t nverts, const double *X,
                            size_t ntets, const int32_t *tets, char *err, size_t errlen);
// The same for any element kind: nodes = 4 (tets, /mesh/tets, XDMF
// Tetrahedron) or 3 (cloth triangles: /mesh/triangles, XDMF Triangle, and
// one more per-element field /frames/smax, the larger stretch; J is then
// the area ratio and smin the smaller stretch).
ek_frames *ek_frames_create_ex(const char *path, int force, size_t nverts, const double *X,
                               size_t nelems, int nodes, const int32_t *elems, char *err,
                               size_t errlen);
// Append one frame; J, smin, psi (energy density from the rest shape) may
// be NULL (written as NaN).
int ek_frames_write(ek_frames *fr, double time, long step, const double *x, const double *J,
                    const double *smin, const double *psi, char *err, size_t errlen);
// Every per-element field of a frame (any may be NULL: written as NaN):
// J, smin, psi as above; smax (triangles only, the larger stretch); the
// velocity gradient's rate of strain D and spin W (nelems x 9 row-major,
// /frames/D, /frames/W: XDMF Tensor attributes) and the principal strain
// rates (nelems x 3, /frames/strain_rates: a Vector attribute), from
// ek_sim_rate_fields.
// vertex_R: the per-vertex rotations of ek_sim_vertex_rotations (nverts x
// 9, /frames/vertex_rotation, a Node-centred Tensor in the XDMF).
typedef struct {
  const double *J, *smin, *psi, *smax, *D, *W, *strain_rates;
  const double *vertex_R;
} ek_frame_fields;
int ek_frames_write_fields(ek_frames *fr, double time, long step, const double *x,
                           const ek_frame_fields *fields, char *err, size_t errlen);
long ek_frames_count(const ek_frames *fr);
// Close the XDMF and remove the scratch copy (every frame is already in
// `path`). 0 on success.
int ek_frames_close(ek_frames *fr, char *err, size_t errlen);
// The run, as string attributes on the file's root (docs/outputs.md; the
// units and description of every dataset are written at creation). NULL
// members are not written. Call before the first frame: 0, EK_EINVAL
// (frames already written) or EK_EIO.
typedef struct {
  const char *program, *scene, *model, *precision, *integrator, *git_revision;
} ek_frames_info;
int ek_frames_set_info(ek_frames *fr, const ek_frames_info *info, char *err, size_t errlen);
// Path of the XDMF companion of an HDF5 path (".h5" replaced by ".xmf", or
// ".xmf" appended).
void ek_frames_xdmf_path(const char *h5path, char *out, size_t outlen);

#ifdef __cplusplus
}
#endif
#endif
