// Internal (not installed): the scene advisor behind ek-sim --advise.
//
// Runs a tet scene's first S simulated seconds with each candidate setting
// (trial.h: models valid for what the scene reaches, precision, SVD sweeps,
// the loop and its iterations), measures each one's deviation from the
// most accurate candidate (the reference) and its cost, and picks the
// cheapest candidate within a tolerance X of the body size.
//
// The reference: the scene's own model and loop, in f64, with the SVD at
// its f64 default (3 approximate + 2 exact sweeps, exact rsqrt: within
// 1e-12 of LAPACK, svd3.h), the implicit loop's newton_tol and cg_tol
// tightened to at most 1e-8 and 1e-6, XPBD at 4x the scene's substeps
// (Macklin et al. 2019: more substeps, closer to the implicit solution).
// It is run first, with the monitor of trial.h: the range of J, strain
// and rotation it reaches decides which models are candidates (below).
//
// Candidates, per valid model (Lame parameters mapped to the scene model's
// small-strain stiffness, ek_trial_set_model), in f64 and f32: the scene's
// loop with its own knobs; where the step takes an SVD, two cheaper SVD
// settings (McAdams et al. 2011 as published: 4 sweeps, approximate rsqrt,
// no refinement; and 2 sweeps, no refinement); the loop's knobs loosened
// one at a time (implicit: newton_tol 1e-4; cg_tol 1e-2; one Newton
// iteration per step, the linearised backward Euler of Baraff and Witkin
// 1998; XPBD: half the substeps, half the sweeps, twice the substeps); and
// the other loops at their usual step, in the scene's precision (explicit
// at half the CFL estimate, implicit and XPBD at dt = 1/60 s; XPBD for
// StVK only, its constraint's energy).
#ifndef EK_SIM_ADVISE_H
#define EK_SIM_ADVISE_H

#include "trial.h"

#include <stdio.h>

#ifdef __cplusplus
extern "C" {
#endif

// Defaults of --tol (a fraction of the body size) and --time (simulated
// seconds; the scene's duration when that is shorter).
#define EK_ADVISE_TOL_DEFAULT 0.01
#define EK_ADVISE_TIME_DEFAULT 0.5

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
  double tol;      // X: largest deviation accepted, fraction of the body size (>= 0)
  double sim_time; // S: simulated seconds per candidate, from the scene's dt
                   // (one step) to EK_TRIAL_MAX_STEPS steps of it
  FILE *progress;  // "candidate k of n" lines; NULL: silent
} ek_advise_opts;

typedef struct {
  ek_scene setting;
  char text[384]; // ek_trial_setting_text
  int skipped;    // not run: the model's range excludes the scene's (reason)
  int failed;     // ran and failed (reason)
  char reason[512];
  int uses_svd;     // the step takes an SVD (ek_trial_uses_svd)
  double deviation; // from the reference's final positions / body size (NaN: not run)
  double cost;      // s per simulated s (median step), NaN: not run
  double cost_min;  // s per simulated s (fastest step)
  double drift;     // relative energy drift (trial.h)
  long steps;
} ek_advise_row;

typedef struct {
  size_t n;
  ek_advise_row *rows; // rows[reference] first
  size_t reference;    // 0
  long scene_row;      // the scene's own setting (-1 if not among the rows)
  long pick;           // the cheapest row within tol (always some: the reference)
  double tol, sim_time, body_size;
  int threads;
  ek_trial_monitor reach; // what the reference run reached
  // Tets inverted at the end of the reference run (ek_sim_check), 0 when
  // the scene allows it: the reference row then fails too.
  size_t reference_inverted;
} ek_advice;

// Run the advisor on a tet scene and its mesh. 0 with *a filled (free with
// ek_advice_free), or < 0 with err (the reference setting failed, bad
// options, a cloth scene, out of memory).
int ek_advise(const ek_scene *scene, const ek_mesh *mesh, const ek_advise_opts *opts, ek_advice *a,
              char *err, size_t errlen);
// The cheapest row that ran, did not fail and deviates at most tol (the
// rule ek_advise applies to opts->tol); -1 if none.
long ek_advice_pick(const ek_advice *a, double tol);
// The table the choice was made from, one row per candidate (setting,
// deviation, cost, drift, verdict), and the pick.
void ek_advice_print(const ek_advice *a, FILE *out);
void ek_advice_free(ek_advice *a);

#ifdef __cplusplus
}
#endif
#endif
