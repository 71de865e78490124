// ek simulation library (libek_sim, ek::sim): scene files.
//
// A scene (JSON, parsed by ek_scene_load) names a mesh (file or box
// generator), a material, the precision of the force kernel, the SVD knobs,
// boundary conditions, gravity, a ground plane, damping, the time step, the
// integrator and the output. Axes: z is up; the ground is the plane
// z = height.
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
//                 "projection": "clamp" | "abs",
//                 "linear_solver": "matrix_free" | "amg" | "direct"}
//                 (ek_scene_implicit: meanings and defaults) or
//                 {"type": "xpbd", "iterations", "substeps", "solver":
//                 "gauss_seidel" | "jacobi", "elements": "tets" |
//                 "clusters"} (ek_scene_xpbd)
//   output        {"file": PATH.h5 (relative to the working directory; its
//                 XDMF goes beside it as PATH.xmf, so a PATH ending in .xmf
//                 is refused), "every": N (default 1)}
//   allow         {"inverted": bool, "nonfinite": bool} (default false):
//                 what the run may end in and still succeed. ek-sim checks
//                 the state at every frame time (ek_sim_check) and fails
//                 (sim/cli.h: exit 3) when a frame holds NaN or inf or the
//                 positions blew up (EK_SIM_BLOWUP_EXTENT), and (exit 4)
//                 when the last frame holds inverted elements (J <= 0).
//                 "inverted": true declares a scene that studies inversion
//                 (say so in its description); "nonfinite": true one that
//                 studies a failure. Either way the summary reports it.
//   advise        {"reference_dt": s} (default none): ek-sim --advise takes
//                 the scene's model in the explicit loop in f64 at this
//                 step as its reference, trusted as converged (no
//                 refinement; sim/advise.h), e.g. a step the scene's author
//                 checked by halving. Without it the advisor refines one.
#ifndef EK_SIM_SCENE_H
#define EK_SIM_SCENE_H

#include <stddef.h>
#include <stdio.h>

#include <ek/core.h>
#include <ek/fvm.h>
#include <ek/hessian.h>
#include <ek/material.h>
#include <ek/svd3.h>
#include <ek/xpbd.h>

#include "mesh.h"
#include "trimesh.h"

#ifdef __cplusplus
extern "C" {
#endif

#define EK_SCENE_PATH_MAX 1024
#define EK_SCENE_MAX_BC 16

// ---------------------------------------------------------------- scenes

// Time integrators, the scene's "integrator": {"type": NAME}.
typedef enum {
  EK_INTEGRATOR_EXPLICIT = 0, // "explicit": symplectic Euler (sim/explicit.c)
  EK_INTEGRATOR_IMPLICIT,     // "implicit": backward Euler by Newton + PCG (sim/implicit.c)
  EK_INTEGRATOR_XPBD,         // "xpbd": XPBD, material stvk or snh (sim/xpbd.c, xpbd.h)
  EK_INTEGRATOR_COUNT
} ek_integrator_type;

// Preconditioners of the implicit loop's conjugate gradient.
typedef enum {
  EK_PRECOND_BLOCK_JACOBI = 0, // "block_jacobi": the inverse 3x3 vertex blocks
  EK_PRECOND_JACOBI,           // "jacobi": the inverse diagonal
} ek_preconditioner;

// The implicit loop's linear solver for each Newton system.
typedef enum {
  EK_LINSOLVE_MATRIX_FREE = 0, // "matrix_free": PCG on the Hessian products (no matrix)
  EK_LINSOLVE_AMG,             // "amg": PETSc KSP CG + PCGAMG on the assembled matrix
  EK_LINSOLVE_DIRECT,          // "direct": PETSc sparse Cholesky of the assembled matrix
  EK_LINSOLVE_COUNT
} ek_linear_solver;

// "matrix_free", "amg", "direct"; "invalid" for others.
const char *ek_linear_solver_name(ek_linear_solver s);
// 1 if this build runs the solver (amg and direct: built with PETSc).
int ek_linear_solver_available(ek_linear_solver s);

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
//   The start point is accepted with no iteration only when grad Phi is
//   exactly 0 there; otherwise at least one iteration runs before the test
//   (r bounds an absolute error: a body moving less than newton_tol L per
//   step would otherwise never feel its forces; sim/implicit.c).
// max_newton [50]: iterations per step; a step that stops above
//   newton_tol is counted and reported (ek_sim_times.unconverged_steps,
//   worst_residual), not hidden; its state is still used, unless it
//   turns the body inside out (signed volume > 0 before, <= 0 after): that
//   step fails with EK_SIM_EUNCONVERGED (sim.h) and is not applied.
// cg_tol [1e-4]: CG stops when |r_k|_{M^-1} <= cg_tol |grad Phi|_{M^-1}.
// max_cg [1000]: CG iterations per Newton iteration (the last iterate is
//   used: with x_0 = 0 every PCG iterate is a descent direction).
// preconditioner ["block_jacobi"]: or "jacobi".
// projection ["clamp"]: how element Hessians are made PSD (hessian.h,
//   ek_projection): "clamp" (negative eigenvalues to 0) or "abs" (to their
//   absolute value, Chen et al. 2024).
// linear_solver ["matrix_free"]: how each Newton system is solved:
//   "matrix_free": the PCG above on the Hessian products (always built;
//     what runs without PETSc);
//   "amg": PETSc's CG (KSPCG) preconditioned by smoothed-aggregation
//     algebraic multigrid (PCGAMG) on the assembled matrix M (1 + c dt) /
//     dt^2 + K (hessian.h, ek_fvm_hessian_assemble; held dofs as identity
//     rows and columns), with the six rigid-body modes of the current
//     positions as the near-null space (MatNullSpaceCreateRigidBody),
//     one damped Jacobi sweep per level, the hierarchy kept across
//     Newton matrices while CG's iterations stay within 2x + 5 of those
//     after its last rebuild (sim/implicit_petsc.c);
//     stops at |r|_2 <= cg_tol |b|_2 (unpreconditioned), max_cg;
//   "direct": PETSc's sparse Cholesky (CHOLMOD, else MUMPS) of the same
//     matrix, for small bodies: one factorisation per Newton iteration.
//   Tets only; "amg" and "direct" need a build with PETSc (CMake found
//   pkg-config's PETSc; the scene is refused otherwise). The default stays
//   "matrix_free": the shipped scenes keep their bits (see sim/README.md
//   for the measured iterations and times of each).
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
  ek_linear_solver linear_solver;
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

// A place in the scene file: line and column (from 1) of a value; 0, 0
// when unknown (a scene built in code, or the key absent).
typedef struct {
  int line, col;
} ek_scene_pos;

// Where the values that checks after parsing may refuse stand in the file
// (ek_sim_create: a region that holds no vertex, a model XPBD cannot take;
// ek-sim: an ISA the CPU lacks, a box beyond the machine's memory; a mesh
// file that does not load), so that those messages too name FILE:LINE:COL
// (ek_scene_at).
typedef struct {
  ek_scene_pos mesh;     // mesh.file, mesh.box or mesh.grid, whichever is given
  ek_scene_pos material; // the material object
  ek_scene_pos model;    // material.model
  ek_scene_pos isa;
  ek_scene_pos region[EK_SCENE_MAX_BC]; // boundary[i].region
  ek_scene_pos dt;
  ek_scene_pos integrator;                 // the integrator object
  ek_scene_pos solver, elements, substeps; // integrator.solver, .elements, .substeps (xpbd)
  ek_scene_pos linear_solver;              // integrator.linear_solver (implicit)
  ek_scene_pos output_file;                // output.file
  ek_scene_pos reference_dt;               // advise.reference_dt
} ek_scene_where;

typedef struct {
  char path[EK_SCENE_PATH_MAX]; // the scene file as given
  ek_scene_where where;         // places of values in the file, for later messages
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
  // "allow": the run may end with inverted elements (the scene studies
  // inversion), frames may hold NaN / inf or blown-up positions.
  int allow_inverted, allow_nonfinite;
  // "advise": {"reference_dt": s}: ek-sim --advise's trusted reference
  // step (0: none, the advisor refines its own).
  double advise_reference_dt;
} ek_scene;

// Parse a scene file. 0 on success; < 0 with ek_last_error naming the file,
// the line and column of the value, the key path and the value
// ("scenes/beam.json:4:52: material.nu = 0.5: Poisson ratio must be < 0.5";
// an unknown key is placed at the key, a missing one at the '{' of the
// object it belongs in). Unknown keys are errors. Text that is not JSON is
// placed at the first byte that is not ("invalid JSON near ...: expected
// ..."), or named "unexpected end of file" with what is left open. *scene
// is fully written on success and left unspecified on error. Checks made
// later (ek_sim_create, ek_scene_mesh, ek-sim) name the value's place too
// (scene->where, ek_scene_at): "scene.json:9:30: boundary[1].region = ...:
// holds no vertex of the mesh".
int ek_scene_load(const char *path, ek_scene *scene);
// Same from text in memory; `name` is used in messages, `base_dir` resolves a
// relative mesh file ("." when NULL).
int ek_scene_parse(const char *text, const char *name, const char *base_dir, ek_scene *scene);
// Build (generate or load) the scene's mesh. NULL on failure (message in
// ek_last_error: for a mesh file, "SCENE:LINE:COL: mesh.file: " and the
// mesh reader's "MESH:LINE: ...").
// A tet scene has an ek_mesh, a cloth scene (scene->triangles) an
// ek_trimesh; asking for the other kind is an error.
ek_mesh *ek_scene_mesh(const ek_scene *scene);
ek_trimesh *ek_scene_trimesh(const ek_scene *scene);
// "FILE:LINE:COL" of a value of the scene (scene->where.*) into buf, or
// "FILE" when its place is unknown; returns buf. EK_SCENE_AT_MAX bytes hold
// any.
#define EK_SCENE_AT_MAX (EK_SCENE_PATH_MAX + 32)
const char *ek_scene_at(const ek_scene *scene, ek_scene_pos pos, char *buf, size_t len);
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

#ifdef __cplusplus
}
#endif
#endif
