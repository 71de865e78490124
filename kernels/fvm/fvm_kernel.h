// Internal: arguments of the FVM block kernels (kernels/fvm/fvm_block.c),
// shared by the kernel and its driver (kernels/fvm/fvm.c). One struct per
// precision because the packed mesh planes and positions are in the working
// precision.
//
// Blocks: AoSoA blocks of one of the element layer's slot orders
// (kernels/elements/tets.h),
// EK_LANES_F32 = 16 or EK_LANES_F64 = 8 tets per block; block b of the
// packed planes: idx[(b*4 + c)*L + l], dm_inv[(b*9 + k)*L + l], v0[b*L + l].
// Padding lanes have idx = -1; they are computed with F = I and never
// written through.
//
// What one call does for blocks [b0, b1):
//   P_in == NULL: gather x, F = Ds Dm^-1, P = material_pk1(F);
//   P_in != NULL: read P from P_in (9 planes per block; phase-split mode);
//   R_warm != NULL (fixed corotated, ARAP, no clamp): R from the warm polar
//   of F seeded with the tet's state rotation, written back to the state
//   (each tet's state is touched by the one call that owns its block), and
//   P = 2 mu (F - R) + lambda (J - 1) cof(F): no SVD;
//   then H = -V0 P Dm^-T (Teran et al. 2003 sec. 4) and
//   f != NULL:      add h1..h3 and -(h1+h2+h3) into f (caller vertex order,
//                   nverts x fstride, fstride 3 or 4), lane by lane in lane order; the caller
//                   guarantees no other thread touches those vertices;
//   corner != NULL: write the corner forces into corner[(b*12 + c*3 + i)*L
//                   + l] (corner c = 0..3, component i) instead.
#ifndef EK_FVM_KERNEL_H
#define EK_FVM_KERNEL_H

#include <ek/material.h>
#include <stddef.h>
#include <stdint.h>

#include "../kernels.h"

struct ek_fvm_args_f32 {
  const int32_t *idx;
  const float *dm_inv;
  const float *v0;
  const int32_t *slot_tet; // slot -> caller tet (for R), -1 = padding
  // Corotated linear's R: R_planes (per-element state, 9 planes, Morton
  // slots; morton_slot maps a caller tet to its slot) when set, else R
  // (ntets x 9, caller order). R_direct: these blocks are the Morton order,
  // so block b's rotations are R_planes' block b.
  const double *R;
  const float *R_planes;
  const int32_t *morton_slot;
  int R_direct;
  const ek_material *mat;
  const ek_svd3_knobs *svd;
  // Fixed corotated / ARAP with the warm-started polar: per-element
  // rotations (9 planes, Morton slots like R_planes), read as the guess and
  // overwritten with the new rotation; NULL: the SVD. polar_iters >= 1.
  float *R_warm;
  int polar_iters;
  const float *x;
  const float *P_in;
  int prefetch; // 1: prefetch the next group's vertex rows (fvm_vec.h)
  float *f;
  int fstride; // floats per vertex row of f: 3, or 4 (padded thread buffers: scatter.h)
  float *corner;
};

struct ek_fvm_args_f64 {
  const int32_t *idx;
  const double *dm_inv;
  const double *v0;
  const int32_t *slot_tet;
  const double *R;
  const double *R_planes;
  const int32_t *morton_slot;
  int R_direct;
  const ek_material *mat;
  const ek_svd3_knobs *svd;
  double *R_warm;
  int polar_iters;
  const double *x;
  const double *P_in;
  int prefetch; // 1: prefetch the next group's vertex rows (fvm_vec.h)
  double *f;
  int fstride;
  double *corner;
};

#endif
