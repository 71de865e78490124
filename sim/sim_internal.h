// Internal: the simulation core shared by the integrators (sim/sim_core.c)
// and the integrator interface (one file per integrator: sim/explicit.c).
// Not installed.
//
// The core owns what every integrator needs: the state, lumped masses,
// boundary conditions, the ground, energies, the timing, and the body
// (body.h), whose operations give the forces in the scene's precision,
// per-element fields, the CFL estimate and the inverted-element report.
// An integrator owns one step and nothing else. ek_sim_step (core) lets
// the body begin the step from x^n (R^n for corotated linear, seed 000),
// calls the integrator's step, and only if that succeeds makes
// (x_next, v_next) the state at t_{n+1} = t_n + dt; so a failed step leaves
// the state as it was, whatever the integrator wrote.
#ifndef EK_SIM_INTERNAL_H
#define EK_SIM_INTERNAL_H

#include <ek/sim/sim.h>
#include <stdio.h>

#include "body.h"

// One time integrator. A new one is a file sim/<name>.c defining a
// `const sim_integrator sim_integrator_<name>`, an ek_integrator_type value
// in sim.h and a row in sim_integrators (sim_core.c).
typedef struct {
  const char *name;        // the scene's integrator.type
  const char *description; // one line, printed by ek-sim --explain
  // Print this integrator's part of the per-step pipeline (after the force
  // kernel lines) as lines numbered from `number`; returns the next number.
  int (*explain)(const ek_scene *scene, FILE *out, int number);
  // Called once the core is built (state, masses, boundary conditions, CFL
  // estimate): check what this integrator needs of the scene and build its
  // private data (*data may stay NULL). 0, or < 0 with the message in
  // sim->error. NULL: nothing to do.
  int (*create)(ek_sim *sim, void **data);
  // Free the private data; NULL: nothing to free.
  void (*destroy)(void *data);
  // One step from t_n = sim->t, (sim->x, sim->v), R^n refreshed: write the
  // state at t_{n+1} = t_n + dt into sim->x_next and sim->v_next, with the
  // boundary conditions and the ground applied at t_{n+1}. Calls the core
  // for forces (sim_forces, sim_check_forces). 0, or EK_SIM_EINVERTED / < 0
  // with the message in sim->error.
  int (*step)(ek_sim *sim, void *data);
} sim_integrator;

// The scene's body's CFL rule in words (body.h cfl; for --explain, which
// runs before any body exists): the one place beside the constructors
// that names the kinds (sim_core.c).
const char *sim_cfl_rule(const ek_scene *scene);

extern const sim_integrator sim_integrator_explicit;
extern const sim_integrator sim_integrator_implicit;
extern const sim_integrator sim_integrator_xpbd;
// Indexed by ek_integrator_type.
extern const sim_integrator *const sim_integrators[EK_INTEGRATOR_COUNT];

struct ek_sim {
  ek_scene scene;
  // The elastic body: a tet mesh or a cloth's triangles behind one table of
  // operations (body.h); the core and the integrators call only those.
  const sim_body *body;
  // The mesh ek_sim_create_scene built (freed with the sim), NULL when the
  // caller owns it.
  ek_mesh *own_mesh;
  ek_trimesh *own_trimesh;
  // One-rings for the per-vertex Kabsch rotations (sim/rate_fields.c),
  // built at the first ek_sim_vertex_rotations: vertex v's set is itself
  // and its neighbours, ring[ring_off[v] .. ring_off[v+1]); ring_P their
  // rest positions, ring_Q the current ones (gathered per call).
  size_t *ring_off;
  int32_t *ring;
  double *ring_P, *ring_Q;
  ek_material mat;
  size_t nv, nt;
  double *x, *v;           // nv x 3: the state at t_n
  double *x_next, *v_next; // the candidate state at t_{n+1} a step writes
  double *x0;              // initial positions, which boundary conditions move
  double *mass, *inv_mass; // lumped; inv_mass 0 for a massless vertex
  signed char *bc_of;      // per vertex: index of its boundary condition, -1 free
  double *f;               // nv x 3: the force of the last sim_forces call
  float *xf, *ff;          // f32 force path
  int time_phases;
  double t;
  long n;
  double cfl_dt, h_min, wave_speed;
  double body_size;      // the rest mesh's bounding-box diagonal
  double body_center[3]; // ... and its centre (ek_sim_check)
  double elastic_rest;   // E(X): not 0 for every model (stable neo-Hookean)
  ek_sim_times times;
  ek_sim_newton_trace newton; // filled by the implicit integrator
  const sim_integrator *integrator;
  void *integrator_data;
  // Counts ek_sim_set_state calls: what an integrator keeps from one step
  // for the next (implicit.c's last acceleration) holds within one epoch.
  unsigned long state_epoch;
  const volatile sig_atomic_t *stop_flag; // ek_sim_set_stop_flag; NULL: none
  char error[1024];      // room for a failed step's place and the check's own message
  ek_scene_pos error_at; // the scene value `error` is about (sim_fail_at); 0, 0: none
  char warning[512];     // pending, for ek_sim_warning; "" when none
  char warning_out[512]; // what ek_sim_warning returned last
};

double sim_now(void);
// Message into sim->error; returns EK_EINVAL.
int sim_fail(ek_sim *sim, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
// The same about a value of the scene (sim->scene.where.*): ek_sim_create's
// message names its FILE:LINE:COL instead of the file alone.
int sim_fail_at(ek_sim *sim, ek_scene_pos at, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
// A warning for the caller (ek_sim_warning): the library prints nothing
// itself (core.h). A pending one is kept; a second is dropped.
void sim_warn(ek_sim *sim, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
// sim->f = f(x), x nv x 3 in double, through the body's force in the
// scene's precision (f32 converts x to float and f back), with the phase
// split when sim->time_phases is set. Timed into sim->times.
int sim_forces(ek_sim *sim, const double *x);
// 0 if sim->f is finite. Otherwise the step cannot go on: EK_SIM_EINVERTED
// naming the inverted elements of x (the model is undefined there), or
// EK_EINVAL for a non-finite force with no inverted element (e.g. dt far
// above the CFL limit); message in sim->error.
int sim_check_forces(ek_sim *sim, const double *x);
// EK_SIM_ESTOPPED with the message in sim->error if the caller's stop flag
// is set (ek_sim_set_stop_flag), else 0. `where` names the point in the
// step ("XPBD substep 3 of 100000").
int sim_stop_requested(ek_sim *sim, const char *where, long i, long n);
// Vertices of [0, nverts) that none of the count x corners elements uses:
// how many, and the first (*first; untouched when none).
size_t sim_count_unused(size_t nverts, const int32_t *elems, size_t count, int corners,
                        size_t *first);
// The vertices of the scene's mesh that no element uses (ek-sim warns):
// how many, the first (0-based, the mesh's order) and the mesh's vertex
// count with them (*nverts). A triangle mesh drops them when it loads
// (mesh_tri.c); a tet mesh keeps them, massless.
size_t sim_unused_vertices(const ek_sim *sim, size_t *first, size_t *nverts);
// Those a triangle mesh dropped (mesh_tri.c), as above.
size_t sim_trimesh_dropped(const ek_trimesh *m, size_t *first);

// Position and velocity that condition b prescribes at time t to a vertex
// whose initial position is x0.
void sim_bc_state(const ek_scene_bc *b, const double x0[3], double t, double x[3], double v[3]);

// The boundary condition holding vertex i at time t, NULL if it is free then
// (a released condition lets its vertices go).
static inline const ek_scene_bc *sim_bc_at(const ek_sim *sim, size_t i, double t) {
  int b = sim->bc_of[i];
  if (b < 0)
    return NULL;
  const ek_scene_bc *bc = &sim->scene.bc[b];
  return bc->release && t >= bc->until ? NULL : bc;
}

// Friction-free ground contact of one vertex: below the plane it is put onto
// it and loses its velocity into it.
static inline void sim_ground_contact(const ek_sim *sim, double x[3], double v[3]) {
  if (sim->scene.has_ground && x[2] < sim->scene.ground_height) {
    x[2] = sim->scene.ground_height;
    if (v[2] < 0)
      v[2] = 0;
  }
}

#endif
