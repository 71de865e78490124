// Internal: the body interface (not installed). A body is the elastic
// part of a simulation: its elements, its rest shape and the operations the
// core (sim_core.c) and the integrators (explicit.c, implicit.c, xpbd.c)
// call on it. The core and the integrators never see the element kind:
// tets (body_tets.c, the FVM force of fvm.h) and triangles (body_cloth.c,
// the cloth of cloth_force.h) each fill one sim_body_ops table, as HOBAK's
// integrators take a mesh and a material and never see the element kind.
// sim/README.md says how to add a body and what each operation guarantees.
//
// Every operation is deterministic: the same inputs give the same bits at
// any thread count (the kernels it calls are; see their headers). The
// operations that fail return 0 or a negative code, with the message in
// sim->error (sim_fail) unless their comment says otherwise.
#ifndef EK_SIM_BODY_H
#define EK_SIM_BODY_H

#include <ek/hessian.h>
#include <ek/sim/sim.h>
#include <stddef.h>
#include <stdint.h>

typedef struct sim_body_ops sim_body_ops;

// What the core reads of a body without calling it.
typedef struct {
  const sim_body_ops *ops;
  void *data;           // the kind's own state (body_tets.c, body_cloth.c)
  size_t nv, ne;        // vertices, elements
  int corners;          // vertices per element: 4 tets, 3 triangles
  const int32_t *elems; // ne x corners: the incidence the one-rings are built from
  const double *X;      // nv x 3: rest positions
  // Lumped masses: m_i = density * mass_scale * lumped[i]; lumped is the
  // vertex's share of its elements' volume (tets, Teran 2003 sec. 4: a
  // quarter of each) or area (triangles: a third of each), mass_scale 1 or
  // the sheet's thickness.
  const double *lumped;
  double mass_scale;
  // What programs read through the public API (sim.h: ek_sim_elements,
  // ek_sim_fields, ek_sim_force_phases), so that they never test the kind:
  // its name ("tets"), the incidence in the caller's order (the frames'
  // topology; elems above may be the body's own order), whether `fields`
  // fills smax, and the force's phase split (names, and where each phase's
  // seconds sit in ek_sim_times: offsetof).
  const char *kind;
  const int32_t *caller_elems;
  int has_smax;
  int oriented; // J <= 0 is an inverted element (tets; not triangles in 3D)
  int nphases;
  const char *phase_names[EK_SIM_MAX_PHASES];
  size_t phase_times[EK_SIM_MAX_PHASES];
} sim_body;

// The implicit integrator's view of a body's Hessian (hessian_create).
typedef struct {
  int f32;            // products in float: hessian_apply reads p32, writes q32
  int residual_merit; // the energy is not the potential of the gradient
                      // (clamped models): the line search on the residual
  int split_timing;   // the gradient pass caches eigensystems: with phase
                      // timing, time a pass without the cache (sim.h)
} sim_hessian_info;

struct sim_body_ops {
  void (*destroy)(sim_body *body);
  // One line for the run's header: counts and model, as "1296 tets, 8
  // colours, model stvk" (ek_sim_describe).
  void (*describe)(const ek_sim *sim, char *buf, size_t len);

  // ---- Core ----
  // The CFL quantities (sim.h, ek_sim_cfl_dt): the smallest element length
  // h_min, the wave speed c, and the explicit step's limit.
  void (*cfl)(const ek_sim *sim, double *h_min, double *wave_speed, double *cfl_dt);
  // Once the state is set (creation): per-element state the forces keep
  // (rotations), R^n, and sim->elastic_rest, the energy at the rest shape.
  // The core puts the scene's path before the message.
  int (*start)(ek_sim *sim);
  // At the start of each step, from sim->x (R^n for corotated linear).
  // NULL: nothing to do.
  int (*begin_step)(ek_sim *sim);
  // ek_sim_set_state replaced sim->x, sim->v: restart what start built from
  // the old state.
  int (*set_state)(ek_sim *sim);
  // The force kernel in the scene's precision: f64 = f(x64) when x32 is
  // NULL, else f32 = f(x32). The core (sim_forces) converts, times the
  // call and names a failure; with sim->time_phases the body adds its
  // kernel's phase split to sim->times. 0, or the kernel's code with the
  // message in ek_last_error.
  int (*forces)(ek_sim *sim, const double *x64, const float *x32, double *f64, float *f32);
  const char *force_kernel; // the kernel in messages: "FVM", "cloth"
  // The force at `vertex` is not finite though x is: the message naming
  // the cause (inverted elements, overflow); hint ends it. Returns
  // EK_SIM_EINVERTED or EK_EINVAL.
  int (*bad_force)(ek_sim *sim, const double *x, size_t vertex, const char *hint);
  // Elements of x (sim->x when NULL) that are inverted (0 where elements
  // have no orientation, e.g. triangles in 3D), and the first of them with
  // its J = V / V0 (*first, *first_J, either may be NULL; untouched when
  // none), for the messages: the same pass as the count.
  size_t (*inverted_count)(const ek_sim *sim, const double *x, size_t *first, double *first_J);
  // Elastic energy E(x) (sim->elastic_rest is subtracted by the caller).
  double (*energy)(const ek_sim *sim, const double *x);
  // Volume (tets) or area (triangles) of sim->x; NAN when it fails.
  double (*measure)(const ek_sim *sim);
  // Per-element fields of sim->x for the frames (sim.h, ek_sim_tet_fields,
  // ek_sim_cloth_fields); any may be NULL; smax only for kinds that have
  // it (NULL else). psi is measured from the rest shape.
  int (*fields)(const ek_sim *sim, double *J, double *smax, double *smin, double *psi);
  // Velocity gradient fields (sim.h, ek_sim_rate_fields); D is not NULL.
  int (*rate_fields)(const ek_sim *sim, double *D, double *W, double *rates);

  // ---- Implicit integrator (implicit.c) ----
  // The Hessian context; NULL with the message in sim->error.
  void *(*hessian_create)(ek_sim *sim, sim_hessian_info *info);
  // The Hessian context of a part of the elements only, elems[0..count)
  // (indices into the body's order), for one MPI rank of the implicit loop
  // (sim/README.md "MPI"): gradient, energy, products, diagonal blocks,
  // pattern and assembled values are then those elements' share, over all
  // the body's vertices (the pattern's rows and columns are the body's
  // vertex numbering). NULL in the table: the body cannot be split (the
  // loop refuses MPI runs); NULL returned: the message in sim->error.
  void *(*hessian_create_part)(ek_sim *sim, sim_hessian_info *info, const size_t *elems,
                               size_t count);
  void (*hessian_destroy)(void *h);
  // At the start of each step (NULL: nothing to do).
  int (*hessian_begin_step)(ek_sim *sim, void *h);
  // grad E(x) into grad and E(x) into *E (+inf outside the model's
  // domain); the products and blocks below are then taken at x. cache 0:
  // a timing pass (split_timing). < 0 with the message in ek_last_error.
  int (*gradient)(const ek_sim *sim, void *h, const double *x, double *grad, double *E, int cache);
  // q = K p (f64) or q32 = K p32 (info.f32); < 0 as gradient.
  int (*hessian_apply)(void *h, const double *p, double *q, const float *p32, float *q32);
  // The same product in parts (hessian.h, ek_fvm_hessian_apply_part), for
  // a caller running its own parallel loop (implicit.c's CG): the number of
  // parts (0 or NULL: hessian_apply only) and in *parallel whether
  // hessian_apply would run on more than one thread; part i's products,
  // then rows [v0, v1) of q (or q32): hessian_apply's bits.
  int (*hessian_apply_parts)(void *h, int *parallel);
  int (*hessian_apply_part)(void *h, int part, const double *p, const float *p32);
  void (*hessian_apply_rows)(void *h, size_t v0, size_t v1, double *q, float *q32);
  // K's 3x3 diagonal blocks, 6 per vertex (xx, xy, xz, yy, yz, zz); < 0
  // as gradient.
  int (*hessian_diagonal)(void *h, double *blocks);
  // The assembled K at the last caching gradient (hessian.h,
  // ek_fvm_hessian_pattern / _assemble): its pattern (the body's, kept)
  // and its values (pattern.nnz, same bits at any thread count); < 0 as
  // gradient. NULL: the body has no assembled Hessian (the implicit loop's
  // "amg" and "direct" linear solvers refuse it).
  int (*hessian_pattern)(void *h, ek_csr_pattern *pattern);
  int (*hessian_assemble)(void *h, double *values);

  // ---- XPBD integrator (xpbd.c) ----
  // The constraints for Young's modulus `young` and the scene's xpbd knobs
  // (checked here, message in sim->error); *f32: sweeps on float
  // displacements from a float base (x_base, xf) instead of the double x.
  void *(*xpbd_create)(ek_sim *sim, double young, int *f32);
  void (*xpbd_destroy)(void *c);
  int (*xpbd_begin)(void *c, const double *w, double h);
  // n sweeps (xpbd.h: ek_xpbd_iterate_*); < 0 with ek_last_error.
  int (*xpbd_iterate)(void *c, const float *x_base, float *xf, double *x, int n);
  int (*xpbd_residual)(const void *c, const float *x_base, const float *xf, const double *x,
                       double *residual, double *cmax);
  // Seconds of the sweep's phases (xpbd.h: ek_xpbd_profile_*); NULL: none.
  int (*xpbd_profile)(void *c, const float *x_base, const float *xf, const double *x,
                      double seconds[3]);
  size_t (*xpbd_count)(const void *c);
};

extern const sim_body_ops sim_body_tets;
extern const sim_body_ops sim_body_triangles;

// The bodies of a scene: NULL (out of memory) or the body; the mesh is
// the caller's and outlives it.
// mat is the scene's material, checked (ek_material_check).
sim_body *sim_body_tets_create(const ek_scene *scene, const ek_material *mat, const ek_mesh *mesh);
sim_body *sim_body_triangles_create(const ek_scene *scene, const ek_material *mat,
                                    const ek_trimesh *mesh);

#endif
