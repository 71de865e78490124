// libFuzzer harness: the scene reader (JSON through cJSON) and the scene
// with its integrator. An input is the scene file, loaded with
// ek_scene_load (so NUL bytes and sizes are seen as a file's). A refusal
// must say why in printable text; a scene that loads must hold finite
// material parameters. A scene on a small generated box or grid whose
// steps are bounded (XPBD substeps x iterations, Newton x CG iterations)
// is then built and stepped a few times: a refusal or a failed step must
// say why in printable text, and a step that succeeds must leave a finite
// state (sim.h, ek_sim_step; issue 28). Mesh files are not loaded (a scene
// may name any path); the mesh readers have their own harnesses.
#include <ek/sim/sim.h>

#include "fuzz_common.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

// Elements and work per step up to which a loaded scene is also run.
#define FUZZ_MAX_ELEMENTS 512
#define FUZZ_MAX_SWEEPS 10000L
#define FUZZ_MAX_PRODUCTS 100000L

static void run_scene(const ek_scene *s) {
  const double elements = s->triangles ? 2.0 * s->grid_cells[0] * s->grid_cells[1]
                                       : 6.0 * s->box_cells[0] * s->box_cells[1] * s->box_cells[2];
  if (s->mesh_file[0] || elements > FUZZ_MAX_ELEMENTS ||
      (double)s->xpbd.substeps * (double)s->xpbd.iterations > FUZZ_MAX_SWEEPS ||
      (double)s->implicit.max_newton * (double)s->implicit.max_cg > FUZZ_MAX_PRODUCTS)
    return;
  ek_mesh *mesh = NULL;
  ek_trimesh *tm = NULL;
  ek_sim *sim = NULL;
  if (s->triangles && (tm = ek_scene_trimesh(s)))
    sim = ek_sim_create_cloth(s, tm);
  else if (!s->triangles && (mesh = ek_scene_mesh(s)))
    sim = ek_sim_create(s, mesh);
  if (!sim)
    fuzz_check_message(ek_last_error());
  for (int n = 0; sim && n < 3; n++) {
    if (ek_sim_step(sim) != 0) {
      fuzz_check_message(ek_last_error());
      break;
    }
    const size_t n3 = 3 * (tm ? ek_trimesh_nverts(tm) : ek_mesh_nverts(mesh));
    for (size_t i = 0; i < n3; i++)
      if (!isfinite(ek_sim_positions(sim)[i]) || !isfinite(ek_sim_velocities(sim)[i])) {
        fprintf(stderr, "fuzz: step %d succeeded with a non-finite state at %zu\n", n, i);
        abort();
      }
  }
  const char *w = sim ? ek_sim_warning(sim) : NULL;
  if (w)
    fuzz_check_message(w);
  ek_sim_destroy(sim);
  ek_mesh_destroy(mesh);
  ek_trimesh_destroy(tm);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  char path[300];
  fuzz_write(fuzz_path("scene.json", path, sizeof path), data, size);
  ek_scene s;
  int rc = ek_scene_load(path, &s);
  if (rc == 0) {
    if (!isfinite(s.material.mu) || !isfinite(s.material.lambda) || !(s.dt > 0) ||
        !isfinite(s.dt) || !(s.density > 0) || !isfinite(s.density)) {
      fprintf(stderr, "fuzz: scene loaded with mu %g lambda %g dt %g density %g\n", s.material.mu,
              s.material.lambda, s.dt, s.density);
      abort();
    }
    run_scene(&s);
  } else {
    const char *err = ek_last_error();
    fuzz_check_message(err);
    // A scene that parsed is refused at a place in the text: the position
    // scan agrees with cJSON's tree (sim/scene.c), and invalid JSON is
    // placed too. (Out of memory goes without.)
    int line, col;
    size_t n = strlen(path);
    if (!strncmp(err, path, n) && err[n] == ':' && !strstr(err, "NUL byte") &&
        !strstr(err, "out of memory") && !strstr(err, "larger than 1 MiB") &&
        sscanf(err + n, ":%d:%d: ", &line, &col) != 2) {
      fprintf(stderr, "fuzz: a scene error without its line and column: %s\n", err);
      abort();
    }
  }
  return 0;
}
