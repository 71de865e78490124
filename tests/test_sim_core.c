// Invariants of the simulation core shared by the integrators:
//  1. A sim steps with the scene's integrator and names it.
#include <ek/sim.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int failures = 0;

static void check(const char *what, int ok, const char *detail) {
  printf("%-52s %s  %s\n", what, ok ? "PASS" : "FAIL", detail);
  if (!ok)
    failures++;
}

static void integrator_test(void) {
  char err[1024];
  ek_scene s;
  int rc = ek_scene_parse("{\"mesh\": {\"box\": [2, 2, 2], \"size\": [1, 1, 1]}, "
                          "\"material\": {\"model\": \"arap\", \"E\": 1e5, \"nu\": 0.3, "
                          "\"density\": 1000}, \"dt\": 1e-4, \"steps\": 10, "
                          "\"integrator\": {\"type\": \"explicit\"}}",
                          "integrator.json", ".", &s, err, sizeof err);
  ek_mesh *m = rc == 0 ? ek_scene_mesh(&s, err, sizeof err) : NULL;
  ek_sim *sim = m ? ek_sim_create(&s, m, err, sizeof err) : NULL;
  rc = sim ? ek_sim_step(sim) : -1;
  const char *name = sim ? ek_sim_integrator_name(sim) : err;
  char detail[1100];
  snprintf(detail, sizeof detail, "integrator \"%s\", step rc %d", name, rc);
  check("sim steps with the scene's integrator", rc == 0 && strcmp(name, "explicit") == 0, detail);
  ek_sim_destroy(sim);
  ek_mesh_destroy(m);
}

int main(int argc, char **argv) {
  unsigned long long seed = 1;
  for (int i = 1; i < argc; ++i)
    if (strcmp(argv[i], "--seed") == 0 && i + 1 < argc)
      seed = strtoull(argv[++i], NULL, 10);
  // Deterministic (no random inputs); the seed is accepted and printed for
  // uniformity with the other tests.
  printf("test_sim_core --seed %llu\n", seed);
  integrator_test();
  printf("%s\n", failures ? "FAILED" : "ALL PASSED");
  return failures ? 1 : 0;
}
