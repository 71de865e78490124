// Internal: the vertices and tets of ek_mesh_box (sim/mesh.c), written once
// for it and for ek_testing's box (verify/check_box.c), which builds the
// same mesh for kernel tests that do not link libek_sim. Header-only, as
// text_escape.h: nothing to link.
#ifndef EK_SIM_MESH_BOX_H
#define EK_SIM_MESH_BOX_H

#include <ek/core.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>

// Kuhn (Freudenthal) split of each cube into 6 tets around the diagonal
// from corner 0 to corner 7: one tet per permutation of the axes, the path
// 0 -> e_a -> e_a+e_b -> 7. All cubes use the same split, so shared faces
// are cut along the same diagonal and the mesh is conforming. Odd
// permutations are listed with vertices 1 and 2 swapped so all volumes are
// positive.
//
// nx x ny x nz cubes (each >= 1) spanning [0, lx] x [0, ly] x [0, lz]
// (sizes finite and > 0: the caller checks both): *X (nverts x 3) and *T
// (ntets x 4) malloc'd, the caller frees them. 0, EK_EINVAL when the box
// is too large for int32 indices, or EK_ENOMEM (*X and *T NULL).
static inline int mesh_box_arrays(int nx, int ny, int nz, double lx, double ly, double lz,
                                  double **X, int32_t **T, size_t *nverts, size_t *ntets) {
  *X = NULL;
  *T = NULL;
  size_t px = (size_t)nx + 1, py = (size_t)ny + 1, pz = (size_t)nz + 1;
  size_t nv = px * py * pz, ncubes = (size_t)nx * ny * nz;
  if (nv > INT32_MAX || ncubes > (size_t)INT32_MAX / 24)
    return EK_EINVAL;
  double *x = malloc(nv * 3 * sizeof(double));
  int32_t *tets = malloc(ncubes * 6 * 4 * sizeof(int32_t));
  if (!x || !tets) {
    free(x);
    free(tets);
    return EK_ENOMEM;
  }
  for (size_t k = 0; k < pz; k++)
    for (size_t j = 0; j < py; j++)
      for (size_t i = 0; i < px; i++) {
        size_t v = (k * py + j) * px + i;
        x[v * 3 + 0] = lx * (double)i / nx;
        x[v * 3 + 1] = ly * (double)j / ny;
        x[v * 3 + 2] = lz * (double)k / nz;
      }
  // Corner c of a cube: bit 0 = +x, bit 1 = +y, bit 2 = +z. The tet of
  // the axis permutation (a, b, c) has Dm = [e_a, e_a+e_b, 7] whose
  // determinant is the permutation's sign, so odd permutations get
  // corners 1 and 2 swapped to keep det Dm > 0.
  // Path corners for each axis permutation (a, b, c): 0, e_a, e_a + e_b, 7.
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
          int32_t *tv = tets + t * 4;
          tv[0] = corner[0];
          tv[1] = corner[p >= 3 ? ab : a]; // odd permutation: 1 and 2 swapped
          tv[2] = corner[p >= 3 ? a : ab];
          tv[3] = corner[7];
        }
      }
  *X = x;
  *T = tets;
  *nverts = nv;
  *ntets = ncubes * 6;
  return 0;
}

#endif
