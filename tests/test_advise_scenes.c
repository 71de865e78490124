// The advisor (sim/advise.h) on every shipped tet scene (scenes/*.json; the
// cloths are not advised): the pick at tol 1e-2, re-run, is within tol of
// the advisor's converged reference, passes every check, and
// the reference's refinement converged (its last change <= tol / 10). Each
// scene runs a short time to keep ctest's time (label "slow": about 2 to 3
// minutes on 2 cores): 200 steps of the scene's dt when explicit (fewer: a free fall's
// explicit error is 1 / steps of its motion), one step
// of it otherwise (a thirtieth or sixtieth of a second), at most the
// scene's duration; scenes of more than EK_ADVISE_TEST_MAX_TETS tets only
// when named. EK_ADVISE_SCENES="a.json b.json" runs only those. An implicit
// scene's candidates include its setting with each assembled linear solver
// (amg, direct) in f64 and f32 when the build has PETSc, none otherwise.
#include "advise.h"
#include "test_sim_common.h"

#include <dirent.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

// Scenes with more tets run only when named (bracket: 120273 tets,
// cantilever*: 6000, about 4 minutes each on 2 busy cores).
#define EK_ADVISE_TEST_MAX_TETS 3000

static int by_name(const void *a, const void *b) {
  return strcmp(*(char *const *)a, *(char *const *)b);
}

static void advise_scene(const char *name, int named) {
  char path[2048], err[1024], detail[1200], what[256];
  snprintf(path, sizeof path, "%s/%s", scenes_dir, name);
  ek_scene scene;
  if (ek_scene_load(path, &scene) != 0) {
    check(name, 0, ek_last_error());
    return;
  }
  if (scene.triangles)
    return;
  ek_mesh *mesh = ek_scene_mesh(&scene);
  if (!mesh) {
    check(name, 0, ek_last_error());
    return;
  }
  if (!named && ek_mesh_ntets(mesh) > EK_ADVISE_TEST_MAX_TETS) {
    printf("%-52s skipped: %zu tets, more than %d (EK_ADVISE_SCENES=%s runs it)\n", name,
           ek_mesh_ntets(mesh), EK_ADVISE_TEST_MAX_TETS, name);
    ek_mesh_destroy(mesh);
    return;
  }
  const double tol = 1e-2;
  const double T = fmin(scene.dt * (double)scene.steps,
                        scene.integrator == EK_INTEGRATOR_EXPLICIT ? 200 * scene.dt : scene.dt);
  ek_advise_opts o = {.tol = tol, .sim_time = T, .rounds = 1, .progress = NULL};
  ek_advice a;
  struct timespec t0, t1;
  clock_gettime(CLOCK_MONOTONIC, &t0);
  if (ek_advise(&scene, mesh, &o, &a, err, sizeof err) != 0) {
    snprintf(what, sizeof what, "%s: ek_advise", name);
    check(what, 0, err);
    ek_mesh_destroy(mesh);
    return;
  }
  clock_gettime(CLOCK_MONOTONIC, &t1);
  const ek_advise_refinement *f = &a.refine;
  snprintf(detail, sizeof detail, "%g s simulated, %zu rows, %.1f s wall; %s", T, a.n,
           (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec), f->stop);
  snprintf(what, sizeof what, "%s: reference converged", name);
  check(what, f->converged, detail);
  // The solver axis (issue 24, advise.h): an implicit scene's own setting
  // with each assembled linear solver, in f64 and f32, among the rows that
  // ran, their text naming the solver; none without PETSc.
  if (scene.integrator == EK_INTEGRATOR_IMPLICIT &&
      scene.implicit.linear_solver == EK_LINSOLVE_MATRIX_FREE)
    for (int ls = EK_LINSOLVE_AMG; ls < EK_LINSOLVE_COUNT; ++ls) {
      const char *lsn = ek_linear_solver_name((ek_linear_solver)ls);
      char key[64];
      snprintf(key, sizeof key, "linear_solver=%s", lsn);
      int prec[2] = {0, 0}, bad = 0;
      size_t rows = 0;
      for (size_t i = 0; i < a.n; ++i) {
        const ek_advise_row *r = &a.rows[i];
        if (r->setting.integrator != EK_INTEGRATOR_IMPLICIT ||
            r->setting.implicit.linear_solver != (ek_linear_solver)ls)
          continue;
        rows++;
        bad += r->skipped || r->rounds < 1 || !strstr(r->text, key);
        if (r->setting.material.model == scene.material.model)
          prec[r->setting.precision == 32] = 1;
      }
      if (ek_linear_solver_available((ek_linear_solver)ls)) {
        snprintf(what, sizeof what, "%s: %s candidates (f64, f32)", name, lsn);
        snprintf(detail, sizeof detail, "%zu rows, f64 %s, f32 %s, %d not run or not named", rows,
                 prec[0] ? "yes" : "no", prec[1] ? "yes" : "no", bad);
        check(what, prec[0] && prec[1] && bad == 0, detail);
      } else {
        snprintf(what, sizeof what, "%s: no %s rows (no PETSc)", name, lsn);
        snprintf(detail, sizeof detail, "%zu rows; skipped: this build has no PETSc", rows);
        check(what, rows == 0, detail);
      }
    }
  if (a.pick < 0) {
    snprintf(what, sizeof what, "%s: a pick", name);
    check(what, 0, "none within tol (the reference itself failed a check)");
  } else {
    const ek_advise_row *p = &a.rows[a.pick];
    ek_trial pt;
    // The pick re-run; the advisor's reference frames (a.ref: one run, or
    // the extrapolation of two).
    int rc = ek_trial_run_frames(&p->setting, mesh, T, 0, a.nframes, &pt);
    ek_advise_measure m;
    if (rc == 0) {
      ek_advise_measure_trial(mesh, &pt, &a.ref, scene.allow_inverted, &m);
      snprintf(detail, sizeof detail, "#%ld %s%s%s", a.pick + 1, p->text,
               m.failed ? ": FAILURE " : "", m.failed ? m.reason : "");
      snprintf(what, sizeof what, "%s: the pick re-run passes the checks", name);
      check(what, !m.failed, detail);
      snprintf(what, sizeof what, "%s: the pick re-run vs the reference", name);
      report(what, m.deviation, tol, detail);
    } else {
      snprintf(what, sizeof what, "%s: re-run", name);
      check(what, 0, pt.error);
    }
    ek_trial_free(&pt);
  }
  ek_advice_free(&a);
  ek_mesh_destroy(mesh);
}

int main(int argc, char **argv) {
  scenes_dir_init(argc, argv);
  char *names[256];
  int n = 0;
  // EK_ADVISE_SCENES="a.json b.json": only those (the arguments are
  // ek_cli_test_args').
  char *only = getenv("EK_ADVISE_SCENES") ? strdup(getenv("EK_ADVISE_SCENES")) : NULL;
  for (char *tok = only ? strtok(only, " ") : NULL; tok && n < 256; tok = strtok(NULL, " "))
    names[n++] = tok;
  if (n == 0) {
    DIR *d = opendir(scenes_dir);
    struct dirent *e;
    while (d && (e = readdir(d)) && n < 256) {
      size_t len = strlen(e->d_name);
      if (len > 5 && strcmp(e->d_name + len - 5, ".json") == 0)
        names[n++] = strdup(e->d_name);
    }
    if (d)
      closedir(d);
    qsort(names, (size_t)n, sizeof *names, by_name);
  }
  check("scenes found", n > 0, scenes_dir);
  for (int i = 0; i < n; ++i) {
    advise_scene(names[i], only != NULL);
    fflush(stdout);
  }
  printf("%s: %d failure(s)\n", argv[0], failures);
  return failures ? 1 : 0;
}
