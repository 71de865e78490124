// Internal: arguments of the cloth force block kernels
// (kernels/cloth_force/cloth_force_block.c), shared with their driver
// (cloth_force.c) and the element layer (kernels/elements/tris.c). One
// struct per precision because the packed planes and positions are in the
// working precision.
//
// Blocks: AoSoA blocks of EK_LANES_F32 = 16 / EK_LANES_F64 = 8 triangles
// (hinges) in the caller's order. Triangle block b: idx[(b*3 + c)*L + l],
// dm_inv[(b*4 + k)*L + l] (row-major 2x2), area[b*L + l]; hinge block b:
// idx[(b*4 + c)*L + l], k[(b*4 + c)*L + l]. Padding lanes have idx = -1,
// Dm^-1 = I, area 0 and k = 0: their corners are 0 and never read.
//
// What one call does for blocks [b0, b1): the corner forces of each
// element into corner[(b*nc*3 + c*3 + i)*L + l] (nc = 3 corners per
// triangle, 4 per hinge; component i); the membrane Hessian kernel its
// corner products (H dx) in the same layout, the energy kernel one value
// per triangle.
#ifndef EK_CLOTH_FORCE_KERNEL_H
#define EK_CLOTH_FORCE_KERNEL_H

#include <ek/cloth_force.h>
#include <stddef.h>
#include <stdint.h>

#include "../kernels.h"

struct ek_cloth_force_args_f32 {
  const int32_t *tri_idx, *hinge_idx;
  const float *dm_inv, *area, *hinge_k;
  ek_membrane_model model;
  float mu, lambda, bending;
  const float *x;
  float *tri_corner, *hinge_corner;
  // The membrane energy and Hessian kernels (cloth_membrane_block.c):
  // tri_energy[b*L + l] = A Psi(F) per triangle; dx (nverts x 3) the
  // direction of the Hessian product, its corners into tri_corner;
  // project: the projected Hessian (cloth_force.h).
  const float *dx;
  float *tri_energy;
  int project;
};

struct ek_cloth_force_args_f64 {
  const int32_t *tri_idx, *hinge_idx;
  const double *dm_inv, *area, *hinge_k;
  ek_membrane_model model;
  double mu, lambda, bending;
  const double *x;
  double *tri_corner, *hinge_corner;
  // The membrane energy and Hessian kernels (cloth_membrane_block.c):
  // tri_energy[b*L + l] = A Psi(F) per triangle; dx (nverts x 3) the
  // direction of the Hessian product, its corners into tri_corner;
  // project: the projected Hessian (cloth_force.h).
  const double *dx;
  double *tri_energy;
  int project;
};

#endif
