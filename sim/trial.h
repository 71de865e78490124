// Internal (not installed): one "trial" of a scene setting, the engine
// shared by the loop maps of the speed/accuracy study (bench/
// tradeoff_loops.c) and the scene advisor (ek-sim --advise, sim/advise.c).
//
// A trial runs a scene (a candidate setting: an edited copy of the scene)
// on its mesh for a given simulated time and returns the cost (wall time
// per simulated second), the final positions, the energy at start and end
// and whether it failed (an error or a non-finite state is a result, never
// a crash). Its deviation from another trial (the reference) is the largest
// vertex distance between their final positions over the body size (the
// rest mesh's bounding-box diagonal).
//
// A candidate is built by editing these fields of an ek_scene copy (every
// other field stays the scene's):
//   material.model, model_name, material.mu, material.lambda
//                          ek_trial_set_model (mu and lambda mapped so that
//                          every model has the scene model's small-strain
//                          stiffness, see there)
//   material.clamp         invertible evaluation (Irving et al. 2004)
//   precision              32 | 64
//   svd.sweeps, svd.refine, svd.exact_rsqrt
//   integrator, dt         the loop (explicit / implicit / xpbd) and its step
//   implicit.newton_tol, implicit.max_newton, implicit.cg_tol, implicit.max_cg,
//   implicit.linear_solver (amg, direct: a build with PETSc,
//                          ek_linear_solver_available)
//   xpbd.substeps, xpbd.iterations
// The trial itself sets steps (and dt, so that a whole number of steps
// ends at the simulated time) and never writes frames.
#ifndef EK_SIM_TRIAL_H
#define EK_SIM_TRIAL_H

#include <ek/sim/sim.h>

#ifdef __cplusplus
extern "C" {
#endif

// What a run reached, recorded when ek_trial_run is asked to monitor:
// over the states sampled (about EK_TRIAL_MONITOR_SAMPLES, evenly in steps,
// the first and the last included), per tet with F = Ds Dm^-1 from the
// current positions (double) and its SVD F = U diag(sigma) V^T:
#define EK_TRIAL_MONITOR_SAMPLES 200
typedef struct {
  double min_J;        // min det F
  double min_sigma;    // min signed singular value
  double max_strain;   // max |F^T F - I|_2 = max_i |sigma_i^2 - 1|
  double max_rotation; // max angle of R = U V^T (radians): rotation from rest
  // max angle of R_prev^T R between consecutive samples, divided by the
  // steps between them: the rotation per step (on average over a sample
  // interval)
  double max_rotation_step;
} ek_trial_monitor;

typedef struct {
  int failed;      // the run stopped: an error or a non-finite state
  char error[512]; // why, when failed
  long steps;      // steps run (asked for: all of them unless failed)
  double dt;       // the step used
  double sim_time; // simulated seconds asked for
  double wall;     // sum of the steps' wall times (s)
  // Per step wall time, median and minimum over the steps, times steps per
  // simulated second: the cost in s per simulated s (median: robust to a
  // disturbed core; minimum: the best case).
  double cost_median, cost_min;
  // Energies (ek_sim_energy, kinetic + elastic + gravity potential) at the
  // start and the end, and the relative drift (E_end - E_start) / scale,
  // scale = the larger kinetic + elastic energy of the two states (NaN when
  // both are 0). With damping the loss is part of it by design; compare a
  // setting's drift with the reference's.
  double energy_start, energy_end, energy_drift;
  size_t nverts;
  double *x; // nverts x 3, the final positions (NULL when failed)
  // The state check at the end (ek_sim_check, as ek-sim's summary): the
  // inverted elements and the extent. A blow-up (or NaN) fails the trial
  // unless the scene's allow.nonfinite; inverted elements are reported
  // here, and the advisor fails a candidate that ends with any unless the
  // scene's allow.inverted.
  ek_sim_health health;
  ek_trial_monitor monitor;
  // Frames (ek_trial_run_frames; 0 / NULL from ek_trial_run): the state
  // after steps k * steps / nframes, k = 1..nframes (equal simulated
  // times for every setting, the steps a multiple of nframes), recorded
  // outside the timed steps: positions (nframes x nverts x 3), kinetic +
  // elastic and gravity potential energy (ek_sim_energy), the smallest
  // J = det F over the tets (F from the positions in double), and the
  // start state's energies as frame "0" (kinel0, pot0).
  int nframes;
  double *frames, *frame_t, *frame_kinel, *frame_pot, *frame_min_J;
  double kinel0, pot0;
} ek_trial;

// The most steps one trial runs (ek-sim --steps takes at most the same).
#define EK_TRIAL_MAX_STEPS 1000000000L

// Run `scene` on `mesh` (a tet scene) for sim_time simulated seconds:
// steps = ceil(sim_time / scene->dt) (to 1e-9 of a step) and dt = sim_time /
// steps; more than EK_TRIAL_MAX_STEPS steps is refused (< 0, message). monitor != 0 records
// t->monitor (costs an SVD per tet per sample, outside the timed steps). Returns 0 when the trial
// ran (t->failed tells whether the simulation did), < 0 only when the trial itself could not be set
// up (out of memory; message in t->error). Free with ek_trial_free.
int ek_trial_run(const ek_scene *scene, const ek_mesh *mesh, double sim_time, int monitor,
                 ek_trial *t);
// ek_trial_run with nframes > 0 frames recorded (ek_trial, above): steps =
// nframes * ceil(sim_time / (nframes * dt)) (to 1e-9 of a step), dt =
// sim_time / steps. A run that fails keeps the frames it reached
// (t->nframes of them).
int ek_trial_run_frames(const ek_scene *scene, const ek_mesh *mesh, double sim_time, int monitor,
                        int nframes, ek_trial *t);
void ek_trial_free(ek_trial *t);

// The rest mesh's bounding-box diagonal.
double ek_trial_body_size(const ek_mesh *mesh);

// Set the scene's model to `model` with Lame parameters chosen so that its
// linearisation at F = I is the scene model's (material.h: every model
// reduces to linear elasticity at F = I with (mu', lambda') = (mu, lambda)
// except ARAP and Psi_R, (mu, 0), and stable neo-Hookean, (3 mu / 4,
// lambda - 5 mu / 8)): the small-strain stiffness is kept, so a deviation
// measures the model, not a change of material. Returns 0, or -1 with a
// reason in why (ARAP and Psi_R have no volume term: they are the same
// material only when the linearised lambda is 0; stable neo-Hookean needs
// lambda != 0).
int ek_trial_set_model(ek_scene *scene, ek_model model, char *why, size_t whylen);

// Whether a step of this setting takes an SVD (so that the SVD knobs
// matter): the explicit force for the models that need R(F) or clamped
// singular values, corotated linear's R^n refresh, the implicit loop's
// gradient pass for every model but linear; never XPBD's constraint.
int ek_trial_uses_svd(const ek_scene *scene);

// The setting as "key=value;..." (model, precision, svd, loop and its
// knobs) for tables and tradeoff points. The implicit loop's linear solver
// is named (";linear_solver=amg" / "direct") only when it is not the
// default matrix_free, so matrix-free settings keep their earlier text.
void ek_trial_setting_text(const ek_scene *scene, char *out, size_t outlen);

#ifdef __cplusplus
}
#endif
#endif
