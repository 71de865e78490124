// Shared by the simulation tests (test_sim_core.c, test_sim_explicit.c,
// test_sim_implicit.c): their pass/fail lines and the shipped scenes'
// folder.
#ifndef EK_TEST_SIM_COMMON_H
#define EK_TEST_SIM_COMMON_H

#include <stdio.h>
#include <string.h>

static int failures = 0;
static char scenes_dir[1024];

// A measured error against its budget: PASS, MARGINAL (above half the
// budget) or FAIL.
static void report(const char *what, double err, double budget, const char *detail) {
  double ratio = err / budget;
  const char *v = !(ratio <= 1.0) ? "FAIL" : ratio > 0.5 ? "MARGINAL" : "PASS";
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

// scenes/ beside tests/ (this header's folder), or `--scenes DIR`.
static void scenes_dir_init(int argc, char **argv) {
  snprintf(scenes_dir, sizeof scenes_dir, "%s", __FILE__);
  char *slash = strrchr(scenes_dir, '/');
  if (slash)
    snprintf(slash, sizeof scenes_dir - (size_t)(slash - scenes_dir), "/../scenes");
  else
    snprintf(scenes_dir, sizeof scenes_dir, "../scenes");
  for (int i = 1; i + 1 < argc; ++i)
    if (strcmp(argv[i], "--scenes") == 0)
      snprintf(scenes_dir, sizeof scenes_dir, "%s", argv[i + 1]);
}

#endif
