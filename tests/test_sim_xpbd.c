// Invariants of the XPBD integrator (sim/xpbd.c; contract in
// include/ek/sim/sim.h, ek_scene_xpbd, and include/ek/xpbd.h):
//   1. a free body without gravity keeps its momentum to rounding (tets
//      and clusters, Gauss-Seidel and Jacobi, f64 and f32);
//   2. XPBD against the implicit loop (backward Euler, StVK, same scene) at
//      the substep h = dt / K: the largest tip difference over 0.5 s of a
//      cantilever, as a table of sweeps N x substeps K. It shrinks as N
//      grows (down to the floor the dropped primal residual leaves) and as
//      K grows;
//   3. a bar hanging under gravity, damped to rest: XPBD's static tip
//      displacement at the default settings against the implicit loop's,
//      within EK_SIM_XPBD_STATIC_TOL;
//   4. 1 and 2 threads give the same bits (a mesh above the parallel grain).
// 1 and 3 also with the stable neo-Hookean constraints ("snh"), and 2 as
// one row (K = 4) against the implicit loop with the snh model.
#include <ek/sim/sim.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "test_sim_common.h"

// 1: momentum |p - p0| / sum m |v0|. f64: the corrections of a constraint
// sum to zero (grad_0 C = -sum grad_k C), so only rounding is left. f32:
// the sweeps run on float displacements from x~ (~1e-3 m per substep here),
// each update rounded to ~1e-10 m, against sum m |v| of 0.3 m/s (measured
// 1e-8 .. 1e-7).
#define MOMENTUM_TOL_F64 1e-12
#define MOMENTUM_TOL_F32 1e-6
// The stable neo-Hookean pair in f32: C_D and C_H are not 0 at rest
// (xpbd.h), so each correction (dl_D dC_D/dF + dl_H cof F) b_k is the
// difference of two terms ~k C |g| with C ~ 1, where StVK's is one term with
// C ~ the strain (~0.1 here): the rounding of an update is ~1 / strain =
// 10 times StVK's (measured 1e-8 .. 1.04e-6).
#define MOMENTUM_TOL_SNH_F32 1e-5
// 3: at the defaults (20 substeps of 5 sweeps) a soft bar (E = 1e5 Pa,
// strain 2.5%) at rest; the g = 0 floor vanishes there (x = x_n: the
// gradients do not move within a step), what is left is the unconverged
// sweeps' softness (measured 8.5e-4; 10 x 1 gives 0.35, sim.h).
#define EK_SIM_XPBD_STATIC_TOL 1e-2

// 1.
static void momentum_test(const char *model, const char *elements, const char *solver, int prec) {
  char json[2048];
  snprintf(json, sizeof json,
           "{\"mesh\": {\"box\": [4, 4, 4], \"size\": [0.1, 0.1, 0.1]},"
           " \"initial\": {\"scale\": [1.15, 0.95, 1.05], \"velocity\": [0.3, -0.2, 0.1]},"
           " \"material\": {\"model\": \"%s\", \"E\": 1e5, \"nu\": 0.3, \"density\": 1000},"
           " \"precision\": \"f%d\", \"dt\": 0.01, \"steps\": 1, \"integrator\": {\"type\": "
           "\"xpbd\", \"substeps\": 4, \"iterations\": 5, \"solver\": \"%s\", \"elements\": "
           "\"%s\"}}",
           model, prec, solver, elements);
  run r;
  if (start(&r, json, 0))
    return;
  const size_t nv = ek_mesh_nverts(r.mesh);
  const double *m = ek_sim_masses(r.sim), *v = ek_sim_velocities(r.sim);
  double p0[3], p[3], scale = 0, worst = 0;
  ek_sim_momentum(r.sim, p0);
  for (size_t i = 0; i < nv; i++)
    scale += m[i] *
             sqrt(v[3 * i] * v[3 * i] + v[3 * i + 1] * v[3 * i + 1] + v[3 * i + 2] * v[3 * i + 2]);
  int rc = 0;
  for (int n = 0; n < 50 && rc == 0; n++) {
    rc = ek_sim_step(r.sim);
    ek_sim_momentum(r.sim, p);
    worst = fmax(worst, sqrt((p[0] - p0[0]) * (p[0] - p0[0]) + (p[1] - p0[1]) * (p[1] - p0[1]) +
                             (p[2] - p0[2]) * (p[2] - p0[2])) /
                            scale);
  }
  char what[128], detail[256];
  snprintf(what, sizeof what, "momentum kept: %s %s %s f%d", model, elements, solver, prec);
  snprintf(detail, sizeof detail, "50 steps of 4 substeps, largest |p - p0| / sum m|v0|%s%s",
           rc ? ": " : "", rc ? ek_last_error() : "");
  const int snh = strcmp(model, "snh") == 0;
  report(what, rc ? INFINITY : worst,
         prec == 64 ? MOMENTUM_TOL_F64
         : snh      ? MOMENTUM_TOL_SNH_F32
                    : MOMENTUM_TOL_F32,
         detail);
  finish(&r);
}

// A cantilever (0.5 x 0.05 x 0.05 m, clamped at x = 0, E = 1e6 Pa, StVK or
// another model): tip z displacement per step.
static void cantilever_json_model(char *json, size_t n, const char *model, double dt, long steps,
                                  const char *integrator) {
  snprintf(json, n,
           "{\"mesh\": {\"box\": [40, 2, 4], \"size\": [0.5, 0.05, 0.05]},"
           " \"material\": {\"model\": \"%s\", \"E\": 1e6, \"nu\": 0.3, \"density\": 1000},"
           " \"precision\": \"f64\", \"boundary\": [{\"type\": \"pin\", \"region\": {\"min\": "
           "[0, 0, 0], \"max\": [0, 0.05, 0.05]}}], \"gravity\": [0, 0, -9.81], \"damping\": 2,"
           " \"dt\": %.17g, \"steps\": %ld, \"integrator\": %s}",
           model, dt, steps, integrator);
}

static void cantilever_json(char *json, size_t n, double dt, long steps, const char *integrator) {
  cantilever_json_model(json, n, "stvk", dt, steps, integrator);
}

// Tip z displacement after each of `steps` steps (tip[steps]); -1 on failure.
static int tip_trajectory(const char *json, long steps, long every, double *tip) {
  run r;
  if (start(&r, json, 0))
    return -1;
  const size_t nv = ek_mesh_nverts(r.mesh);
  const double *X = ek_mesh_rest_positions(r.mesh);
  double xmax = -INFINITY;
  for (size_t i = 0; i < nv; i++)
    xmax = fmax(xmax, X[3 * i]);
  int rc = 0;
  for (long n = 0; n < steps && rc == 0; n++) {
    rc = ek_sim_step(r.sim);
    if ((n + 1) % every)
      continue;
    tip[(n + 1) / every - 1] = end_face_dz(r.mesh, ek_sim_positions(r.sim), xmax);
  }
  if (rc)
    printf("step failed: %s\n", ek_last_error());
  finish(&r);
  return rc ? -1 : 0;
}

// 2.
static void convergence_table(void) {
  const double dt = 1.0 / 30, T = 0.5;
  const long steps = (long)(T / dt + 0.5);
  static const int sweeps[] = {1, 4, 16, 64}, subs[] = {1, 4, 16};
  double err[3][4], *ref = malloc((size_t)steps * sizeof(double)),
                    *tip = malloc((size_t)steps * sizeof(double)), peak = 0;
  char json[2048], integ[256];
  printf("XPBD vs implicit (backward Euler at h = dt / K), cantilever 0.5 m, StVK E = 1e6 Pa, "
         "%.1f s at dt = 1/30 s:\nlargest |tip_xpbd - tip_implicit| / largest |tip_implicit| "
         "over the sampled steps\n  K \\ N",
         T);
  for (int j = 0; j < 4; j++)
    printf(" %10d", sweeps[j]);
  printf("\n");
  int ok = 1;
  for (int i = 0; i < 3; i++) {
    const int K = subs[i];
    // The implicit loop at the substep, sampled at the steps of dt.
    cantilever_json(json, sizeof json, dt / K, steps * K,
                    "{\"type\": \"implicit\", \"newton_tol\": 1e-8}");
    if (tip_trajectory(json, steps * K, K, ref)) {
      failures++;
      goto done;
    }
    peak = 0;
    for (long n = 0; n < steps; n++)
      peak = fmax(peak, fabs(ref[n]));
    printf("  %2d    ", K);
    for (int j = 0; j < 4; j++) {
      snprintf(integ, sizeof integ, "{\"type\": \"xpbd\", \"substeps\": %d, \"iterations\": %d}", K,
               sweeps[j]);
      cantilever_json(json, sizeof json, dt, steps, integ);
      if (tip_trajectory(json, steps, 1, tip)) {
        failures++;
        goto done;
      }
      double e = 0;
      for (long n = 0; n < steps; n++)
        e = fmax(e, fabs(tip[n] - ref[n]));
      err[i][j] = e / peak;
      printf(" %10.3e", err[i][j]);
      fflush(stdout);
    }
    printf("\n");
  }
  // Shrinking as either grows: along every row and column no entry above
  // its left or upper neighbour (where XPBD has not yet moved the body at
  // all, 1 substep and 1 or 4 sweeps, both sit at the same ~200%: 1% is
  // left for that plateau's rounding), and the last entry of every row and
  // column below the first.
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 4; j++) {
      if (j > 0)
        ok &= err[i][j] <= 1.01 * err[i][j - 1];
      if (i > 0)
        ok &= err[i][j] <= 1.01 * err[i - 1][j];
    }
  for (int i = 0; i < 3; i++)
    ok &= err[i][3] < err[i][0];
  for (int j = 0; j < 4; j++)
    ok &= err[2][j] < err[0][j];
  check("XPBD error shrinks with sweeps and with substeps", ok,
        "no entry above its left or upper neighbour; each row's and column's last below its "
        "first");
done:
  free(ref);
  free(tip);
}

// 3.
// snh runs 80 substeps (xpbd.h): its multipliers are not small at rest
// (C_D, C_H are not 0 there), so the dropped primal residual leaves a bias
// the gradients' motion within a substep (~h^2 g) times those multipliers,
// which shrinks as h^2 but does not vanish at rest as StVK's does
// (measured: 1.8e-2 at the default 20 x 5, unchanged at 20 x 20, 1.6e-3
// at 80 x 5).
static void hanging_bar_test(const char *model) {
  char json[2048], xpbd[128];
  double tips[2];
  const int snh = strcmp(model, "snh") == 0;
  snprintf(xpbd, sizeof xpbd,
           snh ? "{\"type\": \"xpbd\", \"substeps\": 80}" : "{\"type\": \"xpbd\"}");
  const char *integ[2] = {"{\"type\": \"implicit\"}", xpbd};
  for (int k = 0; k < 2; k++) {
    snprintf(json, sizeof json,
             "{\"mesh\": {\"box\": [3, 3, 15], \"size\": [0.1, 0.1, 0.5]},"
             " \"material\": {\"model\": \"%s\", \"E\": 1e5, \"nu\": 0.3, \"density\": 1000},"
             " \"precision\": \"f64\", \"boundary\": [{\"type\": \"pin\", \"region\": {\"min\": "
             "[0, 0, 0.5], \"max\": [0.1, 0.1, 0.5]}}], \"gravity\": [0, 0, -9.81], "
             "\"damping\": 20, \"dt\": 0.0333333333333333, \"steps\": 90, \"integrator\": %s}",
             model, integ[k]);
    // The bottom face (z = 0): its mean z displacement.
    run r;
    if (start(&r, json, 0))
      return;
    int rc = 0;
    for (int n = 0; n < 90 && rc == 0; n++)
      rc = ek_sim_step(r.sim);
    const size_t nv = ek_mesh_nverts(r.mesh);
    const double *X = ek_mesh_rest_positions(r.mesh), *x = ek_sim_positions(r.sim);
    double s = 0;
    int c = 0;
    for (size_t i = 0; i < nv; i++)
      if (X[3 * i + 2] < 1e-9) {
        s += x[3 * i + 2] - X[3 * i + 2];
        c++;
      }
    tips[k] = rc ? NAN : s / c;
    finish(&r);
  }
  char detail[256];
  char what[128];
  snprintf(detail, sizeof detail, "bottom displacement after 3 s: implicit %.6e m, XPBD %s %.6e m",
           tips[0], snh ? "(80 substeps)" : "(defaults)", tips[1]);
  snprintf(what, sizeof what, "hanging bar at rest: XPBD vs implicit, %s", model);
  report(what, fabs(tips[1] - tips[0]) / fabs(tips[0]), EK_SIM_XPBD_STATIC_TOL, detail);
}

// 2b. The same comparison with the stable neo-Hookean constraints against
// the implicit loop with the snh model (the same energy up to a constant,
// xpbd.h): K = 4 and 16 substeps, N = 1, 4, 16 sweeps, reported only.
// The bias of the dropped primal residual grows with the multipliers,
// which are not small at rest with this pair (hanging_bar_test), so more
// sweeps do not bring XPBD nearer at a fixed K, and the table is not
// monotone (measured: K = 4: 0.21, 0.78, 0.96; K = 16: 0.97, 0.10, 0.16;
// StVK's K = 4 row 1.73, 0.81, 0.50): no ordering is claimed.
static void snh_vs_implicit(void) {
  const double dt = 1.0 / 30, T = 0.5;
  const long steps = (long)(T / dt + 0.5);
  const int subs[2] = {4, 16}, sweeps[3] = {1, 4, 16};
  double err[2][3] = {{0}}, *ref = malloc((size_t)steps * sizeof(double)),
         *tip = malloc((size_t)steps * sizeof(double));
  char json[2048], integ[256];
  int ok = 1;
  printf("XPBD snh vs implicit snh (at h = dt / K), the cantilever above:\n  K \\ N");
  for (int j = 0; j < 3; j++)
    printf(" %10d", sweeps[j]);
  printf("\n");
  for (int i = 0; i < 2; i++) {
    const int K = subs[i];
    double peak = 0;
    cantilever_json_model(json, sizeof json, "snh", dt / K, steps * K,
                          "{\"type\": \"implicit\", \"newton_tol\": 1e-8}");
    if (tip_trajectory(json, steps * K, K, ref)) {
      failures++;
      goto done;
    }
    for (long n = 0; n < steps; n++)
      peak = fmax(peak, fabs(ref[n]));
    printf("  %2d    ", K);
    for (int j = 0; j < 3; j++) {
      snprintf(integ, sizeof integ, "{\"type\": \"xpbd\", \"substeps\": %d, \"iterations\": %d}", K,
               sweeps[j]);
      cantilever_json_model(json, sizeof json, "snh", dt, steps, integ);
      if (tip_trajectory(json, steps, 1, tip)) {
        failures++;
        goto done;
      }
      for (long n = 0; n < steps; n++)
        err[i][j] = fmax(err[i][j], fabs(tip[n] - ref[n]) / peak);
      ok &= isfinite(err[i][j]);
      printf(" %10.3e", err[i][j]);
      fflush(stdout);
    }
    printf("\n");
  }
  check("XPBD snh vs implicit snh: every run finished, errors finite", ok,
        "the table is reported only (see above)");
done:
  free(ref);
  free(tip);
}

// 4.
static void threads_test(const char *elements, const char *solver) {
  char json[2048];
  snprintf(json, sizeof json,
           "{\"mesh\": {\"box\": [30, 12, 12], \"size\": [1.0, 0.4, 0.4]},"
           " \"material\": {\"model\": \"stvk\", \"E\": 1e6, \"nu\": 0.3, \"density\": 1000},"
           " \"precision\": \"f32\", \"boundary\": [{\"type\": \"pin\", \"region\": {\"min\": [0, "
           "0, 0], \"max\": [0, 0.4, 0.4]}}], \"gravity\": [0, 0, -9.81], \"dt\": 0.01,"
           " \"steps\": 2, \"integrator\": {\"type\": \"xpbd\", \"substeps\": 2, \"iterations\": "
           "3, \"solver\": \"%s\", \"elements\": \"%s\"}}",
           solver, elements);
  long mismatches[4];
  size_t n3 = 0, nc = 0;
  int ok = thread_mismatches(json, 2, 3, mismatches, &n3, &nc) == 0;
  char what[128], detail[200];
  snprintf(what, sizeof what, "same bits at 1, 2 and 3 threads: %s %s", elements, solver);
  snprintf(detail, sizeof detail,
           "%zu constraints, 2 steps: %ld coordinates differ at 2 threads, %ld at 3", nc,
           mismatches[2], mismatches[3]);
  check(what, ok && mismatches[2] == 0 && mismatches[3] == 0, detail);
}

int main(int argc, char **argv) {
  scenes_dir_init(argc, argv);
  printf("test_sim_xpbd\n");
  static const char *el[2] = {"tets", "clusters"}, *so[2] = {"gauss_seidel", "jacobi"};
  for (int e = 0; e < 2; e++)
    for (int s = 0; s < 2; s++) {
      momentum_test("stvk", el[e], so[s], 64);
      momentum_test("stvk", el[e], so[s], 32);
      momentum_test("snh", el[e], so[s], 64);
      momentum_test("snh", el[e], so[s], 32);
      threads_test(el[e], so[s]);
    }
  hanging_bar_test("stvk");
  hanging_bar_test("snh");
  convergence_table();
  snh_vs_implicit();
  printf("%s\n", failures ? "FAILED" : "ALL PASSED");
  return failures ? 1 : 0;
}
