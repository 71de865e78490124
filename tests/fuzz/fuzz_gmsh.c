// libFuzzer harness: the Gmsh .msh reader (ASCII v2 and v4). An input is
// the file; its last byte's low bit sets fix_orientation. A mesh that loads
// must be whole (fuzz_check_mesh); a refusal must say why in printable
// text. ASan, UBSan and leak checks do the rest.
#include "fuzz_common.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  char path[300];
  fuzz_write(fuzz_path("m.msh", path, sizeof path), data, size);
  ek_mesh_opts opts = {.fix_orientation = size ? data[size - 1] & 1 : 0};
  ek_mesh *m = ek_mesh_load_ex(path, &opts);
  if (m)
    fuzz_check_mesh(m);
  else
    fuzz_check_message(ek_last_error());
  ek_mesh_destroy(m);
  return 0;
}
