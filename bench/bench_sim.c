// ek-bench family "sim": the explicit loop (sim/explicit.c), the implicit
// loop (sim/implicit.c) and the XPBD loop (sim/xpbd.c) on the shipped
// scenes, per step, no frame output: explicit: FVM force (fused kernel),
// R^n refresh where the model needs it, integration, boundary conditions
// and ground; implicit: Newton + PCG; XPBD: substeps x solver sweeps.
//
// Rows: sim/<scene>/<model>/<isa>/<prec>/tets:<N>/threads:<T>; one call is
// STEPS_PER_CALL steps (1 for the implicit and XPBD scenes: a step is
// already many passes over the mesh), so the per-item time is the time per
// step. The
// simulation keeps running across calls (a scene has no end; its step count
// is only the default length of a run). After each row the split by phase
// (deformation gradient, SVD/polar, P, scatter from the FVM kernel's
// phase-timed passes; integration; R^n refresh) is measured on PHASE_STEPS
// more steps and recorded as a note, in ms per step. After an implicit row
// the note gives Newton and CG iterations per step, the time by phase, and
// ns per tet of one Hessian product next to one FVM force evaluation of
// the same mesh, precision and state (median of FORCE_CALLS calls). After
// an XPBD row the note gives the sweeps per step, ns per constraint and
// sweep, one sweep split into deformation gradients / constraint
// evaluation / projection (ek_xpbd_profile_*, once per phase-timed step)
// and the residual.
//
// sim/cantilever_xpbd/it:<N>/sub:<K>/threads:<T>: the cantilever_xpbd
// scene at N sweeps per substep x K substeps per step (the cost per step of
// each setting in xpbd_grid; what each buys in accuracy is the table of
// tests/test_sim_xpbd.c), followed, per thread count, by the same note
// from XPBD_PHASE_STEPS phase-timed steps of the last such row's run.
//
// sim/<scene>/solver:<s>/<isa>/<prec>/tets:<N>/threads:<T>: an implicit
// scene with integrator.linear_solver set to each solver this build has
// (matrix_free; amg and direct with PETSc), at the largest thread count
// only: each call runs the scene's first SOLVER_WINDOW steps from its start
// state (ek_sim_set_state), an item is a step, so every solver is timed on
// the same steps (a run of consecutive calls drifts to the settled beam's
// cheap steps, and a fast solver took more of them: amg 1.46 Newton
// iterations per step over 63 steps against direct's 3.29 over 7, 5 from
// the start); after each row a note with Newton iterations per step, CG
// iterations per Newton iteration and ms per step by phase. cantilever_implicit is in the default
// suite (~0.1 to 1 s per step); the bracket (scenes/bracket.json, 120 273 tets: ~10 s per
// matrix-free step) only when --filter names its rows (e.g. --filter 'bracket/solver').
//
// sim/cantilever_1s/...: not a timed row but one run of each loop over 1 s
// of simulated time on the cantilever (explicit at the scene's CFL-bound
// dt, implicit at 1/30 s with the scene's solver, matrix_free, and with
// amg when PETSc is built), printed side by side as a note with the final
// tip positions' difference (one run each: a cost, not a median).
#include <ek/cloth.h>
#include <ek/sim/sim.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench.h"
#include "scene_find.h"

#include <ek/fvm.h>
#include <ek/material.h>
#include <math.h>
#include <omp.h>

enum { STEPS_PER_CALL = 10, PHASE_STEPS = 20, FORCE_CALLS = 21, SOLVER_WINDOW = 3 };
// Phase-timed steps behind the cantilever_xpbd it:N/sub:K note: a step
// profiles one sweep (ek_xpbd_profile_*), so a few steps average a few.
enum { XPBD_PHASE_STEPS = 5 };

typedef struct {
  ek_sim *sim;
  ek_bench *b;
  int failed, steps;
  double *x0, *v0;  // a call's start state, or NULL: go on from the last
  const char *name; // the row's, for its after-row check
} sim_ctx;

static void run_steps(void *p) {
  sim_ctx *c = p;
  if (c->x0 && !c->failed && ek_sim_set_state(c->sim, c->x0, c->v0) != 0) {
    c->failed = 1;
    ek_bench_fail(c->b, "sim: resetting the state failed: %s", ek_last_error());
  }
  for (int i = 0; i < c->steps && !c->failed; ++i) {
    int rc = ek_sim_step(c->sim);
    if (rc != 0) {
      c->failed = 1;
      ek_bench_fail(c->b, "sim: step failed (rc %d): %s", rc, ek_last_error());
    }
  }
}

// A sim row's after-row check (ek_bench_row.after), the state check of
// ek-sim's summary (ek_sim_check, issue 25): a row whose run blew up fails
// and is not recorded, unless the scene's "allow" key says so. A row whose
// step failed has its failure already: the blow-up is not counted again.
// A blown-up row is marked failed, so no phase note follows it.
static int sim_blew_up(void *p) {
  sim_ctx *c = p;
  ek_sim_health h;
  if (!c->sim || c->failed || ek_sim_check(c->sim, &h) != 0 || !h.blown_up || h.allow_nonfinite)
    return 0;
  ek_bench_fail(c->b,
                "%s: the positions blew up after step %ld (t = %g s): vertex %zu %.3g body "
                "sizes from the rest centre, %zu non-finite values",
                c->name, ek_sim_steps_done(c->sim), ek_sim_time(c->sim), h.farthest, h.extent,
                h.nonfinite);
  c->failed = 1;
  return 1;
}

// A sim row: ctx's steps timed, then the state they left checked
// (sim_blew_up) before the row is recorded.
static ek_bench_row sim_row(const char *name, ek_isa isa, const char *precision, int threads,
                            const char *knobs, size_t items, sim_ctx *ctx) {
  return (ek_bench_row){.name = name,
                        .family = "sim",
                        .isa = isa,
                        .precision = precision,
                        .threads = threads,
                        .knobs = knobs,
                        .items = items,
                        .fn = run_steps,
                        .ctx = ctx,
                        .after = sim_blew_up};
}

// The library's pending warning for a row's sim (ek_sim_warning: a CFL or
// Newton warning of its steps), as an ek-bench note on its own line, and
// a run that ends with inverted elements (unless the scene's "allow" key
// says so). Read after the row, not inside the timed steps.
static void note_sim_warning(ek_bench *b, const char *name, ek_sim *sim) {
  const char *w = sim ? ek_sim_warning(sim) : NULL;
  if (w)
    ek_bench_note(b, "warning: %s: %s", name, w);
  ek_sim_health h;
  if (!sim || ek_sim_check(sim, &h) != 0)
    return;
  if (h.inverted > 0 && !h.allow_inverted)
    ek_bench_note(b,
                  "warning: %s: the run ends (step %ld, t = %g s) with %zu of %zu elements "
                  "INVERTED (J <= 0; the first is element %zu, J = %.3g)",
                  name, ek_sim_steps_done(sim), ek_sim_time(sim), h.inverted, h.elements,
                  h.first_inverted, h.first_inverted_J);
}

// A shipped scene by name, from the build or the installed tree
// (sim/scene_find.h); the error names every path tried.
static int load_shipped(const char *name, ek_scene *scene, char *err, size_t errlen) {
  char path[EK_SCENE_PATH_MAX];
  if (ek_shipped_scene(name, path, sizeof path, err, errlen) != 0)
    return -1;
  if (ek_scene_load(path, scene) != 0) {
    snprintf(err, errlen, "%s", ek_last_error());
    return -1;
  }
  return 0;
}

// Whether the filter could select a row of a shipped scene that could not
// be loaded (ek-bench run outside its tree, EK_SCENES_DIR wrong). Such a
// row's name holds what the scene gives (model or linear solver, ISA,
// precision, tet count), so the filter is tried on every name the row could
// have: each model (short and long name) or, with `solvers`, each linear
// solver ("solver:<s>"), each ISA, precision and thread count; the tet
// count, which only the scene knows, as 0. Without a filter every row is
// wanted. A filter that selects sim rows by their tet count alone passes
// here for none: bench_sim then notes the scenes it did not find.
static int missing_scene_wanted(const ek_bench *b, const char *scene, int solvers,
                                const int *counts, int ncounts) {
  const int nwords = solvers ? EK_LINSOLVE_COUNT : 2 * EK_MODEL_COUNT;
  for (int w = 0; w < nwords; ++w)
    for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; ++isa)
      for (int prec = 32; prec <= 64; prec += 32)
        for (int t = 0; t < ncounts; ++t) {
          char name[EK_BENCH_NAME_MAX];
          const char *word = solvers ? ek_linear_solver_name((ek_linear_solver)w)
                             : w % 2 ? ek_model_long_name((ek_model)(w / 2))
                                     : ek_model_name((ek_model)(w / 2));
          snprintf(name, sizeof name, "sim/%s/%s%s/%s/f%d/tets:0/threads:%d", scene,
                   solvers ? "solver:" : "", word, ek_isa_name((ek_isa)isa), prec, counts[t]);
          if (ek_bench_wants(b, name))
            return 1;
        }
  return 0;
}

// A shipped scene that could not be loaded: a failure when the filter could
// select one of its rows (the error names every path tried), else counted
// for the note at the end of bench_sim's listing pass.
static int scene_missing(ek_bench *b, const char *scene, const char *err, int solvers,
                         const int *counts, int ncounts, int *unneeded) {
  if (missing_scene_wanted(b, scene, solvers, counts, ncounts)) {
    ek_bench_fail(b, "sim: %s", err);
    return -1;
  }
  ++*unneeded;
  return 0;
}

static double now(void) { return omp_get_wtime(); }

static int cmp_double(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return x < y ? -1 : x > y;
}

// ns per tet of one FVM force evaluation of the sim's mesh, precision and
// current state (median of FORCE_CALLS).
static double force_ns_per_tet(const ek_scene *scene, const ek_mesh *mesh, const ek_sim *sim) {
  size_t n3 = 3 * ek_mesh_nverts(mesh), nt = ek_mesh_ntets(mesh);
  const double *x = ek_sim_positions(sim);
  double *f = malloc(n3 * sizeof(double)), *R = malloc(nt * 9 * sizeof(double));
  float *xf = malloc(n3 * sizeof(float)), *ff = malloc(n3 * sizeof(float));
  double t[FORCE_CALLS], med = NAN;
  if (f && R && xf && ff) {
    for (size_t i = 0; i < n3; i++)
      xf[i] = (float)x[i];
    for (size_t e = 0; e < nt; e++)
      for (int k = 0; k < 9; k++)
        R[e * 9 + k] = k % 4 == 0;
    ek_fvm_opts o = {.scatter = scene->scatter,
                     .isa = scene->svd.isa,
                     .svd_sweeps = scene->svd.sweeps,
                     .svd_exact_rsqrt = scene->svd.exact_rsqrt,
                     .svd_refine = scene->svd.refine,
                     .R = R};
    int ok = 1;
    for (int i = 0; i < FORCE_CALLS && ok; i++) {
      double t0 = now();
      ok = (scene->precision == 32
                ? ek_mesh_fvm_forces_ex_f32(mesh, &scene->material, xf, ff, &o)
                : ek_mesh_fvm_forces_ex_f64(mesh, &scene->material, x, f, &o)) == 0;
      t[i] = now() - t0;
    }
    if (ok) {
      qsort(t, FORCE_CALLS, sizeof t[0], cmp_double);
      med = 1e9 * t[FORCE_CALLS / 2] / (double)nt;
    }
  }
  free(f);
  free(R);
  free(xf);
  free(ff);
  return med;
}

// After an implicit row: iterations, phases, product vs force per tet.
static void implicit_note(ek_bench *b, const char *name, const ek_scene *scene, const ek_mesh *mesh,
                          const ek_sim *sim) {
  const ek_sim_times *t = ek_sim_timings(sim);
  double n = (double)t->steps, nt = (double)ek_mesh_ntets(mesh);
  if (n <= 0)
    return;
  double product = t->matvecs ? 1e9 * t->matvec / ((double)t->matvecs * nt) : NAN;
  double force = force_ns_per_tet(scene, mesh, sim);
  ek_bench_note(b,
                "%s: %.2f Newton iterations per step, %.1f CG iterations per Newton iteration, "
                "%ld of %ld steps stopped above newton_tol; ms per step: gradient+eigensystems "
                "%.3f, Hessian products %.3f, preconditioner %.3f, CG vectors %.3f, line search "
                "%.3f; one Hessian product %.2f ns/tet vs one force evaluation %.2f ns/tet "
                "(%.2fx)",
                name, (double)t->newton_iterations / n,
                t->newton_iterations ? (double)t->cg_iterations / (double)t->newton_iterations : 0,
                t->unconverged_steps, t->steps, 1e3 * t->gradient / n, 1e3 * t->matvec / n,
                1e3 * t->preconditioner / n, 1e3 * t->cg_vectors / n, 1e3 * t->line_search / n,
                product, force, product / force);
}

// Mean z displacement of the cantilever's free end face (x = L).
static double tip(const ek_sim *sim, const ek_mesh *mesh, double L) {
  const double *X = ek_mesh_rest_positions(mesh), *x = ek_sim_positions(sim);
  double sum = 0;
  int count = 0;
  for (size_t i = 0; i < ek_mesh_nverts(mesh); i++)
    if (fabs(X[3 * i] - L) <= 1e-9 * L) {
      sum += x[3 * i + 2] - X[3 * i + 2];
      count++;
    }
  return count ? sum / count : NAN;
}

// After an XPBD row: sweeps per step, ns per constraint and sweep, the
// sweep's phase split (`steps` phase-timed steps more, one profile each)
// and the residual.
static void xpbd_note(ek_bench *b, const char *name, const ek_scene *scene, ek_sim *sim,
                      int steps) {
  ek_sim_time_phases(sim, 1);
  int rc = 0;
  for (int i = 0; i < steps && rc == 0; ++i)
    rc = ek_sim_step(sim);
  ek_sim_time_phases(sim, 0);
  const ek_sim_times *t = ek_sim_timings(sim);
  if (rc != 0 || t->xpbd_profiles == 0 || t->xpbd_sweeps == 0)
    return;
  const double p = (double)t->xpbd_profiles;
  ek_bench_note(
      b,
      "%s: %ld substeps x %ld sweeps per step (%s, %s), %.2f ns per constraint and "
      "sweep; one sweep split: deformation gradients %.4f ms, constraint evaluation "
      "%.4f ms, projection %.4f ms; residual after the last sweep %.3g (largest C %.3g)",
      name, scene->xpbd.substeps, scene->xpbd.iterations, ek_xpbd_solver_name(scene->xpbd.solver),
      ek_xpbd_elements_name(scene->xpbd.elements),
      1e9 * t->xpbd_solve / ((double)t->xpbd_sweeps * (double)ek_sim_xpbd_constraints(sim)),
      1e3 * t->xpbd_sweep_F / p, 1e3 * t->xpbd_sweep_eval / p, 1e3 * t->xpbd_sweep_project / p,
      t->xpbd_last_residual, t->xpbd_last_cmax);
}

// sim/cantilever_xpbd/it:N/sub:K/threads:T (see the top comment): the
// scene's integrator knobs replaced by each (N, K) below.
static const struct {
  long iterations, substeps;
} xpbd_grid[] = {{1, 10}, {10, 1}, {5, 4}, {2, 20}, {10, 10}, {1, 50}, {4, 25}};

static int xpbd_grid_rows(ek_bench *b, const int *counts, int ncounts) {
  static const char *scene_name = "cantilever_xpbd";
  static ek_scene scene;
  char err[1024] = "";
  ek_mesh *mesh = NULL;
  int rc = 0, loaded = 0;
  for (int t = 0; t < ncounts; ++t) {
    ek_sim *last = NULL; // the last timed row's run, for the phase note
    char last_name[EK_BENCH_NAME_MAX] = "";
    long last_it = 0, last_sub = 0; // the note names the last run's knobs
    for (size_t g = 0; g < sizeof xpbd_grid / sizeof xpbd_grid[0]; ++g) {
      char name[EK_BENCH_NAME_MAX], knobs[256];
      snprintf(name, sizeof name, "sim/%s/it:%ld/sub:%ld/threads:%d", scene_name,
               xpbd_grid[g].iterations, xpbd_grid[g].substeps, counts[t]);
      if (!ek_bench_wants(b, name))
        continue;
      sim_ctx ctx = {NULL, b, 0, 1, NULL, NULL, name};
      if (!ek_bench_listing(b)) {
        if (!loaded) {
          if (load_shipped(scene_name, &scene, err, sizeof err) != 0 ||
              !(mesh = ek_scene_mesh(&scene))) {
            ek_bench_fail(b, "sim: %s: %s", scene_name, err[0] ? err : ek_last_error());
            ek_sim_destroy(last);
            return -1;
          }
          scene.output_file[0] = '\0';
          loaded = 1;
        }
        scene.xpbd.iterations = xpbd_grid[g].iterations;
        scene.xpbd.substeps = xpbd_grid[g].substeps;
        if (!(ctx.sim = ek_sim_create(&scene, mesh))) {
          ek_bench_fail(b, "sim: %s: %s", name, ek_last_error());
          rc = -1;
          continue;
        }
      }
      snprintf(knobs, sizeof knobs,
               "scene=%s;integrator=xpbd;iterations=%ld;substeps=%ld;sweeps_per_step=%ld;"
               "steps_per_call=1",
               scene_name, xpbd_grid[g].iterations, xpbd_grid[g].substeps,
               xpbd_grid[g].iterations * xpbd_grid[g].substeps);
      ek_bench_row row = sim_row(name, EK_ISA_AUTO, "f32", counts[t], knobs, 1, &ctx);
      if (!ek_bench_listing(b)) {
        // The row's ISA and precision are the scene's (the name leaves
        // them out: it is the same scene in every row).
        ek_isa isa = EK_ISA_AUTO;
        if (ek_isa_resolve(scene.svd.isa, &isa) == EK_OK)
          row.isa = isa;
        row.precision = scene.precision == 32 ? "f32" : "f64";
      }
      const int run_rc = ek_bench_run(b, &row);
      note_sim_warning(b, name, ctx.sim);
      if (run_rc != 0 || ctx.failed) {
        rc = -1;
        ek_sim_destroy(ctx.sim);
        continue;
      }
      ek_sim_destroy(last);
      last = ctx.sim;
      snprintf(last_name, sizeof last_name, "%s", name);
      last_it = xpbd_grid[g].iterations;
      last_sub = xpbd_grid[g].substeps;
    }
    // The harness set the threads for the last row; the note's steps run
    // at the same count.
    if (last) {
      omp_set_num_threads(counts[t]);
      scene.xpbd.iterations = last_it;
      scene.xpbd.substeps = last_sub;
      xpbd_note(b, last_name, &scene, last, XPBD_PHASE_STEPS);
    }
    ek_sim_destroy(last);
  }
  ek_mesh_destroy(mesh);
  return rc;
}

// 1 s of the cantilever, explicit vs implicit (see the top comment).
static int cantilever_1s(ek_bench *b, int threads) {
  static const char *names[3] = {"cantilever", "cantilever_implicit", "cantilever_implicit"};
  char name[EK_BENCH_NAME_MAX];
  snprintf(name, sizeof name, "sim/cantilever_1s/explicit_vs_implicit/threads:%d", threads);
  if (!ek_bench_wants(b, name))
    return 0;
  if (ek_bench_listing(b)) {
    ek_bench_note(
        b, "%s: one run of each loop (not a timed row: it runs when a timed row is selected too)",
        name);
    return 0;
  }
  double seconds[3] = {NAN, NAN, NAN}, tips[3] = {NAN, NAN, NAN}, dts[3] = {NAN, NAN, NAN};
  long steps[3] = {0, 0, 0};
  // The third run: the implicit scene with the AMG solver (PETSc builds).
  const int runs = ek_linear_solver_available(EK_LINSOLVE_AMG) ? 3 : 2;
  omp_set_num_threads(threads);
  for (int k = 0; k < runs; k++) {
    char err[1024] = "";
    ek_scene scene;
    ek_mesh *mesh = NULL;
    ek_sim *sim = NULL;
    int loaded = load_shipped(names[k], &scene, err, sizeof err) == 0;
    if (loaded && k == 2)
      scene.implicit.linear_solver = EK_LINSOLVE_AMG;
    if (!loaded || !(mesh = ek_scene_mesh(&scene)) || !(sim = ek_sim_create(&scene, mesh))) {
      ek_bench_fail(b, "sim: %s: %s", names[k], err[0] ? err : ek_last_error());
      ek_mesh_destroy(mesh);
      return -1;
    }
    dts[k] = scene.dt;
    steps[k] = lround(1.0 / scene.dt);
    double t0 = now();
    int rc = 0;
    for (long i = 0; i < steps[k] && rc == 0; i++)
      rc = ek_sim_step(sim);
    seconds[k] = now() - t0;
    tips[k] = tip(sim, mesh, scene.box_size[0]);
    if (rc)
      ek_bench_fail(b, "sim: %s: %s", names[k], ek_last_error());
    ek_sim_destroy(sim);
    ek_mesh_destroy(mesh);
    if (rc)
      return -1;
  }
  char amg[512] = "; implicit with linear_solver amg: no PETSc in this build";
  if (runs == 3)
    snprintf(amg, sizeof amg,
             "; implicit with linear_solver amg %.3f s, explicit / implicit amg %.2fx, tip z "
             "%.6e m, difference %.3g of the explicit one",
             seconds[2], seconds[0] / seconds[2], tips[2], fabs(tips[2] - tips[0]) / fabs(tips[0]));
  ek_bench_note(b,
                "%s: 1 s of simulated time: explicit dt %.3g (%ld steps) %.3f s, implicit dt %.4g "
                "(%ld steps) %.3f s, explicit / implicit %.2fx; tip z displacement explicit "
                "%.6e m, implicit %.6e m, difference %.3g of the explicit one%s",
                name, dts[0], steps[0], seconds[0], dts[1], steps[1], seconds[1],
                seconds[0] / seconds[1], tips[0], tips[1], fabs(tips[1] - tips[0]) / fabs(tips[0]),
                amg);
  return 0;
}

// sim/<scene>/solver:<s>/... (see the top comment): per implicit scene and
// linear solver, the step time (one step per call) and a note with the
// iterations and the phases.
static int solver_rows(ek_bench *b, const int *counts, int ncounts, int *unneeded) {
  static const struct {
    const char *scene;
    int opt_in; // only under a --filter that names the rows
  } cases[] = {{"cantilever_implicit", 0}, {"bracket", 1}};
  const int threads = counts[ncounts - 1];
  int rc = 0;
  for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
    if (cases[k].opt_in && !ek_bench_filtered(b))
      continue;
    char err[1024];
    static ek_scene scene;
    if (load_shipped(cases[k].scene, &scene, err, sizeof err) != 0) {
      if (scene_missing(b, cases[k].scene, err, 1, counts + ncounts - 1, 1, unneeded) != 0)
        rc = -1;
      continue;
    }
    scene.output_file[0] = '\0';
    ek_isa isa = EK_ISA_AUTO;
    if (ek_isa_resolve(scene.svd.isa, &isa) != EK_OK)
      continue;
    // The tet count names the row: a box's from its cells, a file mesh's
    // from the mesh (loaded here: the bracket's rows are opt-in).
    ek_mesh *mesh = scene.mesh_file[0] ? ek_scene_mesh(&scene) : NULL;
    if (scene.mesh_file[0] && !mesh) {
      ek_bench_fail(b, "sim: %s: %s", cases[k].scene, ek_last_error());
      rc = -1;
      continue;
    }
    long tets = mesh ? (long)ek_mesh_ntets(mesh)
                     : 6L * scene.box_cells[0] * scene.box_cells[1] * scene.box_cells[2];
    const char *prec = scene.precision == 32 ? "f32" : "f64";
    for (int ls = 0; ls < EK_LINSOLVE_COUNT; ls++) {
      char name[EK_BENCH_NAME_MAX], knobs[256];
      snprintf(name, sizeof name, "sim/%s/solver:%s/%s/%s/tets:%ld/threads:%d", cases[k].scene,
               ek_linear_solver_name((ek_linear_solver)ls), ek_isa_name(isa), prec, tets, threads);
      if (!ek_bench_wants(b, name))
        continue;
      if (!ek_linear_solver_available((ek_linear_solver)ls)) {
        ek_bench_note(b, "%s: skipped: linear_solver %s needs PETSc, and this build has none", name,
                      ek_linear_solver_name((ek_linear_solver)ls));
        continue;
      }
      scene.implicit.linear_solver = (ek_linear_solver)ls;
      sim_ctx ctx = {NULL, b, 0, SOLVER_WINDOW, NULL, NULL, name};
      if (!ek_bench_listing(b)) {
        if (!mesh && !(mesh = ek_scene_mesh(&scene))) {
          ek_bench_fail(b, "sim: %s: %s", cases[k].scene, ek_last_error());
          rc = -1;
          break;
        }
        omp_set_num_threads(threads);
        if (!(ctx.sim = ek_sim_create(&scene, mesh))) {
          ek_bench_fail(b, "sim: %s: %s", name, ek_last_error());
          rc = -1;
          continue;
        }
        const size_t n3 = 3 * ek_mesh_nverts(mesh);
        ctx.x0 = malloc(n3 * sizeof(double));
        ctx.v0 = malloc(n3 * sizeof(double));
        if (!ctx.x0 || !ctx.v0) {
          ek_bench_fail(b, "sim: %s: out of memory for the start state", name);
          free(ctx.x0), free(ctx.v0), ek_sim_destroy(ctx.sim);
          rc = -1;
          continue;
        }
        memcpy(ctx.x0, ek_sim_positions(ctx.sim), n3 * sizeof(double));
        memcpy(ctx.v0, ek_sim_velocities(ctx.sim), n3 * sizeof(double));
      }
      snprintf(knobs, sizeof knobs,
               "scene=%s;model=%s;integrator=implicit;linear_solver=%s;steps_per_call=%d;"
               "from=start;dt=%g",
               cases[k].scene, scene.model_name, ek_linear_solver_name((ek_linear_solver)ls),
               SOLVER_WINDOW, scene.dt);
      ek_bench_row row = sim_row(name, isa, prec, threads, knobs, SOLVER_WINDOW, &ctx);
      if (ek_bench_run(b, &row) != 0)
        rc = -1;
      note_sim_warning(b, name, ctx.sim);
      const ek_sim_times *t = ctx.sim && !ctx.failed ? ek_sim_timings(ctx.sim) : NULL;
      if (t && t->steps > 0) {
        const double n = (double)t->steps;
        ek_bench_note(
            b,
            "%s (steps 1-%d from the start state): %.2f Newton iterations per step, %.1f CG "
            "iterations per Newton "
            "iteration (%s); ms per step: gradient+eigensystems %.3f, Hessian "
            "products %.3f, preconditioner %.3f, assembly %.3f, solver setup %.3f, "
            "solve %.3f; %ld steps",
            name, SOLVER_WINDOW, (double)t->newton_iterations / n,
            t->newton_iterations ? (double)t->cg_iterations / (double)t->newton_iterations : 0,
            ls == EK_LINSOLVE_DIRECT ? "a factorisation counts 1" : "CG", 1e3 * t->gradient / n,
            1e3 * t->matvec / n, 1e3 * t->preconditioner / n, 1e3 * t->assembly / n,
            1e3 * t->solver_setup / n, 1e3 * t->solver_solve / n, t->steps);
      }
      ek_sim_destroy(ctx.sim);
      free(ctx.x0);
      free(ctx.v0);
    }
    ek_mesh_destroy(mesh);
  }
  return rc;
}

// PHASE_STEPS more steps of a row's run with the phases timed (same
// threads: the harness set them for the row); *before and *after are the
// sim's timings around them. Returns the number of steps taken.
static double phase_timed_steps(ek_sim *sim, ek_sim_times *before, ek_sim_times *after) {
  *before = *ek_sim_timings(sim);
  ek_sim_time_phases(sim, 1);
  for (int i = 0; i < PHASE_STEPS && ek_sim_step(sim) == 0; ++i)
    ;
  *after = *ek_sim_timings(sim);
  return (double)(after->steps - before->steps);
}

// sim/cloth_hang/<model>/<isa>/<prec>/tris:<N>/threads:<T>: the explicit
// cloth step (cloth_force.h) on the hanging cloth of scenes/cloth_hang.json
// refined to 224 x 224 cells (100 352 triangles), dt under its CFL limit;
// after each row the split by phase (membrane, bending, gather from the
// cloth kernel's phase-timed passes; integration) on PHASE_STEPS more
// steps, ms per step, as a note.
static int cloth_rows(ek_bench *b, const int *counts, int ncounts) {
  enum { CELLS = 224 };
  static const char *models[] = {"stvk", "arap"};
  int rc = 0;
  for (int mi = 0; mi < 2; ++mi)
    for (int prec = 32; prec <= 64; prec += 32)
      for (int t = 0; t < ncounts; ++t) {
        char json[1200], name[EK_BENCH_NAME_MAX], knobs[256];
        ek_isa isa = EK_ISA_AUTO;
        if (ek_isa_resolve(EK_ISA_AUTO, &isa) != EK_OK)
          return -1;
        snprintf(name, sizeof name, "sim/cloth_hang/%s/%s/f%d/tris:%d/threads:%d", models[mi],
                 ek_isa_name(isa), prec, 2 * CELLS * CELLS, counts[t]);
        if (!ek_bench_wants(b, name))
          continue;
        // cloth_hang.json at CELLS x CELLS: dt below h_min / c (c ~ 52 m/s).
        snprintf(json, sizeof json,
                 "{\"mesh\": {\"grid\": [%d, %d], \"size\": [1, 1], \"plane\": \"xz\"}, "
                 "\"material\": {\"model\": \"%s\", \"E\": 1e6, \"nu\": 0.3, \"density\": 400}, "
                 "\"cloth\": {\"thickness\": 5e-4}, \"precision\": \"f%d\", \"boundary\": "
                 "[{\"type\": \"pin\", \"region\": {\"min\": [0, 0, 1], \"max\": [0, 0, 1]}}, "
                 "{\"type\": \"pin\", \"region\": {\"min\": [1, 0, 1], \"max\": [1, 0, 1]}}], "
                 "\"gravity\": [0, 0, -9.81], \"damping\": 1, \"dt\": 3e-5, \"steps\": 1}",
                 CELLS, CELLS, models[mi], prec);
        static ek_scene scene;
        ek_trimesh *mesh = NULL;
        sim_ctx ctx = {NULL, b, 0, STEPS_PER_CALL, NULL, NULL, name};
        if (!ek_bench_listing(b)) {
          if (ek_scene_parse(json, "cloth_hang_1e5", ".", &scene) != 0 ||
              !(mesh = ek_scene_trimesh(&scene)) ||
              !(ctx.sim = ek_sim_create_cloth(&scene, mesh))) {
            ek_bench_fail(b, "sim: %s: %s", name, ek_last_error());
            ek_trimesh_destroy(mesh);
            rc = -1;
            continue;
          }
        }
        snprintf(knobs, sizeof knobs,
                 "scene=cloth_hang;cells=%d;model=%s;integrator=explicit;steps_per_call=%d;dt=3e-5",
                 CELLS, models[mi], ctx.steps);
        ek_bench_row row = sim_row(name, isa, prec == 32 ? "f32" : "f64", counts[t], knobs,
                                   (size_t)ctx.steps, &ctx);
        if (ek_bench_run(b, &row) != 0)
          rc = -1;
        note_sim_warning(b, name, ctx.sim);
        if (ctx.sim && !ctx.failed) {
          ek_sim_times before, after;
          double n = phase_timed_steps(ctx.sim, &before, &after);
          if (n > 0)
            ek_bench_note(b,
                          "%s: ms per step by phase (separate passes): membrane %.4f, bending "
                          "%.4f, gather %.4f, integration %.4f",
                          name, 1e3 * (after.cloth_membrane - before.cloth_membrane) / n,
                          1e3 * (after.cloth_bending - before.cloth_bending) / n,
                          1e3 * (after.cloth_gather - before.cloth_gather) / n,
                          1e3 * (after.integration - before.integration) / n);
        }
        ek_sim_destroy(ctx.sim);
        ek_trimesh_destroy(mesh);
      }
  return rc;
}

// sim/rotations/cloth_hang/...: the rotation fields of one state of the
// 224 x 224 hanging cloth (after STEPS_PER_CALL steps): kabsch_one_ring =
// ek_sim_vertex_rotations (gather each vertex's one-ring, Kabsch per
// vertex: ~7 points per set), polar32_element = gather each triangle's
// corners, F (ek_tri_deformation_f64) and its polar (ek_polar32_f64). Items:
// vertices, triangles; same threads.
typedef struct {
  ek_sim *sim;
  const ek_trimesh *mesh;
  double *R, *xc, *F, *Rt;
  int failed;
  ek_bench *b;
} rot_ctx;

static void run_kabsch(void *p) {
  rot_ctx *c = p;
  if (!c->failed && ek_sim_vertex_rotations(c->sim, c->R) != 0) {
    c->failed = 1;
    ek_bench_fail(c->b, "sim: rotations: %s", ek_last_error());
  }
}

static void run_polar(void *p) {
  rot_ctx *c = p;
  const size_t nt = ek_trimesh_ntris(c->mesh);
  const int32_t *T = ek_trimesh_tris(c->mesh);
  const double *x = ek_sim_positions(c->sim);
  for (size_t t = 0; t < nt; ++t)
    for (int k = 0; k < 3; ++k)
      memcpy(c->xc + 9 * t + 3 * k, x + 3 * (size_t)T[3 * t + k], 3 * sizeof(double));
  if (c->failed ||
      ek_tri_deformation_f64(nt, c->xc, ek_cloth_dm_inv(ek_trimesh_cloth(c->mesh)), c->F) != 0 ||
      ek_polar32_f64(nt, c->F, c->Rt, NULL) != 0) {
    c->failed = 1;
    ek_bench_fail(c->b, "sim: rotations: %s", ek_last_error());
  }
}

static int rotation_rows(ek_bench *b, const int *counts, int ncounts) {
  enum { CELLS = 224 };
  int rc = 0;
  for (int kind = 0; kind < 2; ++kind)
    for (int t = 0; t < ncounts; ++t) {
      char name[EK_BENCH_NAME_MAX], json[1200];
      const size_t nv = (CELLS + 1) * (CELLS + 1), nt = 2 * CELLS * CELLS;
      snprintf(name, sizeof name, "sim/rotations/cloth_hang/%s/f64/%s:%zu/threads:%d",
               kind ? "polar32_element" : "kabsch_one_ring", kind ? "tris" : "verts",
               kind ? nt : nv, counts[t]);
      if (!ek_bench_wants(b, name))
        continue;
      rot_ctx c = {.b = b};
      static ek_scene scene;
      ek_trimesh *mesh = NULL;
      if (!ek_bench_listing(b)) {
        snprintf(json, sizeof json,
                 "{\"mesh\": {\"grid\": [%d, %d], \"size\": [1, 1], \"plane\": \"xz\"}, "
                 "\"material\": {\"model\": \"stvk\", \"E\": 1e6, \"nu\": 0.3, \"density\": "
                 "400}, \"cloth\": {\"thickness\": 5e-4}, \"boundary\": [{\"type\": \"pin\", "
                 "\"region\": {\"min\": [0, 0, 1], \"max\": [0, 0, 1]}}], \"gravity\": [0, 0, "
                 "-9.81], \"dt\": 3e-5, \"steps\": 1}",
                 CELLS, CELLS);
        if (ek_scene_parse(json, "rotations", ".", &scene) != 0 ||
            !(mesh = ek_scene_trimesh(&scene)) || !(c.sim = ek_sim_create_cloth(&scene, mesh))) {
          ek_bench_fail(b, "sim: %s: %s", name, ek_last_error());
          ek_trimesh_destroy(mesh);
          rc = -1;
          continue;
        }
        for (int i = 0; i < STEPS_PER_CALL; ++i)
          ek_sim_step(c.sim);
        c.mesh = mesh;
        c.R = malloc(9 * nv * sizeof(double));
        c.xc = malloc(9 * nt * sizeof(double));
        c.F = malloc(6 * nt * sizeof(double));
        c.Rt = malloc(6 * nt * sizeof(double));
        if (!c.R || !c.xc || !c.F || !c.Rt)
          c.failed = 1;
        if (!kind)
          run_kabsch(&c); // builds the one-rings outside the timing
      }
      ek_isa isa = EK_ISA_AUTO;
      ek_isa_resolve(EK_ISA_AUTO, &isa);
      ek_bench_row row = {.name = name,
                          .family = "sim",
                          .isa = isa,
                          .precision = "f64",
                          .threads = counts[t],
                          .knobs = kind ? "rotation=polar32_element" : "rotation=kabsch_one_ring",
                          .items = kind ? nt : nv,
                          .fn = kind ? run_polar : run_kabsch,
                          .ctx = &c};
      if (ek_bench_run(b, &row) != 0 || c.failed)
        rc = -1;
      ek_sim_destroy(c.sim);
      ek_trimesh_destroy(mesh);
      free(c.R), free(c.xc), free(c.F), free(c.Rt);
    }
  return rc;
}

int bench_sim(ek_bench *b) {
  static const char *scenes[] = {"cantilever",
                                 "twist",
                                 "drop",
                                 "crush",
                                 "cantilever_implicit",
                                 "twist_implicit",
                                 "stiff_bar_implicit",
                                 "crush_implicit",
                                 "crush_nh_implicit",
                                 "cantilever_xpbd",
                                 "drop_xpbd",
                                 "twist_xpbd",
                                 "drop_clusters"};
  int counts[EK_BENCH_MAX_THREAD_COUNTS];
  int ncounts = ek_bench_thread_counts(b, counts);
  int rc = 0, unneeded = 0;
  for (size_t k = 0; k < sizeof scenes / sizeof scenes[0]; ++k) {
    char err[1024];
    static ek_scene scene;
    if (load_shipped(scenes[k], &scene, err, sizeof err) != 0) {
      if (scene_missing(b, scenes[k], err, 0, counts, ncounts, &unneeded) != 0)
        rc = -1;
      continue;
    }
    scene.output_file[0] = '\0';
    ek_isa isa = EK_ISA_AUTO;
    if (ek_isa_resolve(scene.svd.isa, &isa) != EK_OK) {
      ek_bench_note(b, "sim: %s skipped: its ISA is not available here", scenes[k]);
      continue;
    }
    // Tet count of the box generator (6 per cell); file meshes are not
    // shipped scenes' case, but are counted after loading.
    long tets =
        scene.mesh_file[0] ? 0 : 6L * scene.box_cells[0] * scene.box_cells[1] * scene.box_cells[2];
    const char *prec = scene.precision == 32 ? "f32" : "f64";
    ek_mesh *mesh = NULL;
    for (int t = 0; t < ncounts; ++t) {
      char name[EK_BENCH_NAME_MAX], knobs[256];
      snprintf(name, sizeof name, "sim/%s/%s/%s/%s/tets:%ld/threads:%d", scenes[k],
               scene.model_name, ek_isa_name(isa), prec, tets, counts[t]);
      if (!ek_bench_wants(b, name))
        continue;
      const int implicit = scene.integrator == EK_INTEGRATOR_IMPLICIT,
                xpbd = scene.integrator == EK_INTEGRATOR_XPBD;
      sim_ctx ctx = {NULL, b, 0, implicit || xpbd ? 1 : STEPS_PER_CALL, NULL, NULL, name};
      if (!ek_bench_listing(b)) {
        if (!mesh && !(mesh = ek_scene_mesh(&scene))) {
          ek_bench_fail(b, "sim: %s: %s", scenes[k], ek_last_error());
          rc = -1;
          break;
        }
        if (!(ctx.sim = ek_sim_create(&scene, mesh))) {
          ek_bench_fail(b, "sim: %s: %s", scenes[k], ek_last_error());
          rc = -1;
          continue;
        }
      }
      snprintf(knobs, sizeof knobs, "scene=%s;model=%s;integrator=%s;steps_per_call=%d;dt=%g",
               scenes[k], scene.model_name, ek_scene_integrator_name(scene.integrator), ctx.steps,
               scene.dt);
      ek_bench_row row = sim_row(name, isa, prec, counts[t], knobs, (size_t)ctx.steps, &ctx);
      if (ek_bench_run(b, &row) != 0)
        rc = -1;
      note_sim_warning(b, name, ctx.sim);
      if (ctx.sim && !ctx.failed && implicit) {
        implicit_note(b, name, &scene, mesh, ctx.sim);
      } else if (ctx.sim && !ctx.failed && xpbd) {
        xpbd_note(b, name, &scene, ctx.sim, 1);
      } else if (ctx.sim && !ctx.failed) {
        // The split, on a few more steps of the same run (same threads:
        // the harness set them for the row).
        ek_sim_times before, after;
        double n = phase_timed_steps(ctx.sim, &before, &after);
        if (n > 0)
          ek_bench_note(b,
                        "%s: ms per step by phase (separate passes): deformation gradient "
                        "%.4f, SVD/polar %.4f, P %.4f, scatter %.4f, integration %.4f, R^n "
                        "refresh %.4f",
                        name, 1e3 * (after.deformation_gradient - before.deformation_gradient) / n,
                        1e3 * (after.svd_polar - before.svd_polar) / n,
                        1e3 * (after.pk1 - before.pk1) / n,
                        1e3 * (after.scatter - before.scatter) / n,
                        1e3 * (after.integration - before.integration) / n,
                        1e3 * (after.polar_refresh - before.polar_refresh) / n);
      }
      ek_sim_destroy(ctx.sim);
    }
    ek_mesh_destroy(mesh);
  }
  if (xpbd_grid_rows(b, counts, ncounts) < 0)
    rc = -1;
  if (cloth_rows(b, counts, ncounts) < 0)
    rc = -1;
  if (rotation_rows(b, counts, ncounts) < 0)
    rc = -1;
  if (solver_rows(b, counts, ncounts, &unneeded) < 0)
    rc = -1;
  if (unneeded && ek_bench_listing(b))
    ek_bench_note(b,
                  "sim: %d shipped scene(s) not found (EK_SCENES_DIR, or the installed or "
                  "source tree's scenes/); the filter selects none of their rows",
                  unneeded);
  if (cantilever_1s(b, counts[ncounts - 1]) < 0)
    rc = -1;
  return rc;
}
