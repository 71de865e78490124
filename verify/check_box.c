// A box of tets at the kernel level (check_box.h): ek_mesh_box's vertices
// and tets (sim/mesh.c), without the simulation library.
#include "check_box.h"

#include <ek/core.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

int ek_check_box_create(ek_check_box *b, int nx, int ny, int nz, double lx, double ly, double lz) {
  memset(b, 0, sizeof *b);
  if (nx < 1 || ny < 1 || nz < 1 || !(lx > 0 && isfinite(lx)) || !(ly > 0 && isfinite(ly)) ||
      !(lz > 0 && isfinite(lz)))
    return EK_EINVAL;
  size_t px = (size_t)nx + 1, py = (size_t)ny + 1, pz = (size_t)nz + 1;
  size_t nverts = px * py * pz, ncubes = (size_t)nx * ny * nz;
  if (nverts > INT32_MAX || ncubes > (size_t)INT32_MAX / 24)
    return EK_EINVAL;
  double *X = malloc(nverts * 3 * sizeof(double));
  int32_t *T = malloc(ncubes * 6 * 4 * sizeof(int32_t));
  if (!X || !T) {
    free(X);
    free(T);
    return EK_ENOMEM;
  }
  // The same coordinates as ek_mesh_box: l * i / n, bit for bit.
  for (size_t k = 0; k < pz; k++)
    for (size_t j = 0; j < py; j++)
      for (size_t i = 0; i < px; i++) {
        size_t v = (k * py + j) * px + i;
        X[v * 3 + 0] = lx * (double)i / nx;
        X[v * 3 + 1] = ly * (double)j / ny;
        X[v * 3 + 2] = lz * (double)k / nz;
      }
  // Kuhn (Freudenthal) split around the cube's diagonal from corner 0 to
  // corner 7 (bit 0 = +x, bit 1 = +y, bit 2 = +z): one tet per axis
  // permutation (a, b, c), the path 0 -> e_a -> e_a + e_b -> 7; odd
  // permutations swap corners 1 and 2 so that det Dm > 0. Same order as
  // ek_mesh_box.
  static const int perms[6][3] = {{0, 1, 2}, {1, 2, 0}, {2, 0, 1}, {0, 2, 1}, {1, 0, 2}, {2, 1, 0}};
  size_t t = 0;
  for (size_t k = 0; k < (size_t)nz; k++)
    for (size_t j = 0; j < (size_t)ny; j++)
      for (size_t i = 0; i < (size_t)nx; i++) {
        int32_t corner[8];
        for (int c = 0; c < 8; c++)
          corner[c] =
              (int32_t)(((k + (c >> 2 & 1)) * py + (j + (c >> 1 & 1))) * px + (i + (c & 1)));
        for (int p = 0; p < 6; p++, t++) {
          int a = 1 << perms[p][0], ab = a | 1 << perms[p][1];
          int32_t *tv = T + t * 4;
          tv[0] = corner[0];
          tv[1] = corner[p >= 3 ? ab : a];
          tv[2] = corner[p >= 3 ? a : ab];
          tv[3] = corner[7];
        }
      }
  ek_tets *el = ek_tets_create(nverts, X, ncubes * 6, T);
  if (!el) {
    free(X);
    free(T);
    return EK_EINVAL;
  }
  *b = (ek_check_box){nverts, ncubes * 6, X, T, el};
  return 0;
}

void ek_check_box_destroy(ek_check_box *b) {
  if (!b)
    return;
  ek_tets_destroy(b->el);
  free(b->X);
  free(b->T);
  memset(b, 0, sizeof *b);
}
