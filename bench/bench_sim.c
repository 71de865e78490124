// ek-bench family "sim": the explicit loop (sim/explicit.c) on every shipped
// scene, per step: FVM force (fused kernel), R^n refresh where the model
// needs it, integration, boundary conditions and ground; no frame output.
//
// Rows: sim/<scene>/<model>/<isa>/<prec>/tets:<N>/threads:<T>; one call is
// STEPS_PER_CALL steps, so the per-item time is the time per step. The
// simulation keeps running across calls (a scene has no end; its step count
// is only the default length of a run). After each row the split by phase
// (deformation gradient, SVD/polar, P, scatter from the FVM kernel's
// phase-timed passes; integration; R^n refresh) is measured on PHASE_STEPS
// more steps and recorded as a note, in ms per step.
#include <ek/sim.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench.h"

enum { STEPS_PER_CALL = 10, PHASE_STEPS = 20 };

typedef struct {
  ek_sim *sim;
  ek_bench *b;
  int failed;
} sim_ctx;

static void run_steps(void *p) {
  sim_ctx *c = p;
  for (int i = 0; i < STEPS_PER_CALL && !c->failed; ++i) {
    int rc = ek_sim_step(c->sim);
    if (rc != 0) {
      c->failed = 1;
      ek_bench_fail(c->b, "sim: step failed (rc %d): %s", rc, ek_sim_last_error(c->sim));
    }
  }
}

// The shipped scenes, found relative to this source file (CMake compiles
// with an absolute __FILE__).
static void scene_path(const char *name, char *out, size_t outlen) {
  char dir[1024];
  snprintf(dir, sizeof dir, "%s", __FILE__);
  char *slash = strrchr(dir, '/');
  if (slash)
    *slash = '\0';
  else
    snprintf(dir, sizeof dir, ".");
  snprintf(out, outlen, "%s/../scenes/%s.json", dir, name);
}

int bench_sim(ek_bench *b) {
  static const char *scenes[] = {"cantilever", "twist", "drop", "crush"};
  int counts[EK_BENCH_MAX_THREAD_COUNTS];
  int ncounts = ek_bench_thread_counts(b, counts);
  int rc = 0;
  for (size_t k = 0; k < sizeof scenes / sizeof scenes[0]; ++k) {
    char path[1200], err[1024];
    static ek_scene scene;
    scene_path(scenes[k], path, sizeof path);
    if (ek_scene_load(path, &scene, err, sizeof err) != 0) {
      ek_bench_fail(b, "sim: %s", err);
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
      sim_ctx ctx = {NULL, b, 0};
      if (!ek_bench_listing(b)) {
        if (!mesh && !(mesh = ek_scene_mesh(&scene, err, sizeof err))) {
          ek_bench_fail(b, "sim: %s: %s", scenes[k], err);
          rc = -1;
          break;
        }
        if (!(ctx.sim = ek_sim_create(&scene, mesh, err, sizeof err))) {
          ek_bench_fail(b, "sim: %s: %s", scenes[k], err);
          rc = -1;
          continue;
        }
      }
      snprintf(knobs, sizeof knobs, "scene=%s;model=%s;steps_per_call=%d;dt=%g", scenes[k],
               scene.model_name, STEPS_PER_CALL, scene.dt);
      ek_bench_row row = {.name = name,
                          .family = "sim",
                          .isa = isa,
                          .precision = prec,
                          .threads = counts[t],
                          .knobs = knobs,
                          .items = STEPS_PER_CALL,
                          .fn = run_steps,
                          .ctx = &ctx};
      if (ek_bench_run(b, &row) != 0)
        rc = -1;
      if (ctx.sim && !ctx.failed) {
        // The split, on a few more steps of the same run (same threads:
        // the harness set them for the row).
        ek_sim_times before = *ek_sim_timings(ctx.sim);
        ek_sim_time_phases(ctx.sim, 1);
        for (int i = 0; i < PHASE_STEPS && ek_sim_step(ctx.sim) == 0; ++i)
          ;
        const ek_sim_times *after = ek_sim_timings(ctx.sim);
        double n = (double)(after->steps - before.steps);
        if (n > 0)
          ek_bench_note(b,
                        "%s: ms per step by phase (separate passes): deformation gradient "
                        "%.4f, SVD/polar %.4f, P %.4f, scatter %.4f, integration %.4f, R^n "
                        "refresh %.4f",
                        name, 1e3 * (after->deformation_gradient - before.deformation_gradient) / n,
                        1e3 * (after->svd_polar - before.svd_polar) / n,
                        1e3 * (after->pk1 - before.pk1) / n,
                        1e3 * (after->scatter - before.scatter) / n,
                        1e3 * (after->integration - before.integration) / n,
                        1e3 * (after->polar_refresh - before.polar_refresh) / n);
      }
      ek_sim_destroy(ctx.sim);
    }
    ek_mesh_destroy(mesh);
  }
  return rc;
}
