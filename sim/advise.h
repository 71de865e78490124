// Internal (not installed): the scene advisor behind ek-sim --advise.
//
// Runs a tet scene's first S simulated seconds with each candidate setting
// (trial.h: models valid for what the scene reaches, precision, SVD sweeps,
// the loop, its step and its iterations), measures each one against a
// converged reference over the whole run, checks that it is physical, times
// it repeatedly and picks by a rule that is stable under the timing spread.
//
// The reference (issue 26): the scene's model in the explicit loop in f64
// (the SVD at its f64 default, within 1e-12 of LAPACK, svd3.h; the SVD
// polar), at dt_0 = the smaller of the scene's explicit step and half the
// guaranteed stability bound (ek_sim_cfl_dt), then refined: dt halved
// until two successive runs differ (the deviation below) by at most tol /
// 10, at most EK_ADVISE_MAX_REFINE halvings and opts.ref_budget seconds of
// wall time; the last run is the reference. Every loop converges to the
// same motion as dt -> 0 (explicit: symplectic Euler; implicit: backward
// Euler, O(dt) damping; XPBD: Macklin et al. 2019, substeps -> implicit),
// so the explicit loop's limit is the scene's answer; the table prints the
// successive changes and whether the last one met tol / 10. The explicit
// loop's error being first order in dt, Richardson's extrapolation 2 x_k -
// x_(k-1) of two successive runs removes its leading term (Hairer, Norsett
// and Wanner, Solving ODEs I, sec. II.9); when two successive
// extrapolations differ by at most tol / 10 (and the runs themselves do
// not), the last extrapolation is the reference (row 1, not a setting one
// can run: never the pick). Every refinement run is a row of the table (a
// user's "smaller explicit step"), measured against the reference; when
// the finest run still misses tol by e, explicit candidates at 0.7 dt tol /
// e (the first-order prediction; f64 and f32) are added. A scene may
// state a trusted reference instead ("advise": {"reference_dt": s},
// scene.h): one explicit f64 run at that step, not refined.
//
// The deviation of a candidate: over the nframes common frames (equal
// simulated times, trial.h's ek_trial_run_frames), the worst frame's
// largest vertex distance from the reference's positions, divided by
// scale = min(body size, the reference's largest vertex displacement from
// rest over the run) (the body size when the reference does not move).
// Holding every vertex still deviates by the reference's largest
// displacement: >= 1 by construction, so with tol < 1 it never passes, nor
// does a run that damps the motion away (issue 26: a size-relative final
// distance passed both on a vibrating cube).
//
// The checks: a candidate that fails one is a FAILURE with its reason, not
// "over tol": the trial failed (an error, NaN/inf, a blow-up past
// EK_SIM_BLOWUP_EXTENT); an inverted element (J <= 0) at a frame, unless
// the scene's allow.inverted; a flattened element (J below EK_ADVISE_FLAT_J
// times min(1, the reference's smallest J)); a run-away (a vertex further
// from rest than EK_ADVISE_RUNAWAY times the reference's largest
// displacement plus one body size); an energy drift (at some frame the
// total energy differs from the reference's by more than
// EK_ADVISE_ENERGY_MAX of the reference's energy scale, max over frames of
// kinetic + elastic + |gravity potential change|).
//
// Candidates, per valid model (Lame parameters mapped to the scene model's
// small-strain stiffness, ek_trial_set_model), in f64 and f32: the scene's
// loop with its own knobs; where the step takes an SVD, two cheaper SVD
// settings (McAdams et al. 2011 as published: 4 sweeps, approximate rsqrt,
// no refinement; and 2 sweeps, no refinement). For the scene's model also
// the knobs a user would try: explicit dt = 0.5, 0.9, 1.5, 2, 3 x the
// guaranteed bound; implicit dt = the scene's / 2 and / 4, 1/60, 1/120 s,
// newton_tol 1e-4, cg_tol 1e-2, one Newton iteration per step (Baraff and
// Witkin 1998); XPBD substeps x {1/2, 1, 2, 4} times iterations x {1/2, 1,
// 2}. And the other loops in the scene's precision: explicit at 0.5 and 0.9
// x the bound, implicit at 1/60 s (or the frame step) and 1/240 s, XPBD (StVK and
// stable neo-Hookean) at its default knobs and 4x the substeps.
// The solver axis (issue 24): every implicit candidate of the scene's model
// at the scene's own knobs (an implicit scene: in f64 and f32; otherwise
// the implicit row at the frame step) is also run with each other linear
// solver this build has (integrator.linear_solver: matrix_free, and with
// PETSc amg and direct, scene.h), timed and measured like every row; its
// setting text names the solver (";linear_solver=amg"; matrix_free rows
// name none). The table's "solvers" line lists the solvers tried and those
// skipped (a build without PETSc).
//
// Costs: every candidate's first run gives one cost (median step wall time
// x steps per simulated second); those within tol run opts.rounds - 1 more
// times, interleaved (round by round over the candidates, alternating the
// order), and their cost is the median over the rounds with the min and
// max as its interval. The pick rule (ek_advice_pick): among the
// candidates that pass (no check failed, deviation <= tol), take the one
// with the cheapest median; every passing candidate whose cost interval
// overlaps that one's is tied with it; of the tied, the smallest deviation
// wins, then the cheaper median, then the earlier row.
#ifndef EK_SIM_ADVISE_H
#define EK_SIM_ADVISE_H

#include "trial.h"

#include <stdio.h>

#ifdef __cplusplus
extern "C" {
#endif

// Defaults of --tol (a fraction of the scale above, < 1) and --time
// (simulated seconds; the scene's duration when that is shorter).
#define EK_ADVISE_TOL_DEFAULT 0.01
#define EK_ADVISE_TIME_DEFAULT 0.5
// The reference's refinement (above) and the checks' bounds.
#define EK_ADVISE_MAX_REFINE 6
#define EK_ADVISE_REF_BUDGET 120.0
#define EK_ADVISE_ROUNDS 3
#define EK_ADVISE_MAX_FRAMES 20
#define EK_ADVISE_FLAT_J 0.1
#define EK_ADVISE_RUNAWAY 10.0
#define EK_ADVISE_ENERGY_MAX 0.1

// Validity of the models for what the reference run reached (trial.h's
// monitor), the rules of advise.c's model_excluded:
// Small strain: |F^T F - I|_2 <= EK_ADVISE_SMALL_STRAIN, i.e. Green strain
// E = (F^T F - I) / 2 at most 1%. Linear elasticity replaces E by
// e = sym(grad u), dropping grad u^T grad u / 2 (Bonet and Wood 2008,
// Nonlinear Continuum Mechanics for FEA, sec. 4.2-4.3), which relative to
// e is about |grad u| / 2: at most ~1% of the stress here. A rotation by
// theta shows up in e as a ghost strain of 1 - cos theta (linear elasticity
// is not rotation invariant: Sifakis and Barbic 2012, FEM Simulation of 3D
// Deformable Solids, sec. 3.2; Muller et al. 2002, sec. 1), held to the
// same 1% (theta <= 0.14 rad).
#define EK_ADVISE_SMALL_STRAIN 0.02

typedef struct {
  double tol;        // X: largest deviation accepted (above), 0 <= X < 1
  double sim_time;   // S: simulated seconds per candidate, from the scene's dt
                     // (one step) to EK_TRIAL_MAX_STEPS steps of it
  int rounds;        // timing rounds of the candidates within tol (>= 1; 0:
                     // EK_ADVISE_ROUNDS)
  double ref_budget; // wall seconds the reference's refinement may take
                     // (0: EK_ADVISE_REF_BUDGET)
  FILE *progress;    // "candidate k of n" lines; NULL: silent
} ek_advise_opts;

// A candidate's trial measured against the reference's (above).
typedef struct {
  double deviation;  // worst frame: max vertex distance / scale (NaN: not comparable)
  int worst_frame;   // its index (0-based), -1 if none
  double worst_t;    // its simulated time
  double energy_dev; // max over frames |E - E_ref| / the reference's energy scale
  double min_J;      // smallest J over the frames
  double motion;     // largest vertex displacement from rest / body size
  int failed;        // a check failed (reason)
  char reason[512];
} ek_advise_measure;

// Measure trial c against the reference trial ref (both from
// ek_trial_run_frames with the same nframes): the deviation and the checks
// (above). allow_inverted: the scene's allow.inverted.
void ek_advise_measure_trial(const ek_mesh *mesh, const ek_trial *c, const ek_trial *ref,
                             int allow_inverted, ek_advise_measure *m);

typedef struct {
  ek_scene setting;
  char text[384]; // ek_trial_setting_text
  int skipped;    // not run: the model's range excludes the scene's (reason)
  int failed;     // ran and failed (reason)
  char reason[512];
  int uses_svd;     // the step takes an SVD (ek_trial_uses_svd)
  double deviation; // ek_advise_measure's (NaN: not run)
  double worst_t;   // the simulated time of its worst frame
  double energy_dev, min_J;
  double cost;             // s per simulated s: median over the rounds (NaN: not run)
  double cost_lo, cost_hi; // min and max over the rounds
  int rounds;              // timing rounds run
  int ladder;              // a run of the reference's refinement (measured there)
  double cost_min;         // s per simulated s (the fastest step of the first run)
  long steps;
} ek_advise_row;

// The reference's refinement: run k at dt[k], wall[k] seconds; change[k]
// its deviation from run k - 1 (NaN for k = 0 or when run k failed).
// ext_change[k] the deviation between the extrapolations of runs (k-1, k)
// and (k-2, k-1) (NaN for k < 2).
typedef struct {
  int runs;
  double dt[EK_ADVISE_MAX_REFINE + 1], wall[EK_ADVISE_MAX_REFINE + 1],
      change[EK_ADVISE_MAX_REFINE + 1], ext_change[EK_ADVISE_MAX_REFINE + 1];
  int converged;    // the last change (or extrapolation change) <= tol / 10
  int extrapolated; // the reference is 2 x_k - x_(k-1), not one run's
  char stop[384];   // why the refinement stopped
} ek_advise_refinement;

typedef struct {
  size_t n;
  ek_advise_row *rows; // rows[reference] first
  size_t reference;    // 0
  long scene_row;      // the scene's own setting (-1 if not among the rows)
  long pick;           // ek_advice_pick(tol) (always some: the reference)
  double tol, sim_time, body_size;
  double scale;  // the deviation's divisor (above), m
  double motion; // the reference's largest vertex displacement from rest, m
  int nframes;
  int threads;
  ek_advise_refinement refine;
  ek_trial_monitor reach; // what the reference run reached
  ek_trial ref;           // the reference's frames (ek_advise_measure_trial's ref)
  // Tets inverted at the end of the reference run (ek_sim_check), 0 when
  // the scene allows it: the reference row then fails too.
  size_t reference_inverted;
} ek_advice;

// Run the advisor on a tet scene and its mesh. 0 with *a filled (free with
// ek_advice_free), or < 0 with err (the reference setting failed, bad
// options, a cloth scene, out of memory).
int ek_advise(const ek_scene *scene, const ek_mesh *mesh, const ek_advise_opts *opts, ek_advice *a,
              char *err, size_t errlen);
// The pick rule (above) for tol: -1 if no row passes.
long ek_advice_pick(const ek_advice *a, double tol);
// The table the choice was made from, one row per candidate (setting,
// deviation, cost, drift, verdict), and the pick.
void ek_advice_print(const ek_advice *a, FILE *out);
// A row's reason as printed: a trial's message names "FILE (trial
// SETTING)" (trial.c), and the row names its setting already, so the
// parenthesis is dropped ("x.json (trial model=stvk;dt=0.1): step 3: ..."
// -> "x.json: step 3: ..."). out receives the text.
void ek_advise_reason_text(const char *reason, char *out, size_t n);
void ek_advice_free(ek_advice *a);

#ifdef __cplusplus
}
#endif
#endif
