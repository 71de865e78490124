// Shared by the simulation tests (test_sim_core.c, test_sim_explicit.c,
// test_sim_implicit.c, test_sim_xpbd.c): their pass/fail lines, the shipped
// scenes' folder, a scene run from text or file, and the 1 vs 2 threads
// comparison.
#ifndef EK_TEST_SIM_COMMON_H
#define EK_TEST_SIM_COMMON_H

#include "check.h"
#include "cli.h"
#include <ek/sim/sim.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int failures = 0;
static char scenes_dir[1024];

// A measured error against its budget: PASS, MARGINAL (above half the
// budget) or FAIL.
static void report(const char *what, double err, double budget, const char *detail) {
  double ratio = err / budget;
  const char *v = ek_verdict_name(ek_check_verdict(err, budget));
  printf("%-52s err %.3e  budget %.1e  err/budget %.3f  %s  %s\n", what, err, budget, ratio, v,
         detail);
  if (!(ratio <= 1.0))
    failures++;
}

static void check(const char *what, int ok, const char *detail) {
  printf("%-52s %s  %s\n", what, ok ? "PASS" : "FAIL", detail);
  if (!ok)
    failures++;
}

// Parses the test's arguments ([--seed N] [--scenes DIR], cli.h) and sets
// scenes_dir: scenes/ beside tests/ (this header's folder), or DIR. Returns
// the seed.
static unsigned long long scenes_dir_init(int argc, char **argv) {
  const char *scenes = NULL;
  unsigned long long seed = ek_cli_test_args(argc, argv, 1, &scenes);
  if (scenes)
    snprintf(scenes_dir, sizeof scenes_dir, "%s", scenes);
  else {
    snprintf(scenes_dir, sizeof scenes_dir, "%s", __FILE__);
    char *slash = strrchr(scenes_dir, '/');
    if (slash)
      snprintf(slash, sizeof scenes_dir - (size_t)(slash - scenes_dir), "/../scenes");
    else
      snprintf(scenes_dir, sizeof scenes_dir, "../scenes");
  }
  return seed;
}

// A scene (JSON text, or a shipped scene's name when is_file), its mesh and
// its simulation, no frame output. -1 (reported as a failure) if any of
// them is refused.
typedef struct {
  ek_scene scene;
  ek_mesh *mesh;
  ek_sim *sim;
} run;

static inline int start(run *r, const char *json_or_name, int is_file) {
  char path[1200];
  memset(r, 0, sizeof *r);
  int rc;
  if (is_file) {
    snprintf(path, sizeof path, "%s/%s.json", scenes_dir, json_or_name);
    rc = ek_scene_load(path, &r->scene);
  } else {
    rc = ek_scene_parse(json_or_name, "test.json", ".", &r->scene);
  }
  r->scene.output_file[0] = '\0';
  if (rc == 0 && (r->mesh = ek_scene_mesh(&r->scene)))
    r->sim = ek_sim_create(&r->scene, r->mesh);
  if (!r->sim) {
    printf("%s: %s\nFAIL\n", is_file ? json_or_name : "scene", ek_last_error());
    failures++;
    ek_mesh_destroy(r->mesh);
    return -1;
  }
  return 0;
}

static inline void finish(run *r) {
  ek_sim_destroy(r->sim);
  ek_mesh_destroy(r->mesh);
}

// Mean z displacement of the vertices on the face x = L: a cantilever's
// free end along x (the beam axis' deflection there).
static inline double end_face_dz(const ek_mesh *mesh, const double *x, double L) {
  const double *X = ek_mesh_rest_positions(mesh);
  double sum = 0;
  int count = 0;
  for (size_t i = 0; i < ek_mesh_nverts(mesh); ++i)
    if (fabs(X[3 * i] - L) <= 1e-9 * L) {
      sum += x[3 * i + 2] - X[3 * i + 2];
      count++;
    }
  return sum / count;
}

// `steps` steps of the scene text at 1, 2, ..., max_threads threads
// (max_threads <= 3; 3 is more than this machine's 2 cores: a thread often
// waits for a core): mismatches[t], the coordinates whose bits at t
// threads differ from 1 thread's; the coordinate count (*n3) and the XPBD
// constraints (*nc, 0 for other integrators). 0 if every step ran.
static inline int thread_mismatches(const char *json, int steps, int max_threads,
                                    long mismatches[4], size_t *n3, size_t *nc) {
  double *x1 = NULL;
  int ok = 1;
  for (int t = 0; t < 4; t++)
    mismatches[t] = 0;
  for (int threads = 1; threads <= max_threads && threads <= 3 && ok; threads++) {
    omp_set_num_threads(threads);
    run r;
    if (start(&r, json, 0)) {
      ok = 0;
      break;
    }
    *n3 = 3 * ek_mesh_nverts(r.mesh);
    *nc = ek_sim_xpbd_constraints(r.sim);
    for (int n = 0; n < steps; n++)
      ok &= ek_sim_step(r.sim) == 0;
    const double *x = ek_sim_positions(r.sim);
    if (threads == 1) {
      x1 = malloc(*n3 * sizeof(double));
      ok &= x1 != NULL;
      if (x1)
        memcpy(x1, x, *n3 * sizeof(double));
    } else {
      for (size_t i = 0; i < *n3; i++)
        mismatches[threads] += memcmp(&x[i], &x1[i], sizeof(double)) != 0;
    }
    finish(&r);
  }
  omp_set_num_threads(2);
  free(x1);
  return ok ? 0 : -1;
}

#endif
