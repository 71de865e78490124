// libFuzzer harness: the triangle mesh readers (OBJ and Gmsh 2D, sim/mesh_tri.c).
// An input is the file; its last byte's low bit picks the format (1: .obj,
// 0: .msh). A mesh that loads must be whole: at least one triangle, indices
// in range, finite rest positions and triangles of positive finite area; a
// refusal must say why in printable text. ASan, UBSan and leak checks do
// the rest.
#include <ek/sim/trimesh.h>

#include "fuzz_common.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void check_trimesh(const ek_trimesh *m) {
  size_t nv = ek_trimesh_nverts(m), nt = ek_trimesh_ntris(m);
  const double *X = ek_trimesh_rest_positions(m);
  const int32_t *T = ek_trimesh_tris(m);
  if (nt == 0) {
    fprintf(stderr, "fuzz: a triangle mesh with no triangles loaded\n");
    abort();
  }
  for (size_t i = 0; i < 3 * nv; i++)
    if (!isfinite(X[i])) {
      fprintf(stderr, "fuzz: vertex %zu loaded with coordinate %g\n", i / 3, X[i]);
      abort();
    }
  for (size_t t = 0; t < nt; t++) {
    const int32_t *c = T + 3 * t;
    for (int k = 0; k < 3; k++)
      if (c[k] < 0 || (size_t)c[k] >= nv) {
        fprintf(stderr, "fuzz: triangle %zu loaded with vertex index %d of %zu\n", t, c[k], nv);
        abort();
      }
    const double *a = X + 3 * c[0], *b = X + 3 * c[1], *d = X + 3 * c[2];
    double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    double e2[3] = {d[0] - a[0], d[1] - a[1], d[2] - a[2]};
    double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                   e1[0] * e2[1] - e1[1] * e2[0]};
    double twoA = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (!(twoA > 0) || !isfinite(twoA)) {
      fprintf(stderr, "fuzz: triangle %zu loaded with 2 x area %g\n", t, twoA);
      abort();
    }
  }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  char path[300];
  int obj = size ? data[size - 1] & 1 : 1;
  fuzz_write(fuzz_path(obj ? "m.obj" : "m.msh", path, sizeof path), data, size);
  ek_trimesh *m = ek_trimesh_load(path);
  if (m)
    check_trimesh(m);
  else
    fuzz_check_message(ek_last_error());
  ek_trimesh_destroy(m);
  return 0;
}
