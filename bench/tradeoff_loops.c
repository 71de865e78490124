// The loop maps of the speed/accuracy study (tradeoff.h): for the
// cantilever (scenes/cantilever*.json, family "loop/cantilever") and the
// twisted bar (scenes/twist*.json, "loop/twist"), explicit / implicit /
// XPBD settings x f32 / f64 x SVD sweeps x iterations or substeps, and the
// implicit loop's linear solvers (matrix_free; amg and direct in a build
// with PETSc), each run for 1 s of simulated time (sim/trial.h). A point's error is the
// deviation of its final positions from the most accurate setting's, per
// vertex over the body size (the distribution over the vertices; err_max
// is the deviation of trial.h); its cost the time per simulated second;
// energy_drift trial.h's relative energy change (the scenes are damped:
// the cantilever critically for its first mode, so most of the energy
// gravity puts in is dissipated by design: compare a point's drift with
// the reference's). The cantilever is at rest by 1 s (damping time 1/32
// s), so its map measures how well each setting reaches the static
// solution; the bar is still being twisted at 1 s (until 1.5 s), so its
// map measures the motion.
//
// The most accurate setting (is_reference): the explicit loop (symplectic
// Euler) in f64 at the scene's dt (cantilever 3.4e-5 s on the coarse beam
// below, about 1/5000 of the first bending period; bar 2e-4 s), with the
// SVD at its f64 default (within 1e-12 of LAPACK): the smallest step of
// the three loops, and no iteration stopped early. The implicit loop's
// backward Euler at dt = 1/30 s and XPBD (the StVK constraint: against
// fixed corotated or stable neo-Hookean, the same material up to the
// strains reached, plus the model's difference) are measured from it.
//
// Mesh: on the shipped cantilever (100 x 1 x 10 cubes) the implicit loop
// takes about 20 s per simulated second (README, XPBD section: 19.7 s) and
// the explicit one about 8x the coarse beam's ~1 s (4x the tets at half
// the step), so the cantilever's map runs on the same beam at half the
// resolution (50 x 1 x 5 cubes, 1500 tets; the explicit dt doubled with
// the element size, 3.4e-5 s) to keep the whole loops part within 5
// minutes on 2 cores. The bar runs as shipped (20 x 4 x 4 cubes).
#include "tradeoff.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "scene_find.h"
#include "trial.h"

// Simulated time per setting (issue 12: the deviation after 1 s).
#define LOOPS_SIM_TIME 1.0
// --quick (tests): the cantilever only, for this long.
#define LOOPS_QUICK_SIM_TIME 0.02

typedef struct {
  ek_scene scene;
  int is_default, is_reference;
} loop_setting;

typedef struct {
  loop_setting *v;
  int n, cap;
} setting_list;

static int push(setting_list *l, const ek_scene *s, int is_default, int is_reference) {
  if (l->n == l->cap) {
    int cap = l->cap ? 2 * l->cap : 32;
    loop_setting *v = realloc(l->v, (size_t)cap * sizeof *v);
    if (!v)
      return -1;
    l->v = v;
    l->cap = cap;
  }
  l->v[l->n++] = (loop_setting){*s, is_default, is_reference};
  return 0;
}

static int load_shipped(const char *name, ek_scene *scene) {
  char path[EK_SCENE_PATH_MAX], err[1024] = "";
  if (ek_shipped_scene(name, path, sizeof path, err, sizeof err) != 0 ||
      ek_scene_load(path, scene) != 0) {
    fprintf(stderr, "tradeoff loops: %s\n", err[0] ? err : ek_last_error());
    return -1;
  }
  return 0;
}

// The beam at half the shipped resolution (see the top of this file).
static void coarsen(ek_scene *s) {
  s->box_cells[0] = 50;
  s->box_cells[2] = 5;
  if (s->integrator == EK_INTEGRATOR_EXPLICIT)
    s->dt *= 2;
}

// Add s unless its setting text is already in the list (a knob the step
// does not use, e.g. SVD sweeps for a model that takes no SVD).
static int push_new(setting_list *l, const ek_scene *s, int is_default, int is_reference) {
  char a[384], b[384];
  ek_trial_setting_text(s, a, sizeof a);
  for (int i = 0; i < l->n; ++i) {
    ek_trial_setting_text(&l->v[i].scene, b, sizeof b);
    if (strcmp(a, b) == 0)
      return 0;
  }
  return push(l, s, is_default, is_reference);
}

// One family's settings from its explicit, implicit and XPBD scenes,
// the reference first: explicit in f64 (the reference), the scene's f32,
// the f32 SVD settings (McAdams et al. 2011 as published: 4 sweeps, no
// refinement, approximate rsqrt; then 2 and 1 sweeps); implicit: the scene
// (f32 products), f64, newton_tol 1e-8 / 1e-4 / 1e-3, cg_tol 1e-2, one
// Newton iteration per step (Baraff and Witkin 1998); no SVD variant: with
// 2 sweeps and no refinement in the gradient pass the cantilever's implicit
// second took 242 s (median step, at a load average of 10 on 2 cores,
// when the default SVD took 15 s), over the suite's budget by itself; XPBD: substeps x sweeps
// (README: at equal sweeps per step one sweep per substep wins) in f32 up to max_substeps, the
// finest also in f64. The bar stops at 500 substeps: its XPBD deviation levels off at 2.5e-3 from
// 100 substeps on (StVK against stable neo-Hookean), and 1000 and 2000 substeps took 9 and 17 s per
// simulated s at that load.
static int family_settings(setting_list *l, const char *const names[3], int coarse,
                           long max_substeps) {
  ek_scene ex, im, xp;
  if (load_shipped(names[0], &ex) || load_shipped(names[1], &im) || load_shipped(names[2], &xp))
    return -1;
  if (coarse) {
    coarsen(&ex);
    coarsen(&im);
    coarsen(&xp);
  }
  const ek_svd3_opts svds[] = {{4, -1, ex.svd.isa, EK_SVD3_REFINE_NONE},
                               {2, -1, ex.svd.isa, EK_SVD3_REFINE_NONE},
                               {1, -1, ex.svd.isa, EK_SVD3_REFINE_NONE}};
  int rc = 0;
  ek_scene s = ex;
  s.precision = 64;
  s.svd = (ek_svd3_opts){0, 0, ex.svd.isa, 0};
  rc |= push_new(l, &s, 0, 1);
  rc |= push_new(l, &ex, 1, 0);
  for (int k = 0; k < 3; ++k) {
    s = ex;
    s.svd = svds[k];
    rc |= push_new(l, &s, 0, 0);
  }
  rc |= push_new(l, &im, 1, 0);
  s = im;
  s.precision = 64;
  rc |= push_new(l, &s, 0, 0);
  const double newton_tols[] = {1e-8, 1e-4, 1e-3};
  for (int k = 0; k < 3; ++k) {
    s = im;
    s.implicit.newton_tol = newton_tols[k];
    rc |= push_new(l, &s, 0, 0);
  }
  s = im;
  s.implicit.cg_tol = 1e-2;
  rc |= push_new(l, &s, 0, 0);
  s = im;
  s.implicit.max_newton = 1;
  rc |= push_new(l, &s, 0, 0);
  // The solver axis (issue 24): the implicit settings with each assembled
  // linear solver this build has (PETSc's CG + GAMG, its sparse Cholesky;
  // sim/README.md "The implicit loop's linear solvers"): the scene's knobs,
  // f64, and newton_tol 1e-4 (the cheap end). Their rows name the solver
  // (";linear_solver=..."); the matrix-free rows above keep their names.
  // Without PETSc they are skipped (ek_tradeoff_loops says so).
  for (int ls = EK_LINSOLVE_AMG; ls < EK_LINSOLVE_COUNT; ++ls) {
    if (!ek_linear_solver_available((ek_linear_solver)ls))
      continue;
    s = im;
    s.implicit.linear_solver = (ek_linear_solver)ls;
    rc |= push_new(l, &s, 0, 0);
    s.precision = 64;
    rc |= push_new(l, &s, 0, 0);
    s = im;
    s.implicit.linear_solver = (ek_linear_solver)ls;
    s.implicit.newton_tol = 1e-4;
    rc |= push_new(l, &s, 0, 0);
  }
  const long grid[][2] = {{20, 10}, {100, 10}, {500, 2}, {1000, 1}, {2000, 1}};
  rc |= push_new(l, &xp, 1, 0);
  for (int k = 0; k < 5 && grid[k][0] <= max_substeps; ++k) {
    s = xp;
    s.xpbd.substeps = grid[k][0];
    s.xpbd.iterations = grid[k][1];
    rc |= push_new(l, &s, 0, 0);
  }
  s = xp;
  s.precision = 64;
  s.xpbd.substeps = max_substeps;
  s.xpbd.iterations = max_substeps >= 1000 ? 1 : 2;
  rc |= push_new(l, &s, 0, 0);
  return rc;
}

// Run every setting of a family (reference first) and add one point each.
static int run_family(ek_tradeoff *t, const char *family, const setting_list *l, double sim_time) {
  char metric[96];
  snprintf(metric, sizeof metric, "vertex distance / body size after %g s", sim_time);
  ek_mesh *mesh = ek_scene_mesh(&l->v[0].scene);
  if (!mesh) {
    fprintf(stderr, "tradeoff loops: %s: %s\n", family, ek_last_error());
    return -1;
  }
  const size_t nv = ek_mesh_nverts(mesh);
  const double L = ek_trial_body_size(mesh);
  double *dev = malloc(nv * sizeof(double));
  if (!dev) {
    ek_mesh_destroy(mesh);
    return -1;
  }
  ek_trial ref;
  memset(&ref, 0, sizeof ref);
  int rc = 0;
  for (int i = 0; i < l->n && rc == 0; ++i) {
    const loop_setting *c = &l->v[i];
    char setting[384];
    ek_trial_setting_text(&c->scene, setting, sizeof setting);
    fprintf(stderr, "  %s %d/%d %s\n", family, i + 1, l->n, setting);
    ek_trial tr;
    if (ek_trial_run(&c->scene, mesh, sim_time, 0, &tr) != 0) {
      fprintf(stderr, "tradeoff loops: %s: %s\n", family, tr.error);
      rc = -1;
      break;
    }
    if (i == 0 && (tr.failed || !c->is_reference)) {
      fprintf(stderr, "tradeoff loops: %s: the reference setting %s failed: %s\n", family, setting,
              tr.error);
      ek_trial_free(&tr);
      rc = -1;
      break;
    }
    ek_tradeoff_point p;
    memset(&p, 0, sizeof p);
    p.family = family;
    p.setting = setting;
    p.is_default = c->is_default;
    p.is_reference = c->is_reference;
    p.time_median = tr.cost_median;
    p.time_min = tr.cost_min;
    p.time_unit = "s/simulated s";
    p.threads = omp_get_max_threads();
    p.error_metric = metric;
    p.budget = NAN;
    p.energy_drift = tr.energy_drift;
    if (tr.failed) {
      // A failure is a point (its cost up to the failure, its error NaN).
      fprintf(stderr, "tradeoff loops: %s: %s failed: %s\n", family, setting, tr.error);
      p.count = 0;
      p.err_p50 = p.err_p99 = p.err_p9999 = p.err_max = NAN;
    } else {
      const double *x = tr.x, *xr = i == 0 ? tr.x : ref.x;
      for (size_t v = 0; v < nv; ++v) {
        double d2 = 0;
        for (int k = 0; k < 3; ++k)
          d2 += (x[3 * v + k] - xr[3 * v + k]) * (x[3 * v + k] - xr[3 * v + k]);
        dev[v] = sqrt(d2) / L;
      }
      ek_tradeoff_distribution(dev, (long)nv, &p);
    }
    rc = ek_tradeoff_add(t, &p);
    if (i == 0)
      ref = tr; // kept for the others
    else
      ek_trial_free(&tr);
  }
  ek_trial_free(&ref);
  free(dev);
  ek_mesh_destroy(mesh);
  return rc;
}

int ek_tradeoff_loops(ek_tradeoff *t) {
  static const char *const cantilever[3] = {"cantilever", "cantilever_implicit", "cantilever_xpbd"};
  static const char *const twist[3] = {"twist", "twist_implicit", "twist_xpbd"};
  setting_list l = {0};
  const int quick = ek_tradeoff_options(t)->quick;
  const double sim_time = quick ? LOOPS_QUICK_SIM_TIME : LOOPS_SIM_TIME;
  for (int ls = EK_LINSOLVE_AMG; ls < EK_LINSOLVE_COUNT; ++ls)
    if (!ek_linear_solver_available((ek_linear_solver)ls))
      fprintf(stderr,
              "tradeoff loops: implicit linear_solver %s skipped: it needs PETSc, and this build "
              "has none (the implicit points are matrix_free only)\n",
              ek_linear_solver_name((ek_linear_solver)ls));
  int rc = family_settings(&l, cantilever, 1, 2000);
  if (rc == 0)
    rc = run_family(t, "loop/cantilever", &l, sim_time);
  l.n = 0;
  if (rc == 0 && !quick)
    rc = family_settings(&l, twist, 0, 500);
  if (rc == 0)
    rc = run_family(t, "loop/twist", &l, sim_time);
  free(l.v);
  return rc;
}
