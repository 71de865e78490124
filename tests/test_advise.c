// The scene advisor (sim/advise.h, ek-sim --advise) picks the cheapest
// candidate whose deviation from the most accurate setting is within X:
// (1) with X = 0 it picks the reference configuration (deviation 0 by
//     definition; every other setting deviates);
// (2) on scenes/small_strain.json, whose Green strain stays below 1% (the
//     reference run's monitor shows it), it picks a model whose step takes
//     no SVD (linear, StVK, neo-Hookean, stable neo-Hookean) when such a
//     candidate is within X (the default 1% of the body size), and the
//     pick's measured deviation is <= X.
// Each candidate runs the scene's first 0.1 s (ek-sim --advise --time 0.1):
// the test stays well under a minute on 2 cores.
// Plus: the table has one row per candidate with a verdict, and a model
// outside its validity range is skipped with a reason (ARAP and Psi_R:
// this scene has a volume term, nu = 0.3).
#include "advise.h"
#include "test_sim_common.h"

#include <math.h>

int main(int argc, char **argv) {
  scenes_dir_init(argc, argv);
  char path[2048], err[1024];
  snprintf(path, sizeof path, "%s/small_strain.json", scenes_dir);
  ek_scene scene;
  if (ek_scene_load(path, &scene) != 0) {
    printf("FAIL loading %s: %s\n", path, ek_last_error());
    return 1;
  }
  ek_mesh *mesh = ek_scene_mesh(&scene);
  if (!mesh) {
    printf("FAIL mesh: %s\n", ek_last_error());
    return 1;
  }
  const double tol = EK_ADVISE_TOL_DEFAULT;
  ek_advise_opts o = {.tol = tol, .sim_time = 0.1, .progress = stderr};
  ek_advice a;
  if (ek_advise(&scene, mesh, &o, &a, err, sizeof err) != 0) {
    printf("FAIL ek_advise: %s\n", err);
    ek_mesh_destroy(mesh);
    return 1;
  }
  ek_advice_print(&a, stdout);

  char detail[512];
  // The scene is what it says: Green strain |F^T F - I| / 2 below 1%.
  snprintf(detail, sizeof detail, "max |F^T F - I| / 2 = %.3g", a.reach.max_strain / 2);
  check("small_strain: Green strain below 1%", a.reach.max_strain / 2 < 0.01, detail);

  // (1) X = 0: the reference, and nothing else deviates by exactly 0.
  long pick0 = ek_advice_pick(&a, 0.0);
  snprintf(detail, sizeof detail, "pick #%ld, reference #%zu", pick0 + 1, a.reference + 1);
  check("tol 0 picks the reference configuration", pick0 == (long)a.reference, detail);

  // (2) X = 1%: a no-SVD model when one is within X.
  long pick = a.pick;
  size_t nosvd_within = 0, skipped = 0, ran = 0;
  for (size_t i = 0; i < a.n; ++i) {
    const ek_advise_row *r = &a.rows[i];
    skipped += r->skipped;
    ran += !r->skipped;
    if (!r->skipped && !r->failed && !r->uses_svd && r->deviation <= tol)
      nosvd_within++;
  }
  snprintf(detail, sizeof detail, "%zu candidates ran, %zu skipped, %zu without SVD within X", ran,
           skipped, nosvd_within);
  check("candidates without an SVD exist within X", nosvd_within > 0, detail);
  check("models outside their range are skipped (ARAP, Psi_R: nu = 0.3)", skipped >= 2, detail);
  check("ek_advise's pick is ek_advice_pick(tol)", pick == ek_advice_pick(&a, tol), "");
  if (pick >= 0) {
    const ek_advise_row *p = &a.rows[pick];
    const ek_model m = p->setting.material.model;
    const int nosvd_model = m == EK_MODEL_LINEAR || m == EK_MODEL_STVK ||
                            m == EK_MODEL_NEO_HOOKEAN || m == EK_MODEL_STABLE_NEO_HOOKEAN;
    snprintf(detail, sizeof detail, "#%ld %s", pick + 1, p->text);
    check("tol 1%: the pick's step takes no SVD", nosvd_within == 0 || !p->uses_svd, detail);
    check("tol 1%: the pick is linear, StVK, NH or SNH", nosvd_within == 0 || nosvd_model, detail);
    report("tol 1%: the pick's measured deviation", p->deviation, tol, p->text);
    // The pick is the cheapest within X.
    int cheapest = 1;
    for (size_t i = 0; i < a.n; ++i) {
      const ek_advise_row *r = &a.rows[i];
      if (!r->skipped && !r->failed && r->deviation <= tol && r->cost < p->cost)
        cheapest = 0;
    }
    check("tol 1%: no cheaper candidate within X", cheapest, detail);
  } else {
    check("tol 1%: a pick exists (the reference is always within)", 0, "");
  }
  ek_advice_free(&a);
  ek_mesh_destroy(mesh);
  printf("%s: %d failure(s)\n", argv[0], failures);
  return failures ? 1 : 0;
}
