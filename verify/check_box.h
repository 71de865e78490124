// ek_testing: a box of tets at the kernel level, for kernel tests that link
// libek and ek_testing only (no libek_sim, HDF5 or cJSON).
//
// ek_check_box_create builds the same vertices and tets, in the same order,
// as the simulation library's ek_mesh_box, from the same code
// (sim/mesh_box.h: a Kuhn split of each cube into 6 positively oriented
// tets), as plain arrays, and the element layer the kernels read
// (ek_tets_create, elements.h). A test that moved from ek_mesh_box sees
// the same mesh.
#ifndef EK_CHECK_BOX_H
#define EK_CHECK_BOX_H

#include <stddef.h>
#include <stdint.h>

#include <ek/elements.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct {
  size_t nverts, ntets;
  double *X;   // nverts x 3 rest positions
  int32_t *T;  // ntets x 4 vertex indices (caller order)
  ek_tets *el; // the element layer of (X, T)
} ek_check_box;

// nx x ny x nz cubes spanning [0, lx] x [0, ly] x [0, lz]. 0, or on
// failure (*b zeroed): EK_EINVAL for counts < 1, sizes not finite and > 0
// or a box too large, EK_ENOMEM, or ek_tets_create's error (message in
// ek_last_error).
int ek_check_box_create(ek_check_box *b, int nx, int ny, int nz, double lx, double ly, double lz);
void ek_check_box_destroy(ek_check_box *b);

#ifdef __cplusplus
}
#endif
#endif
