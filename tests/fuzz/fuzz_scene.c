// libFuzzer harness: the scene reader (JSON through cJSON). An input is the
// scene file, loaded with ek_scene_load (so NUL bytes and sizes are seen as
// a file's). A refusal must say why in printable text; a scene that loads
// must hold finite material parameters. Meshes are not loaded (a scene may
// name any path or a 4096^3 box); the mesh readers have their own
// harnesses.
#include <ek/sim.h>

#include "fuzz_common.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  char path[300];
  fuzz_write(fuzz_path("scene.json", path, sizeof path), data, size);
  ek_scene s;
  char err[1024] = "";
  int rc = ek_scene_load(path, &s, err, sizeof err);
  if (rc == 0) {
    if (!isfinite(s.material.mu) || !isfinite(s.material.lambda) || !(s.dt > 0) ||
        !isfinite(s.dt) || !(s.density > 0) || !isfinite(s.density)) {
      fprintf(stderr, "fuzz: scene loaded with mu %g lambda %g dt %g density %g\n", s.material.mu,
              s.material.lambda, s.dt, s.density);
      abort();
    }
  } else {
    fuzz_check_message(err);
  }
  return 0;
}
