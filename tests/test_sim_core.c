// Invariants of the simulation core shared by the integrators:
//  1. The frames' energy density (ek_sim_tet_fields) is measured from the
//     rest shape, like ek_sim_energy's elastic energy: 0 at rest for every
//     model (stable neo-Hookean's Psi(I) is not 0), and sum_e V0_e psi_e
//     equals the elastic energy once the body has deformed, both within
//     EK_SIM_ENERGY_FIELD_TOL (norms in sim.h).
//  2. A sim steps with the scene's integrator and names it.
//
// The scene is the shipped drop (scenes/drop.json: a cube falling onto the
// ground), with stable neo-Hookean as shipped and with corotated linear (no
// rest value to subtract); 1000 steps take it past the impact.
#include <ek/sim/sim.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "test_sim_common.h"
#include "test_tolerances.h"

// Psi(F) per tet of positions x, not shifted: what the field held before it
// was measured from the rest shape. Corotated linear is evaluated with
// R = I, its R^n at the rest shape (polar(I) = I).
static int raw_psi(const ek_mesh *m, const ek_scene *s, const double *x, double *psi) {
  size_t nt = ek_mesh_ntets(m);
  double *f = malloc(3 * ek_mesh_nverts(m) * sizeof(double)), *R = calloc(9 * nt, sizeof(double));
  for (size_t e = 0; R && e < nt; ++e)
    R[9 * e] = R[9 * e + 4] = R[9 * e + 8] = 1;
  ek_fvm_opts o = {0};
  o.psi = psi;
  o.R = R;
  int rc = f && R ? ek_mesh_fvm_forces_ex_f64(m, &s->material, x, f, &o) : EK_ENOMEM;
  free(f);
  free(R);
  return rc;
}

static void field_test(const char *model) {
  char path[1200], what[96], detail[256];
  ek_scene s;
  snprintf(path, sizeof path, "%s/drop.json", scenes_dir);
  if (ek_scene_load(path, &s) != 0) {
    printf("cannot load %s: %s\n", path, ek_last_error());
    failures++;
    return;
  }
  s.output_file[0] = '\0';
  if (strcmp(model, s.model_name) != 0) {
    ek_scene_model_from_name(model, &s.material.model);
    snprintf(s.model_name, sizeof s.model_name, "%s", model);
  }
  ek_mesh *m = ek_scene_mesh(&s);
  ek_sim *sim = m ? ek_sim_create(&s, m) : NULL;
  size_t nt = m ? ek_mesh_ntets(m) : 0;
  double *psi = malloc(nt * sizeof(double)), *psi_rest = malloc(nt * sizeof(double));
  if (!sim || !psi || !psi_rest || raw_psi(m, &s, ek_mesh_rest_positions(m), psi_rest) != 0) {
    printf("drop (%s): %s\n", model, sim ? ek_last_error() : ek_last_error());
    failures++;
    goto done;
  }
  const double *V0 = ek_mesh_rest_volumes(m);

  // 1a. At rest (the initial state is the rest shape, translated).
  double max_field = 0, max_rest = 0;
  int rc = ek_sim_tet_fields(sim, NULL, NULL, psi);
  for (size_t e = 0; e < nt; ++e) {
    max_field = fmax(max_field, fabs(psi[e]));
    max_rest = fmax(max_rest, fabs(psi_rest[e]));
  }
  double stress_scale = s.material.mu + fabs(s.material.lambda);
  snprintf(detail, sizeof detail,
           "max |field| %.3g J/m^3 at t = 0; |Psi(F_rest)| up to %.6g J/m^3; mu + |lambda| %.3g",
           max_field, max_rest, stress_scale);
  snprintf(what, sizeof what, "%s: energy density 0 at rest", model);
  report(what, rc == 0 ? max_field / stress_scale : INFINITY, EK_SIM_ENERGY_FIELD_TOL, detail);

  // 1b. After the impact: the field sums to the elastic energy.
  long steps = 1000;
  for (long n = 0; n < steps && rc == 0; ++n)
    rc = ek_sim_step(sim);
  ek_sim_energies en;
  if (rc == 0)
    rc = ek_sim_energy(sim, &en);
  if (rc == 0)
    rc = ek_sim_tet_fields(sim, NULL, NULL, psi);
  double sum = 0, size = 0;
  for (size_t e = 0; rc == 0 && e < nt; ++e) {
    sum += V0[e] * psi[e];
    size += V0[e] * (fabs(psi[e] + psi_rest[e]) + fabs(psi_rest[e]));
  }
  snprintf(detail, sizeof detail, "t = %g s: sum V0 field %.12g J, elastic energy %.12g J",
           ek_sim_time(sim), sum, rc == 0 ? en.elastic : NAN);
  snprintf(what, sizeof what, "%s: sum V0 field = elastic energy", model);
  report(what, rc == 0 && size > 0 ? fabs(sum - en.elastic) / size : INFINITY,
         EK_SIM_ENERGY_FIELD_TOL, detail);
  if (rc)
    printf("    step %ld failed: %s\n", ek_sim_steps_done(sim), ek_last_error());
  // The body must have deformed, or the sum compares zeros.
  snprintf(detail, sizeof detail, "elastic energy %.3g J", rc == 0 ? en.elastic : NAN);
  snprintf(what, sizeof what, "%s: deformed after the impact", model);
  check(what, rc == 0 && en.elastic > 0, detail);
done:
  free(psi);
  free(psi_rest);
  ek_sim_destroy(sim);
  ek_mesh_destroy(m);
}

static void integrator_test(void) {
  ek_scene s;
  int rc = ek_scene_parse("{\"mesh\": {\"box\": [2, 2, 2], \"size\": [1, 1, 1]}, "
                          "\"material\": {\"model\": \"arap\", \"E\": 1e5, \"nu\": 0.3, "
                          "\"density\": 1000}, \"dt\": 1e-4, \"steps\": 10, "
                          "\"integrator\": {\"type\": \"explicit\"}}",
                          "integrator.json", ".", &s);
  ek_mesh *m = rc == 0 ? ek_scene_mesh(&s) : NULL;
  ek_sim *sim = m ? ek_sim_create(&s, m) : NULL;
  rc = sim ? ek_sim_step(sim) : -1;
  const char *name = sim ? ek_sim_integrator_name(sim) : ek_last_error();
  char detail[1100];
  snprintf(detail, sizeof detail, "integrator \"%s\", step rc %d", name, rc);
  check("sim steps with the scene's integrator", rc == 0 && strcmp(name, "explicit") == 0, detail);
  ek_sim_destroy(sim);
  ek_mesh_destroy(m);
}

int main(int argc, char **argv) {
  unsigned long long seed = scenes_dir_init(argc, argv);
  // Deterministic (shipped scene, no random inputs); the seed is accepted
  // and printed for uniformity with the other tests.
  printf("test_sim_core --seed %llu (scenes from %s)\n", seed, scenes_dir);
  field_test("stable_neo_hookean");
  field_test("corotated_linear");
  integrator_test();
  printf("%s\n", failures ? "FAILED" : "ALL PASSED");
  return failures ? 1 : 0;
}
